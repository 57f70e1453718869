import time

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from hrc_drake.motion.gpdm import GPDM, KAPPA, neg_log_posterior, pack, pair_indices

DIM = 9
_MAP = np.random.default_rng(42).normal(size=(DIM, 2))
_OFFSET = np.random.default_rng(43).normal(scale=0.3, size=DIM)
#: shoulder, elbow, wrist xyz of a resting arm (m): the map below moves around these
_REST = np.array([0.0, 0.2, 1.4, 0.05, 0.25, 1.1, 0.3, 0.3, 1.0])
_TURN = 2 * np.pi / 80
_A = 0.99 * np.array([[np.cos(_TURN), -np.sin(_TURN)], [np.sin(_TURN), np.cos(_TURN)]])


def observe(x: np.ndarray) -> np.ndarray:
    """A fixed smooth nonlinear map of 2-d latents (n, 2) to 9 arm coordinates (n, 9)."""
    return _REST + 0.3 * np.tanh(0.8 * x @ _MAP.T + _OFFSET)


def roll_out(x0: np.ndarray, length: int) -> np.ndarray:
    """The known latent dynamics, a decaying rotation x_{t+1} = A x_t, from x0: (length, 2)."""
    xs = [np.asarray(x0, dtype=float)]
    for _ in range(length - 1):
        xs.append(_A @ xs[-1])
    return np.array(xs)


def toy_data(seed: int = 7):
    """3 recorded realisations (different starts, lengths, noise), the noise-free mean trajectory and
    the noise-free realisations."""
    rng = np.random.default_rng(seed)
    starts = [np.array([1.0, 0.0]) + 0.05 * rng.normal(size=2) for _ in range(3)]
    lengths, noise = (58, 60, 62), (0.003, 0.005, 0.008)
    clean = [observe(roll_out(s, n)) for s, n in zip(starts, lengths, strict=True)]
    seqs = [c + e * rng.normal(size=c.shape) for c, e in zip(clean, noise, strict=True)]
    truth = observe(roll_out(np.mean(starts, axis=0), 60))
    return seqs, truth, clean


def spread(seqs) -> float:
    """The data's spread: root mean over the 9 coordinates of their variance."""
    return float(np.sqrt(np.concatenate(seqs).var(axis=0).mean()))


def rms(a, b) -> float:
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


@pytest.fixture(scope="module")
def fitted():
    seqs, truth, clean = toy_data()
    start = time.perf_counter()
    model = GPDM(latent_dim=2, random_state=0).fit(seqs)
    elapsed = time.perf_counter() - start
    print(f"\nGPDM fit: 3 sequences x ~60 poses, D = 9, d = 2: {elapsed:.3f} s, {model.n_iter_} iterations")
    return model, seqs, truth, clean


def _random_problem(seed=0):
    rng = np.random.default_rng(seed)
    lengths, dim, d = [4, 5, 3], 4, 2
    y = rng.normal(size=(sum(lengths), dim))
    y -= y.mean(0)
    x = rng.normal(size=(sum(lengths), d))
    alpha, beta, w = np.array([0.8, 1.3, 0.2, 5.0]), np.array([0.7, 20.0]), rng.uniform(0.5, 2.0, dim)
    return y, lengths, x, alpha, beta, w


def test_gradient_matches_finite_differences():
    y, lengths, x, alpha, beta, w = _random_problem()
    theta = pack(x, alpha, beta, w)
    value, grad = neg_log_posterior(theta, y, lengths, 2, dynamics_weight=1.7)
    step = 1e-6
    numeric = np.empty_like(theta)
    for i in range(len(theta)):
        e = np.zeros_like(theta)
        e[i] = step
        plus = neg_log_posterior(theta + e, y, lengths, 2, 1.7)[0]
        minus = neg_log_posterior(theta - e, y, lengths, 2, 1.7)[0]
        numeric[i] = (plus - minus) / (2 * step)
    assert np.isfinite(value)
    np.testing.assert_allclose(grad, numeric, rtol=1e-5, atol=1e-6 * np.abs(numeric).max())


def test_objective_is_the_negative_log_posterior_of_wang_et_al():
    """Value against Gaussian log densities built from the kernels entry by entry (Wang et al.)."""
    y, lengths, x, alpha, beta, w = _random_problem(1)
    n, dim = y.shape
    lam = 1.7
    value, _ = neg_log_posterior(pack(x, alpha, beta, w), y, lengths, 2, lam)
    i_in, i_out, starts = pair_indices(lengths)
    assert list(starts) == [0, 4, 9] and 3 not in i_in and 4 not in i_out and len(i_in) == n - 3
    k_y = np.array([[np.exp(-beta[0] / 2 * np.sum((a - b) ** 2)) for b in x] for a in x])
    k_y += np.eye(n) / beta[1]
    xi = x[i_in]
    k_x = np.array([[alpha[0] * np.exp(-alpha[1] / 2 * np.sum((a - b) ** 2)) + alpha[2] * a @ b for b in xi]
                    for a in xi]) + np.eye(len(xi)) / alpha[3]
    log_y = sum(multivariate_normal(np.zeros(n), k_y).logpdf(y[:, k] * w[k]) for k in range(dim))
    log_x = sum(multivariate_normal(np.zeros(len(xi)), k_x).logpdf(x[i_out, j]) for j in range(2))
    expected = (-log_y - n * np.log(w).sum() + (w**2).sum() / (2 * KAPPA**2) - lam * log_x
                + 0.5 * (x[starts] ** 2).sum() + np.log(alpha).sum() + np.log(beta).sum())
    constants = (n * dim + lam * len(xi) * 2) / 2 * np.log(2 * np.pi)
    assert value == pytest.approx(expected - constants, rel=1e-10)


def test_gpdm_recovers_a_known_latent_dynamics(fitted):
    model, seqs, truth, _ = fitted
    phi = model.regressed_trajectory()
    assert phi.shape == (60, DIM)  # the median training length
    error, scale = rms(phi, truth), spread(seqs)
    print(f"regressed trajectory (8.26): RMS {error * 1e3:.2f} mm = {100 * error / scale:.2f} % of spread")
    assert error < 0.1 * scale
    # a trivially wrong model, the constant trajectory at the data mean, fails the same criterion
    constant = np.broadcast_to(np.concatenate(seqs).mean(0), truth.shape)
    assert rms(constant, truth) > 0.5 * scale
    # so does the right path at the wrong speed (half the latent rotation rate)
    slow = truth[np.arange(60) // 2]
    assert rms(slow, truth) > 0.1 * scale


def test_one_step_dynamics_and_reconstruction_on_training_latents(fitted):
    model, seqs, _, clean = fitted
    for x, y in zip(model.latent_, clean, strict=True):
        step = np.linalg.norm(np.diff(x, axis=0), axis=1).mean()
        one_step = np.linalg.norm(model.predict_dynamics(x[:-1]) - x[1:], axis=1).mean()
        print(f"one-step dynamics error {100 * one_step / step:.2f} % of the mean latent step")
        assert one_step < 0.05 * step
        # the latents reconstruct the noise-free poses (noise 3-8 mm, spread ~120 mm)
        assert rms(model.predict_observation(x), y) < 0.05 * spread(seqs)
    assert model.alpha_.shape == (4,) and model.beta_.shape == (2,) and model.w_.shape == (DIM,)
    assert model.mean_ == pytest.approx(np.concatenate(seqs).mean(0))


def test_regressed_trajectory_follows_eq_8_26(fitted):
    model = fitted[0]
    phi, x = model.regressed_trajectory(length=15, return_latent=True)
    assert phi.shape == (15, DIM) and x.shape == (15, 2)
    np.testing.assert_allclose(x[0], np.mean([s[0] for s in model.latent_], axis=0))
    np.testing.assert_allclose(x[1:], model.predict_dynamics(x[:-1]), atol=1e-12)
    np.testing.assert_allclose(phi, model.predict_observation(x), atol=1e-12)
    mean, var = model.predict_observation(x, return_var=True)
    next_x, var_x = model.predict_dynamics(x, return_var=True)
    assert var.shape == (15, DIM) and var_x.shape == (15, 2)
    assert (var >= 0).all() and (var_x >= 0).all()
    # far from the data the observation GP reverts to the mean with its prior variance 1 / w^2
    far_mean, far_var = model.predict_observation(np.full((1, 2), 1e3), return_var=True)
    np.testing.assert_allclose(far_mean[0], model.mean_, atol=1e-9)
    np.testing.assert_allclose(far_var[0], 1 / model.w_**2, rtol=1e-9)


def test_same_seed_same_model_and_generator_seeds():
    seqs = toy_data(3)[0]
    seqs = [s[:20] for s in seqs]
    a = GPDM(latent_dim=2, max_iter=30, random_state=5).fit(seqs)
    b = GPDM(latent_dim=2, max_iter=30, random_state=5).fit(seqs)
    c = GPDM(latent_dim=2, max_iter=30, random_state=np.random.default_rng(5)).fit(seqs)
    for other in (b, c):
        np.testing.assert_array_equal(a.regressed_trajectory(), other.regressed_trajectory())
        for xa, xo in zip(a.latent_, other.latent_, strict=True):
            np.testing.assert_array_equal(xa, xo)
    d = GPDM(latent_dim=2, max_iter=30, random_state=6).fit(seqs)
    assert not np.array_equal(a.latent_[0], d.latent_[0])
    e = GPDM(latent_dim=2, max_iter=30, jitter=0.0, random_state=1).fit(seqs)
    f = GPDM(latent_dim=2, max_iter=30, jitter=0.0, random_state=2).fit(seqs)
    np.testing.assert_array_equal(e.latent_[1], f.latent_[1])  # PCA alone is deterministic


@pytest.mark.parametrize(
    ("sequences", "kwargs", "match"),
    [
        ([], {}, "empty"),
        ([np.zeros((2, 9))], {}, "2 poses"),
        ([np.ones((5, 9)), np.ones((5, 8))], {}, "D = 8"),
        ([np.full((5, 9), np.nan)], {}, "NaN"),
        ([np.r_[np.ones((4, 9)), np.full((1, 9), np.inf)]], {}, "inf"),
        ([np.ones(9)], {}, "2-D"),
        (np.ones((5, 9)), {}, "list"),
        ([np.random.default_rng(0).normal(size=(5, 9))], {"latent_dim": 0}, "latent_dim"),
        ([np.random.default_rng(0).normal(size=(5, 9))], {"latent_dim": 10}, "latent_dim"),
        ([np.random.default_rng(0).normal(size=(5, 9))], {"max_iter": 0}, "max_iter"),
    ],
)
def test_bad_input_is_named(sequences, kwargs, match):
    with pytest.raises(ValueError, match=match):
        GPDM(**kwargs).fit(sequences)


def test_using_an_unfitted_model_is_an_error():
    model = GPDM(latent_dim=2)
    with pytest.raises(ValueError, match="not fitted"):
        model.regressed_trajectory()
    with pytest.raises(ValueError, match="not fitted"):
        model.predict_dynamics(np.zeros((1, 2)))


def test_prediction_inputs_are_checked(fitted):
    model = fitted[0]
    with pytest.raises(ValueError, match=r"\(n, 2\)"):
        model.predict_observation(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="length"):
        model.regressed_trajectory(length=0)
