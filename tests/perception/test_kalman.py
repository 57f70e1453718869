"""Chain of integrators, vectorised Kalman filter and RTS smoother (eq. 9.1-9.5, 8.3, 8.6)."""

import numpy as np
import pytest

from hrc_drake.perception.kalman import ChainOfIntegrators, KalmanFilter, rts_smooth


def test_jerk_chain_matrices_match_eq_9_2_and_9_3():
    dt, sigma = 0.1, 2.0
    m = ChainOfIntegrators(order=4, dt=dt, sigma=sigma, dim=3)
    i3 = np.eye(3)
    expected_a = np.block([
        [i3, dt * i3, dt**2 / 2 * i3, dt**3 / 6 * i3],
        [0 * i3, i3, dt * i3, dt**2 / 2 * i3],
        [0 * i3, 0 * i3, i3, dt * i3],
        [0 * i3, 0 * i3, 0 * i3, i3],
    ])
    np.testing.assert_allclose(m.A, expected_a)
    expected_w = np.diag(np.repeat([dt**4 / 24, dt**3 / 6, dt**2 / 2, dt], 3)) * sigma**2
    np.testing.assert_allclose(m.W, expected_w)
    np.testing.assert_allclose(m.C, np.hstack([i3, np.zeros((3, 9))]))


def test_three_integrator_chain_and_per_block_sigma():
    m = ChainOfIntegrators(order=3, dt=0.5, sigma=[1.0, 2.0, 3.0], dim=1)
    np.testing.assert_allclose(m.A, [[1, 0.5, 0.125], [0, 1, 0.5], [0, 0, 1]])
    np.testing.assert_allclose(np.diag(m.W), [0.5**3 / 6, 4 * 0.5**2 / 2, 9 * 0.5])


@pytest.mark.parametrize("kwargs", [dict(order=0), dict(dt=0.0), dict(sigma=[1.0, 2.0]), dict(sigma=-1.0)])
def test_bad_model_parameters_raise(kwargs):
    with pytest.raises(ValueError):
        ChainOfIntegrators(**kwargs)


def _naive_kf(model, ys, meas_std, p0):
    """Textbook single-track KF, the reference for the vectorised one."""
    x = np.zeros(model.state_size)
    x[: model.dim] = ys[0]
    p = p0.copy()
    out = [x.copy()]
    r = meas_std**2 * np.eye(model.dim)
    for y in ys[1:]:
        x = model.A @ x
        p = model.A @ p @ model.A.T + model.W
        if np.all(np.isfinite(y)):
            s = model.C @ p @ model.C.T + r
            k = p @ model.C.T @ np.linalg.inv(s)
            x = x + k @ (y - model.C @ x)
            p = (np.eye(len(x)) - k @ model.C) @ p
        out.append(x.copy())
    return np.array(out), p


def test_vectorised_kf_equals_textbook_kf_per_track():
    rng = np.random.default_rng(0)
    model = ChainOfIntegrators(order=4, dt=1 / 30, sigma=20.0, dim=3)
    kf = KalmanFilter(model, n_tracks=3, measurement_std=0.02, initial_std=0.5)
    ys = rng.normal(size=(20, 3, 3)).cumsum(axis=0) * 0.01
    ys[5:9, 1] = np.nan  # track 1 occluded for 4 frames
    means, covs = kf.filter_sequence(ys)
    for t in range(3):
        ref, p_ref = _naive_kf(model, ys[:, t], 0.02, kf._initial_cov)
        np.testing.assert_allclose(means[:, t], ref, atol=1e-10)
        np.testing.assert_allclose(covs[-1, t], p_ref, atol=1e-12)


def test_open_loop_under_occlusion_grows_covariance_and_extrapolates():
    model = ChainOfIntegrators(order=4, dt=0.1, sigma=1.0, dim=3)
    kf = KalmanFilter(model, n_tracks=2, measurement_std=0.001, initial_std=1.0)
    velocity = np.array([0.5, 0.0, -0.2])
    for k in range(40):
        kf.step(np.stack([velocity * 0.1 * k, np.zeros(3)]))
    traces = []
    for _ in range(10):
        kf.step(np.zeros((2, 3)), mask=np.array([False, True]))
        traces.append(np.trace(kf.position_covariances[0]))
    assert np.all(np.diff(traces) > 0)
    # The constant-velocity track keeps moving at its velocity while occluded.
    np.testing.assert_allclose(kf.positions[0], velocity * 0.1 * 49, atol=5e-3)
    assert np.trace(kf.position_covariances[1]) < 1e-5


def test_measurement_shape_error():
    kf = KalmanFilter(ChainOfIntegrators(), n_tracks=8)
    with pytest.raises(ValueError, match="shape"):
        kf.update(np.zeros((7, 3)))


def test_ellipsoid_axes_and_box_fraction():
    model = ChainOfIntegrators(order=2, dt=0.1, sigma=1.0, dim=3)
    kf = KalmanFilter(model, n_tracks=1, measurement_std=0.1)
    kf.update(np.zeros((1, 3)))
    kf.P_[0, :3, :3] = np.diag([0.04, 0.01, 0.01])
    centers, semi, axes = kf.ellipsoid(0.9)
    np.testing.assert_allclose(np.sort(semi[0]), np.sort(np.sqrt([0.04, 0.01, 0.01]) * np.sqrt(6.2513886)),
                               rtol=1e-6)
    assert kf.ellipsoid_fraction_in_box([0, 0, 0], [10, 10, 10])[0] == 1.0
    assert kf.ellipsoid_fraction_in_box([5, 0, 0], [1, 1, 1])[0] == 0.0
    half = kf.ellipsoid_fraction_in_box([5, 0, 0], [10, 10, 10])[0]  # the x >= 0 half
    assert abs(half - 0.5) < 0.06


def test_rts_equals_batch_gaussian_posterior():
    rng = np.random.default_rng(3)
    model = ChainOfIntegrators(order=2, dt=0.2, sigma=[0.3, 1.5], dim=1)
    kf = KalmanFilter(model, n_tracks=1, measurement_std=0.1, initial_std=0.7)
    k_steps = 7
    ys = np.cumsum(rng.normal(size=k_steps)).reshape(k_steps, 1, 1) * 0.2
    ys[3] = np.nan
    means, covs = kf.filter_sequence(ys)
    sm_x, sm_p = rts_smooth(model, means, covs)
    # Information form of the whole window: prior on x0, transitions, measurements k >= 1.
    s = model.state_size
    lam = np.zeros((k_steps * s, k_steps * s))
    eta = np.zeros(k_steps * s)
    p0 = kf._initial_cov
    x0 = np.array([ys[0, 0, 0], 0.0])
    lam[:s, :s] += np.linalg.inv(p0)
    eta[:s] += np.linalg.inv(p0) @ x0
    wi = np.linalg.inv(model.W)
    a = model.A
    for k in range(k_steps - 1):
        i, j = slice(k * s, (k + 1) * s), slice((k + 1) * s, (k + 2) * s)
        lam[i, i] += a.T @ wi @ a
        lam[i, j] -= a.T @ wi
        lam[j, i] -= wi @ a
        lam[j, j] += wi
    c = model.C
    for k in range(1, k_steps):
        if np.isfinite(ys[k, 0, 0]):
            i = slice(k * s, (k + 1) * s)
            lam[i, i] += c.T @ c / 0.01
            eta[i] += c.T @ ys[k, 0] / 0.01
    cov = np.linalg.inv(lam)
    mean = cov @ eta
    np.testing.assert_allclose(sm_x[:, 0].ravel(), mean, atol=1e-9)
    for k in range(k_steps):
        np.testing.assert_allclose(sm_p[k, 0], cov[k * s:(k + 1) * s, k * s:(k + 1) * s], atol=1e-9)
    np.testing.assert_allclose(sm_x[-1], means[-1])


def test_rts_rejects_bad_shapes_and_nan():
    model = ChainOfIntegrators(order=2, dim=1)
    with pytest.raises(ValueError):
        rts_smooth(model, np.zeros((4, 3)), np.zeros((4, 3, 3)))
    covs = np.broadcast_to(np.eye(2), (4, 2, 2)).copy()
    means = np.zeros((4, 2))
    means[1, 0] = np.nan
    with pytest.raises(ValueError, match="finite"):
        rts_smooth(model, means, covs)


def _fractions_from_every_sample(kf, center, size, confidence):
    """Both fractions of 9.1.3 the long way: every ball sample and every grid point, no shortcut."""
    from hrc_drake.perception.kalman import _BALL_SAMPLES, _box_grid, chi2_quantile, unit_ball_samples

    m, semi, axes = kf.ellipsoid(confidence)
    ball = unit_ball_samples(_BALL_SAMPLES, 3)
    pts = m[:, None, :] + np.einsum("tij,nj->tni", axes * semi[:, None, :], ball)
    in_box = np.all(np.abs(pts - center) <= 0.5 * size, axis=2).mean(axis=1)
    grid = center + _box_grid(3) * size
    cov = kf.position_covariances + 1e-15 * np.eye(3)
    offset = grid[None] - kf.positions[:, None, :]
    m2 = np.einsum("tnd,tnd->tn", offset, np.linalg.solve(cov, np.swapaxes(offset, 1, 2)).swapaxes(1, 2))
    return in_box, (m2 <= chi2_quantile(confidence, 3)).mean(axis=1)


def test_the_bounding_box_shortcuts_give_the_fractions_of_every_sample():
    rng = np.random.default_rng(4)
    decided = 0
    for _ in range(60):
        kf = KalmanFilter(ChainOfIntegrators(order=int(rng.integers(1, 5))), n_tracks=8)
        points = rng.uniform(-1, 1, (8, 3))
        kf.update(points, np.ones(8, dtype=bool))
        for _ in range(int(rng.integers(0, 30))):
            kf.predict(1)
            kf.update(points + rng.normal(0, 0.02, (8, 3)), rng.random(8) < 0.5)
        center, size = rng.uniform(-0.5, 0.5, 3), rng.uniform(0.05, 1.5, 3)
        in_box, box_in = _fractions_from_every_sample(kf, center, size, 0.9)
        np.testing.assert_array_equal(kf.ellipsoid_fraction_in_box(center, size, 0.9), in_box)
        np.testing.assert_array_equal(kf.box_fraction_in_ellipsoid(center, size, 0.9), box_in)
        some = rng.random(8) < 0.5
        np.testing.assert_array_equal(kf.box_fraction_in_ellipsoid(center, size, 0.9, tracks=some),
                                      np.where(some, box_in, 0.0))
        decided += np.sum((in_box == 0) | (in_box == 1))
    assert decided > 100  # the shortcuts' cases occur
