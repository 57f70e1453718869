"""The compiled kernels against their numpy references (hrc_drake/kernels.py and each subpackage's
_kernels.py), and how they compile (lazily, per group, saying so once on a first run)."""

import numpy as np
import pytest

from hrc_drake import kernels
from hrc_drake.human import _kernels as human_kernels
from hrc_drake.human.body import BodyModel
from hrc_drake.human.camera import DepthCameraModel
from hrc_drake.intention import _kernels as intention_kernels
from hrc_drake.motion import _kernels as motion_kernels
from hrc_drake.motion import reactive
from hrc_drake.motion.geometry import segment_segment_closest
from hrc_drake.perception import _kernels as perception_kernels


def _random_capsules(rng, count):
    start = rng.uniform(-0.5, 0.5, size=(count, 3))
    end = start + rng.normal(scale=0.3, size=(count, 3))
    end[0] = start[0]  # a point-like capsule: the degenerate branch of Ericson 5.1.9
    radius = rng.uniform(0.01, 0.1, size=count)
    return start, end, radius


def test_capsule_clearances_equal_the_numpy_segment_distance_minus_radii():
    rng = np.random.default_rng(0)
    start_a, end_a, radius_a = _random_capsules(rng, 7)
    start_b, end_b, radius_b = _random_capsules(rng, 5)
    start_b[1], end_b[1] = start_a[2] + 0.1, end_a[2] + 0.1  # a parallel pair
    got = kernels.capsule_clearances(start_a, end_a, radius_a, start_b, end_b, radius_b)
    distance, _, _ = segment_segment_closest(start_a[:, None], end_a[:, None], start_b[None], end_b[None])
    expected = distance - radius_a[:, None] - radius_b[None, :]
    assert got.shape == (7, 5)
    np.testing.assert_allclose(got, expected, atol=1e-12)


def test_capsule_clearances_accept_read_only_strided_and_integer_inputs():
    rng = np.random.default_rng(1)
    start, end, radius = _random_capsules(rng, 6)
    reference = kernels.capsule_clearances(start, end, radius, start, end, radius)
    wide = np.zeros((6, 6))
    wide[:, ::2] = start  # a strided view
    read_only = end.copy()
    read_only.flags.writeable = False
    got = kernels.capsule_clearances(wide[:, ::2], read_only, radius, start, end, radius)
    np.testing.assert_array_equal(got, reference)
    ones = kernels.capsule_clearances([[0, 0, 0]], [[1, 0, 0]], [0], [[0, 2, 0]], [[1, 2, 0]], [0])
    assert ones[0, 0] == pytest.approx(2.0)


def test_hidden_points_equal_occluded_or_outside_the_view_cone():
    camera = DepthCameraModel([-0.2, 0.0, 1.8], [1.0, 0.0, 1.0],
                              [([0.5, 0.0, 1.2], [0.2, 0.4, 0.3]), ([0.6, 0.5, 1.0], [0.1, 0.1, 0.6])],
                              margin=0.02)
    rng = np.random.default_rng(2)
    points = rng.uniform([-0.5, -1.0, 0.0], [1.5, 1.0, 2.2], size=(400, 3))
    capsules = _random_capsules(rng, 4)
    capsules = (capsules[0] + [0.6, 0.0, 1.2], capsules[1] + [0.6, 0.0, 1.2], capsules[2] * 2)
    for links in (None, capsules):
        expected = camera.is_occluded(points, links) | ~camera.in_view(points)
        got = camera.is_hidden(points, links)
        np.testing.assert_array_equal(got, expected)
        assert 0 < expected.sum() < len(points)  # both kinds of point are tested


def test_warm_up_compiles_every_kernel_and_returns_its_seconds():
    seconds = kernels.warm_up()
    assert 0.0 < seconds < 120.0
    assert kernels.warm_up() < 1.0  # the second call finds them compiled


def _random_poses(body, rng, count):
    q = body.rest_q() + rng.normal(scale=0.4, size=(count, 12))
    return np.clip(q, body.q_lower, body.q_upper)


def test_skeleton_points_and_jacobian_equal_the_body_model_and_its_numpy_jacobian():
    body = BodyModel()
    dims = reactive._kernel_dims(body)
    rng = np.random.default_rng(3)
    for q in _random_poses(body, rng, 6):
        np.testing.assert_allclose(human_kernels.skeleton_points(dims, q), body.points(q), atol=1e-14)
        visible = rng.random(8) > 0.3
        visible[:3] = True
        model, jacobian = motion_kernels.skeleton_jacobian(dims, q, visible, 1e-5)
        ref_model, ref_jacobian = reactive._points_and_jacobian(body, q, visible)
        np.testing.assert_allclose(model, ref_model, atol=1e-14)
        np.testing.assert_allclose(jacobian, ref_jacobian, atol=1e-9)
        assert jacobian.shape == (3 * visible.sum(), 12)


def test_tracking_gauss_newton_equals_the_numpy_steps_and_a_moved_body_keeps_the_numpy_path():
    body = BodyModel()
    dims = reactive._kernel_dims(body)
    rng = np.random.default_rng(4)
    for q0 in _random_poses(body, rng, 6):
        points = body.points(np.clip(q0 + rng.normal(scale=0.05, size=12), body.q_lower, body.q_upper))
        visible = rng.random(8) > 0.2
        target = points[visible].ravel()
        ref_q, ref_rms = reactive._tracking_gauss_newton(body, target, visible, q0, 4, 1e-3)
        limits = (body.q_lower, body.q_upper)
        q, rms = motion_kernels.tracking_gauss_newton(dims, *limits, target, visible, q0, 4, 1e-3, 1e-5)
        np.testing.assert_allclose(q, ref_q, atol=1e-9)
        assert rms == pytest.approx(ref_rms, rel=1e-9, abs=1e-12)

    class LongArms(BodyModel):  # other kinematics: the kernels, written for BodyModel's, must not be used
        def _points(self, q, with_fore_dir=False):
            return super()._points(q, with_fore_dir) * 1.1

        def _points_single(self, q, with_fore_dir=False):
            return self._points(q[None], with_fore_dir)[0]

    assert reactive._kernel_dims(LongArms()) is None
    long_arms = LongArms()
    q0 = body.rest_q()
    q = reactive.tracking_inverse(long_arms, long_arms.points(q0 + 0.02), q0)
    np.testing.assert_allclose(long_arms.points(q), long_arms.points(q0 + 0.02), atol=0.02)


def test_bounding_capsule_equals_its_numpy_form(monkeypatch):
    rng = np.random.default_rng(5)
    for points in (rng.normal(size=(3, 300)) * [[0.4], [0.1], [0.05]], rng.normal(size=(3, 2000)),
                   np.zeros((3, 5)) + [[0.1], [0.2], [0.3]]):  # a single point: the ball branch
        offsets = rng.uniform(-0.1, 0.1, size=(4, 3))
        got = motion_kernels.bounding_capsule(points, offsets, 3)
        ref = reactive._bounding_capsule(points, offsets, 3)
        ends = np.array([got[0], got[1]])
        if np.abs(ends[0] - ref[0]).max() > 1e-9:  # an eigenvector of the other sign: ends swapped
            ends = ends[::-1]
        np.testing.assert_allclose(ends, [ref[0], ref[1]], atol=1e-9)
        assert got[2] == pytest.approx(ref[2], rel=1e-12)
    # the swept volumes the builder makes with the kernel are those of the numpy form
    body = BodyModel()
    builder = reactive.SweptVolumeBuilder(body)
    boxes = []
    for q in _random_poses(body, rng, 4):
        delta_plus, delta_minus = rng.uniform(0.0, 0.4, 12), rng.uniform(0.0, 0.4, 12)
        boxes.append((q, delta_plus, delta_minus, builder.build(q, delta_plus, delta_minus)))
    monkeypatch.setattr(motion_kernels, "bounding_capsule", reactive._bounding_capsule)
    for q, delta_plus, delta_minus, (start, end, radius) in boxes:
        ref_start, ref_end, ref_radius = builder.build(q, delta_plus, delta_minus)
        np.testing.assert_allclose(radius, ref_radius, rtol=1e-12)
        same = np.abs(start - ref_start).max(axis=1) < 1e-9
        np.testing.assert_allclose(np.where(same[:, None], start, end), ref_start, atol=1e-9)


@pytest.mark.parametrize("groups", ["gp_a", "gp_b", "gp_c"])
def test_gp_rollouts_equal_the_numpy_rollouts_with_the_same_draws(groups):
    from hrc_drake.motion.gp import GPMotionModel

    t = np.arange(160) * 0.05
    q = np.stack([np.sin(t * (1.0 + 0.1 * j)) + 0.01 * j for j in range(12)], -1)
    phi = np.stack([q, np.gradient(q, axis=0), np.gradient(np.gradient(q, axis=0), axis=0)], -1)
    windows = np.stack([phi[k - 3:k + 1] for k in range(3, 160)])
    model = GPMotionModel(groups, order=3, max_samples=60, random_state=1).fit(windows)
    got = model.sample_rollouts(phi[-3:], 5, 20, np.random.default_rng(7))
    reference = model._rollouts_numpy(phi[-3:], 5, 20, np.random.default_rng(7))
    assert got.shape == (20, 5, 12)
    np.testing.assert_allclose(got, reference, atol=1e-8)
    assert np.ptp(got[:, -1], axis=0).max() > 1e-3  # the trials differ: the noise is used


@pytest.mark.parametrize("dim", [1, 3])
def test_rts_smoothed_means_equal_the_numpy_smoother(dim):
    from hrc_drake.perception.kalman import ChainOfIntegrators, KalmanFilter, rts_smooth, rts_smoothed_means

    model = ChainOfIntegrators(order=3, dt=0.05, sigma=2.0, dim=dim)
    rng = np.random.default_rng(6)
    track = np.cumsum(rng.normal(scale=0.05, size=(30, 4, dim)), axis=0)
    filt = KalmanFilter(model, n_tracks=4, measurement_std=0.05)
    means, covs = filt.filter_sequence(track + rng.normal(scale=0.05, size=track.shape))
    reference, _ = rts_smooth(model, means, covs)
    got = rts_smoothed_means(model, means, covs)
    np.testing.assert_allclose(got, reference, atol=1e-12)
    assert np.abs(got - means).max() > 1e-3  # smoothing moved the filtered means
    with pytest.raises(ValueError, match="rts_smooth: means must be"):
        rts_smoothed_means(model, means[..., :2], covs)


def test_window_velocity_equals_the_numpy_least_squares_line():
    from hrc_drake.intention.features import least_squares_velocity

    rng = np.random.default_rng(11)
    times = np.arange(8) / 30.0
    cases = 0
    for trial in range(200):
        speed = rng.choice([0.0, 0.05, 0.3, 1.0])
        wrists = rng.normal(size=(1, 2, 3)) + speed * times[:, None, None] * rng.normal(size=(1, 2, 3))
        wrists = wrists + rng.normal(scale=0.005, size=wrists.shape)
        wrists[rng.random((8, 2)) < 0.25 * (trial % 3)] = np.nan  # none, some or many samples missing
        expected_v, expected_moving = least_squares_velocity(times, wrists, 0.15, significance=3.5)
        got_v, got_moving = intention_kernels.window_velocity(times, wrists, 0.15, 5, 3.5)
        np.testing.assert_allclose(got_v, expected_v, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(got_moving, expected_moving)
        cases += int(expected_moving.sum())
    assert 50 < cases < 350  # both moving and still wrists were tested


def test_goal_log_likelihoods_equal_the_numpy_features_and_mixture_density():
    from hrc_drake.intention.bayes import _PHI, _PSI, goal_log_likelihoods_numpy
    from hrc_drake.intention.features import AT_GOAL, NEUTRAL_ANGLE
    from hrc_drake.intention.likelihood import default_model
    from hrc_drake.messages import HEAD, L_WRIST, R_WRIST

    model = default_model()
    rng = np.random.default_rng(12)
    for trial in range(40):
        points = rng.normal(scale=0.3, size=(8, 3)) + [0.5, 0.0, 1.0]
        velocity = rng.normal(size=(2, 3))
        moving = rng.random(2) > 0.3
        gaze = rng.normal(size=3)
        samples = rng.normal(scale=0.05, size=(4, 1 + trial % 5, 3)) + [0.8, 0.0, 0.9]
        if trial % 7 == 0:
            samples[1, 0] = points[L_WRIST]  # a wrist at a goal's centre: its angle is 0 there
        if trial % 9 == 0:
            points[HEAD] = np.nan  # no head: the neutral gaze angle
        for density, columns, use_gaze in ((model.gmm4d, _PHI, True), (model.gmm2d, _PSI, False)):
            expected = goal_log_likelihoods_numpy(points, velocity, moving, gaze, samples, density, use_gaze)
            wrists = points[[L_WRIST, R_WRIST]]
            got = intention_kernels.goal_log_likelihoods(wrists, velocity, moving, points[HEAD], gaze,
                                                         samples, columns, *density.kernel_arrays(),
                                                         NEUTRAL_ANGLE, AT_GOAL)
            assert got.shape == (2, 4)
            np.testing.assert_allclose(got, expected, rtol=1e-10, atol=1e-10)


def _settled_kalman(rng):
    kf, _ = _kalman_pair(rng)
    for _ in range(5):
        kf.predict()
        kf.update(rng.normal(size=(8, 3)))
    return kf


def _kalman_pair(rng, order=4):
    from hrc_drake.perception.kalman import ChainOfIntegrators, KalmanFilter

    kf = KalmanFilter(ChainOfIntegrators(order=order, sigma=rng.uniform(0.5, 2.0, order)), n_tracks=8,
                      measurement_std=0.02)
    return kf, kf.clone()


def test_kalman_predict_and_update_equal_their_numpy_forms():
    rng = np.random.default_rng(13)
    for order in (2, 4):
        compiled, reference = _kalman_pair(rng, order)
        truth = rng.normal(size=(8, 3))
        for frame in range(60):
            truth = truth + 0.01 * rng.normal(size=(8, 3))
            y = truth + 0.02 * rng.normal(size=(8, 3))
            y[rng.random(8) < 0.3] = np.nan  # occluded rows
            y[frame % 8, frame % 3] = 2e6 if frame % 11 == 0 else y[frame % 8, frame % 3]  # absurd value
            mask = rng.random(8) > 0.1
            steps = 1 + frame % 3
            compiled.predict(steps)
            reference._predict_numpy(steps)
            compiled.update(y, mask)
            reference._update_numpy(y, mask)
            np.testing.assert_array_equal(compiled.initialized_, reference.initialized_)
            np.testing.assert_allclose(compiled.x_, reference.x_, rtol=1e-9, atol=1e-12)
            np.testing.assert_allclose(compiled.P_, reference.P_, rtol=1e-9, atol=1e-15)
        assert compiled.initialized_.all()


def test_kalman_gate_equals_the_numpy_mahalanobis_distance():
    rng = np.random.default_rng(14)
    kf = _settled_kalman(rng)
    y = rng.normal(size=(8, 3))
    rows = np.array([0, 3, 5, 7])
    nu = y[rows] - kf.x_[rows, :3]
    s = kf.P_[rows, :3, :3] + 0.02**2 * np.eye(3)
    expected = np.einsum("pi,pi->p", nu, np.linalg.solve(s, nu[:, :, None])[:, :, 0])
    got = perception_kernels.kalman_gate(kf.x_, kf.P_, y, rows, 0.02**2)
    np.testing.assert_allclose(got, expected, rtol=1e-12)


def test_position_samples_equal_mean_plus_the_cholesky_factor_times_the_draws():
    rng = np.random.default_rng(15)
    kf = _settled_kalman(rng)
    rows = np.array([1, 2, 6])
    z = rng.standard_normal((3, 40, 3))
    chol = np.linalg.cholesky(kf.P_[rows, :3, :3])
    expected = kf.x_[rows, None, :3] + z @ np.swapaxes(chol, 1, 2)
    got = perception_kernels.position_samples(kf.x_, kf.P_, rows, z)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-15)
    singular = kf.P_.copy()
    singular[1, :3, :3] = 0.0
    with pytest.raises(ValueError, match="positive definite"):
        perception_kernels.position_samples(kf.x_, singular, rows, z)


def test_bayes_rows_equal_the_numpy_bayes_update():
    from hrc_drake.intention.bayes import _LOG_LIKELIHOOD_FLOOR, bayes_update

    rng = np.random.default_rng(16)
    for trial in range(50):
        prior = rng.dirichlet(np.ones(5), size=3)
        log_lik = rng.normal(scale=20.0, size=(3, 5))
        log_lik[rng.random((3, 5)) < 0.2] = np.nan
        if trial % 5 == 0:
            log_lik[1] = -np.inf  # no finite likelihood: the prior stays
        switch = rng.uniform(0.0, 0.5, size=3)
        active = rng.random(3) > 0.2
        expected = bayes_update(prior, log_lik, switch, active)
        got = intention_kernels.bayes_rows(prior, log_lik, switch, active, _LOG_LIKELIHOOD_FLOOR)
        np.testing.assert_allclose(got, expected, rtol=1e-14, atol=1e-300)


def test_body_points_of_one_pose_are_the_float_forward_kinematics_bit_for_bit():
    body = BodyModel()
    for q in _random_poses(body, np.random.default_rng(17), 200):
        np.testing.assert_array_equal(body._points(q), body._points_single(q))


#: two kernels of the intention group and the prediction group's, each called twice
_FIRST_RUN = """
import numpy as np
from hrc_drake.intention import _kernels as intention
from hrc_drake.prediction import _kernels as prediction
for _ in range(2):
    intention.window_velocity(np.arange(3.0), np.zeros((3, 2, 3)), 0.1, 2, 3.0)
    intention.bayes_rows(np.full((2, 2), 0.5), np.zeros((2, 2)), np.zeros(2), np.ones(2, dtype=bool), -30.0)
    prediction.merged_end_mass(np.zeros(1), np.zeros(1), np.zeros(1), np.ones((1, 1)), np.ones((1, 2)),
                               np.ones((1, 2)), np.ones(1))
"""


def test_a_first_run_names_each_group_it_compiles_once_and_a_cached_run_says_nothing(tmp_path):
    import os
    import subprocess
    import sys

    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}

    def stderr() -> str:
        return subprocess.run([sys.executable, "-c", _FIRST_RUN], env=env, capture_output=True, text=True,
                              check=True, timeout=120).stderr

    first = stderr()
    intention_line = ("compiling kernels for the intention estimator and the action segmenter "
                      "(first run only) ...")
    assert first.count(intention_line) == 1, first
    assert first.count("compiling kernels for the waiting-time predictor (first run only) ...") == 1, first
    assert first.count("compiling kernels") == 2, first  # no other group: those were not called
    assert "compiling" not in stderr()  # the disk cache has them now


def test_each_group_is_registered_and_its_warm_up_steps_cache_every_kernel_it_compiles():
    import importlib

    for name, (module, description) in kernels.GROUPS.items():
        assert callable(importlib.import_module(module)._warm_up_steps), name
        assert description.startswith("the "), name
        kernels.warm_up([name])
        assert kernels.uncached_groups([name]) == [], name  # every kernel of its own has a cache index
    assert kernels.warm_up(["prediction"]) < 60.0
    with pytest.raises(ValueError, match="unknown kernel group.*'safty'.*the groups are"):
        kernels.uncached_groups(["safty"])


def test_warm_up_makes_only_the_calls_it_claims_first_from_its_start(tmp_path, monkeypatch):
    from hrc_drake.prediction import _kernels as prediction_kernels

    made = []
    steps = [lambda k=k: made.append(k) for k in range(4)]
    monkeypatch.setattr(prediction_kernels, "_warm_up_steps", lambda: steps)
    kernels.warm_up(["prediction"], start=0.5)
    assert made == [2, 3, 0, 1]
    made.clear()
    (tmp_path / "prediction.3").touch()  # another process has it
    kernels.warm_up(["prediction"], start=0.5, claims=str(tmp_path))
    assert made == [2, 0, 1]
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"prediction.{k}" for k in range(4)]


_AHEAD = """
import json, sys
from numba.core import event
from hrc_drake import kernels

groups = ["prediction", "scheduling"]
before = kernels.uncached_groups(groups)
ahead = kernels.compile_ahead(groups, processes=2)
ahead.wait()
compiled = []

class Listener(event.Listener):
    def on_start(self, ev):
        compiled.append(ev.data["dispatcher"].py_func.__name__)

    def on_end(self, ev):
        pass

event.register("numba:compile", Listener())
kernels.warm_up(groups)
print(json.dumps({"before": before, "after": kernels.uncached_groups(groups), "compiled_here": compiled,
                  "again": kernels.compile_ahead(groups).groups}))
"""


def test_compile_ahead_fills_the_disk_cache_so_that_the_caller_only_loads(tmp_path):
    import json
    import os
    import subprocess
    import sys

    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    proc = subprocess.run([sys.executable, "-c", _AHEAD], env=env, capture_output=True, text=True, check=True,
                          timeout=300)
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["before"] == ["prediction", "scheduling"]
    assert out["after"] == []
    assert out["compiled_here"] == []  # loaded from what the background processes cached
    assert out["again"] == []  # nothing left to compile: no process started
    notice = ("compiling kernels for the waiting-time predictor, the Monte Carlo scheduler "
              "(first run only, 2 background processes) ...")
    assert proc.stderr.count(notice) == 1, proc.stderr
    assert proc.stderr.count("compiling") == 1, proc.stderr  # the caller compiled nothing itself


def test_a_failed_background_process_is_reported_and_its_work_left_to_first_use(monkeypatch, capsys):
    monkeypatch.setattr(kernels, "uncached_groups", lambda groups: list(groups))
    monkeypatch.setattr(kernels, "_AHEAD_CODE", "import sys; sys.exit('no compiler here')")
    ahead = kernels.compile_ahead(["prediction"], processes=1)
    assert ahead.groups == ["prediction"]
    assert ahead.wait() >= 0.0
    err = capsys.readouterr().err
    assert "a process compiling kernels ahead failed (exit 1: no compiler here); what it left undone " \
           "compiles when first used" in err, err
    assert "hrc_drake.prediction._kernels" not in kernels._NOTICE._told  # first use says so again
    assert kernels.warm_up(["prediction"]) < 60.0


def test_stopping_compile_ahead_ends_its_processes(monkeypatch):
    monkeypatch.setattr(kernels, "uncached_groups", lambda groups: list(groups))
    monkeypatch.setattr(kernels, "_AHEAD_CODE", "import time; time.sleep(60)")
    with kernels.compile_ahead(["safety"], processes=2) as ahead:
        processes = [process for process, _ in ahead._processes]
        assert len(processes) == 2
    assert all(process.poll() is not None for process in processes)
    # no more processes than warm-up calls: the waiting-time predictor's one kernel takes one
    with kernels.compile_ahead(["prediction"], processes=4) as ahead:
        assert len(ahead._processes) == 1


def test_a_kernel_calling_another_file_s_kernels_is_stamped_with_that_file_too():
    """numba stamps a cached kernel with its own file only: editing `_skeleton_points` or
    `_solve_pivoting` must make the motion group's cache stale, as it compiled them in."""
    stamp = motion_kernels._tracking_gauss_newton._cache._cache_file._source_stamp
    assert stamp[1:] == (kernels._file_stamp(kernels.__file__), kernels._file_stamp(human_kernels.__file__))
    perception_stamp = perception_kernels._kalman_update._cache._cache_file._source_stamp
    assert perception_stamp[1:] == (kernels._file_stamp(kernels.__file__),)
    assert not isinstance(intention_kernels._bayes_rows._cache._cache_file._source_stamp, tuple)  # no callee


_GROUPS_USED = """
import importlib, json, sys, warnings
warnings.simplefilter("ignore")
from hrc_drake import kernels
from hrc_drake.cell.build import build_cell
from hrc_drake.cell.run import simulate
from hrc_drake.cell.scenario import load_scenario

path = sys.argv[1]
simulate(build_cell(load_scenario(path), path), 20.0, progress=None)
print(json.dumps([name for name in kernels.GROUPS if any(k.overloads for k in kernels._group_kernels(name))]))
"""


@pytest.mark.parametrize("cell", ["torch_clock", "torch_segmentation", "full_pipeline"])
def test_the_groups_compiled_ahead_for_a_cell_are_those_its_run_calls(cell):
    """`cell.build.kernel_groups` against the groups whose kernels a 20 s run of the cell loaded
    (in a fresh interpreter: this one has loaded them all)."""
    import json
    import subprocess
    import sys

    from hrc_drake.cell.build import kernel_groups
    from hrc_drake.cell.scenario import load_scenario
    from tests.conftest import DIAGRAMS

    path = str(DIAGRAMS / f"{cell}.yaml")
    proc = subprocess.run([sys.executable, "-c", _GROUPS_USED, path], capture_output=True, text=True,
                          check=True, timeout=600)
    used = json.loads(proc.stdout.strip().splitlines()[-1])
    assert sorted(kernel_groups(load_scenario(path))) == sorted(used)


def test_compile_ahead_starts_at_most_max_ahead_processes_by_default(monkeypatch):
    monkeypatch.setattr(kernels, "uncached_groups", lambda groups: list(groups))
    monkeypatch.setattr(kernels, "_AHEAD_CODE", "pass")
    monkeypatch.setattr(kernels.os, "cpu_count", lambda: 64)
    with kernels.compile_ahead(["safety", "perception"]) as ahead:  # 13 calls
        assert len(ahead._processes) == kernels.MAX_AHEAD_PROCESSES == 4
