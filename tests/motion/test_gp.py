import numpy as np
import pytest
from sklearn.gaussian_process import GaussianProcessRegressor

from hrc_drake.motion.gp import (
    GPMotionModel,
    kernel_8_7,
    kernel_theta,
    log_marginal_likelihood,
    motion_kernel,
)


def test_kernel_equals_eq_8_7():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(6, 4))
    theta = np.array([0.3, 0.7, 1.9, 0.05])
    kernel = motion_kernel(*theta)
    expected = np.empty((6, 6))
    for i in range(6):
        for j in range(6):
            rbf = np.exp(-theta[1] / 2 * np.sum((x[i] - x[j]) ** 2))
            expected[i, j] = theta[0] * x[i] @ x[j] + theta[2] * rbf + theta[3] * (i == j)
    np.testing.assert_allclose(kernel(x), expected, rtol=1e-12)
    ours = kernel_8_7(x, x, theta) + theta[3] * np.eye(6)
    np.testing.assert_allclose(ours, expected, rtol=1e-12)
    np.testing.assert_allclose(kernel_theta(kernel), theta)
    with pytest.raises(ValueError, match="theta2"):
        motion_kernel(1.0, -1.0, 1.0, 1.0)


def test_likelihood_matches_scikit_learn_and_its_gradient():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(30, 3))
    y = np.column_stack([np.sin(x[:, 0]), x[:, 1] * 0.5]) + 0.05 * rng.normal(size=(30, 2))
    theta = np.array([0.2, 0.8, 1.1, 0.03])
    gram = x @ x.T
    sq = ((x[:, None] - x[None]) ** 2).sum(-1)
    value, gradient = log_marginal_likelihood(np.log(theta), gram, sq, y)
    regressor = GaussianProcessRegressor(motion_kernel(*theta), alpha=1e-8, optimizer=None).fit(x, y)
    assert value == pytest.approx(regressor.log_marginal_likelihood_value_, rel=1e-6)
    step = 1e-6
    numeric = [(log_marginal_likelihood(np.log(theta) + step * e, gram, sq, y)[0] - value) / step
               for e in np.eye(4)]
    np.testing.assert_allclose(gradient, numeric, rtol=1e-3, atol=1e-3)


def _constant_velocity_windows(order, velocity, dt=0.05, n=60, n_dof=12, seed=0):
    """Windows of P+1 states of joints moving at constant velocities (q'' = 0)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n + order) * dt
    windows = []
    for start in rng.uniform(-1.0, 1.0, size=n):
        q = start + np.outer(t, velocity)
        phi = np.stack([q, np.broadcast_to(velocity, q.shape), np.zeros_like(q)], -1)
        k = rng.integers(0, n)
        windows.append(phi[k:k + order + 1])
    return np.array(windows)


@pytest.mark.parametrize("kind", ["gp_a", "gp_b", "gp_c"])
def test_models_learn_constant_velocity(kind):
    velocity = np.linspace(-0.6, 0.6, 12)
    windows = _constant_velocity_windows(2, velocity)
    model = GPMotionModel(kind, order=2, max_samples=60, random_state=0).fit(windows)
    assert model.theta_.shape == (len(model.groups), 4)
    history = windows[0, 1:]
    prediction = model.predict(history)
    expected_q = history[-1, :, 0] + velocity * 0.05
    np.testing.assert_allclose(prediction[:, 0], expected_q, atol=0.01)
    np.testing.assert_allclose(prediction[:, 1], velocity, atol=0.02)


def test_partial_fit_keeps_a_fixed_size_training_set():
    velocity = np.full(12, 0.2)
    windows = _constant_velocity_windows(1, velocity, n=40)
    model = GPMotionModel("gp_c", order=1, max_samples=25, random_state=3)
    model.partial_fit(windows[:20])
    assert model.n_samples_ == 20
    model.partial_fit(windows[20:30])
    assert model.n_samples_ == 25
    # the 10 new samples: 5 fill the set, 5 replace old ones
    kept = {tuple(np.round(y[:, 0], 9)) for y in model.Y_}
    assert sum(tuple(np.round(w[-1, :, 0], 9)) in kept for w in windows[20:30]) == 10
    assert sum(tuple(np.round(w[-1, :, 0], 9)) in kept for w in windows[:20]) == 15
    with pytest.raises(ValueError, match="windows must be"):
        model.partial_fit(windows[:, :1])


def test_rollouts_follow_constant_velocity():
    velocity = np.linspace(-0.5, 0.5, 12)
    windows = _constant_velocity_windows(2, velocity)
    model = GPMotionModel("gp_c", order=2, max_samples=60, random_state=0).fit(windows)
    history = windows[5, 1:]
    rollouts = model.sample_rollouts(history, steps=8, n_trials=30, rng=1)
    assert rollouts.shape == (30, 8, 12)
    expected = history[-1, :, 0] + np.outer(np.arange(1, 9) * 0.05, velocity)
    np.testing.assert_allclose(rollouts.mean(axis=0), expected, atol=0.05)
    again = model.sample_rollouts(history, steps=8, n_trials=30, rng=1)
    np.testing.assert_array_equal(rollouts, again)


def test_hyperparameters_reoptimised_only_every_kth_refit():
    rng = np.random.default_rng(4)
    t = np.arange(120) * 0.05
    q = np.stack([np.sin(t * (1.0 + 0.2 * j)) for j in range(12)], -1)
    q = q + rng.normal(scale=0.01, size=q.shape)
    phi = np.stack([q, np.gradient(q, axis=0), np.gradient(np.gradient(q, axis=0), axis=0)], -1)
    windows = np.stack([phi[k - 2:k + 1] for k in range(2, 120)])
    every = GPMotionModel("gp_c", order=2, max_samples=40, random_state=1)
    third = GPMotionModel("gp_c", order=2, max_samples=40, random_state=1, hyperparameter_every=3)
    thetas = {1: [], 3: []}
    for start in range(0, 100, 10):
        for model, key in ((every, 1), (third, 3)):
            model.partial_fit(windows[start:start + 10])
            thetas[key].append(model.theta_.copy())
    changed = [not np.array_equal(a, b) for a, b in zip(thetas[3][:-1], thetas[3][1:], strict=True)]
    assert changed == [k % 3 == 2 for k in range(9)]  # refits 3, 6, 9 (0-based) optimise
    assert all(not np.array_equal(a, b) for a, b in zip(thetas[1][:-1], thetas[1][1:], strict=True))
    # between optimisations the training set and its factorisation are still refreshed
    np.testing.assert_array_equal(third.X_, every.X_)
    assert not np.array_equal(third.buckets_[0]["alpha"], every.buckets_[0]["alpha"])
    with pytest.raises(ValueError, match="hyperparameter_every"):
        GPMotionModel("gp_c", hyperparameter_every=0)
