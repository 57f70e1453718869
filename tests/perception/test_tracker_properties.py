"""Property tests of the skeleton trackers on arbitrary streams (Hypothesis): frames with NaN,
inf, huge values, untracked points, jumps, long gaps and time going backwards."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from hrc_drake.messages import SKELETON_PARENTS, SkeletonFrame
from hrc_drake.perception.kalman import ChainOfIntegrators, KalmanFilter
from hrc_drake.perception.particle_filter import SkeletonParticleFilter
from hrc_drake.perception.tracker import MAX_GAP, UNKNOWN_SPREAD, SkeletonTracker

POSE = np.array([
    [0.0, 0.0, 1.40], [0.0, 0.0, 1.65], [0.0, 0.2, 1.40], [0.0, -0.2, 1.40],
    [0.0, 0.2, 1.10], [0.0, -0.2, 1.10], [0.27, 0.2, 1.10], [0.27, -0.2, 1.10],
])
WS_CENTER, WS_SIZE = np.array([0.6, 0.2, 1.1]), np.array([0.5, 0.6, 0.6])
STD = 0.01  # measurement_std of every filter below
GATE = 6.0


def hidden_in_front(p):
    return p[..., 0] > 0.15


small = st.floats(-0.03, 0.03)
near = st.tuples(small, small, small)  # noise around the pose
offset = st.one_of(
    near, near, near,
    st.lists(st.floats(-5.0, 5.0), min_size=3, max_size=3),  # a jump
    st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=3, max_size=3),  # NaN, inf, huge
    st.just([math.nan] * 3),  # an untracked point's row
)
time_step = st.one_of(
    st.just(1.0 / 30.0), st.just(1.0 / 30.0),
    st.just(0.0),  # the same time again
    st.floats(-1.0, 0.0),  # backwards
    st.floats(0.0, 3.0),  # a skipped stretch
    st.floats(3.0, MAX_GAP),  # a pause the filters predict over
    st.sampled_from([MAX_GAP, MAX_GAP * 2, 1e9, math.nan, math.inf, -math.inf]),  # long gaps, bad times
)
gaze = st.one_of(st.just((1.0, 0.0, 0.0)), st.just((0.0, -1.0, 0.0)), st.just((math.nan, 0.0, 0.0)))
mostly_tracked = st.lists(st.sampled_from([True, True, True, False]), min_size=8, max_size=8)
messy = st.tuples(time_step, st.lists(offset, min_size=8, max_size=8), st.lists(st.booleans(), min_size=8,
                  max_size=8), gaze, st.booleans())
clean = st.tuples(st.just(1.0 / 30.0), st.lists(near, min_size=8, max_size=8), mostly_tracked,
                  st.just((1.0, 0.0, 0.0)), st.just(True))
frame = st.one_of(clean, clean, messy)  # runs of clean frames: calibration, occlusions, re-acquisition
stream = st.lists(frame, min_size=5, max_size=40)


def build_frames(draws):
    """SkeletonFrames from the drawn steps; a non-finite step gives that frame's time only."""
    clock, frames = 0.0, []
    for step, offsets, tracked, g, g_valid in draws:
        if math.isfinite(step):
            clock += step
            t = clock
        else:
            t = step
        with np.errstate(over="ignore", invalid="ignore"):
            points = POSE + np.array(offsets, dtype=float)
        frames.append(SkeletonFrame(time=t, points=points, tracked=np.array(tracked), gaze=np.array(g),
                                    gaze_valid=g_valid))
    return frames


def valid_rows(points, tracked):
    """Rows a filter must take as measurements: tracked, finite and not absurd."""
    with np.errstate(invalid="ignore"):
        return tracked & np.all(np.isfinite(points), axis=1) & np.all(np.abs(points) <= 1e6, axis=1)


def run_tracker(kind, frames, is_hidden, seed=0):
    tracker = SkeletonTracker(kind, {"particles": 40, "display_particles": 5, "calibration_frames": 3},
                              is_hidden=is_hidden, workspace_center=WS_CENTER, workspace_size=WS_SIZE,
                              seed=seed)
    with np.errstate(over="ignore", invalid="ignore"):
        return [tracker.update(f) for f in frames]


def assert_well_formed(est):
    assert est.points.shape == (8, 3) and np.all(np.isfinite(est.points))
    assert np.all(np.isfinite(est.spread)) and np.all(est.spread >= 0)
    assert np.all((est.workspace_fraction >= 0) & (est.workspace_fraction <= 1))
    assert np.all(np.isfinite(est.gaze))
    if est.particles is not None:
        assert np.all(np.isfinite(est.particles))


@settings(max_examples=60, deadline=None)
@given(draws=stream, kind=st.sampled_from(["particle_filter", "kalman", "none"]),
       hidden=st.booleans())
def test_tracker_on_any_stream_is_finite_documented_and_repeatable(draws, kind, hidden):
    frames = build_frames(draws)
    is_hidden = hidden_in_front if hidden else None
    estimates = run_tracker(kind, frames, is_hidden)
    # Reference of the documented bookkeeping: time backwards or a gap over MAX_GAP starts a new
    # run, a frame with a non-finite time is ignored; held = last seen measurement of each point.
    last_t, ever, held = None, np.zeros(8, dtype=bool), np.zeros((8, 3))
    previous = None
    for f, est in zip(frames, estimates, strict=True):
        assert_well_formed(est)
        if not math.isfinite(f.time):
            if previous is not None:
                assert est is previous  # ignored: the estimate is unchanged
            continue
        if last_t is not None and (f.time < last_t - 1e-9 or f.time - last_t > MAX_GAP):
            ever[:] = False
        last_t = f.time
        seen = valid_rows(f.points, f.tracked)
        np.testing.assert_array_equal(est.tracked, seen)
        ever |= seen
        held[seen] = f.points[seen]
        if not (np.all(np.isfinite(f.gaze))):
            assert not est.gaze_valid
        for i in np.flatnonzero(~ever):
            if kind != "particle_filter":  # the PF may place a never-seen point from its constraints
                parent = SKELETON_PARENTS[i]
                assert est.spread[i] == UNKNOWN_SPREAD and est.workspace_fraction[i] == 1.0
                np.testing.assert_array_equal(est.points[i], est.points[parent] if parent >= 0 else 0.0)
        if kind == "none":
            np.testing.assert_array_equal(est.points[ever], held[ever])
        elif kind == "particle_filter":
            # eq. (9.8) posterior of a seen point: (I - K) of the innovation, within the gate
            err = np.linalg.norm(est.points[seen] - f.points[seen], axis=1)
            assert np.all(err <= GATE * STD * (1 + 1e-6) * math.sqrt(3)), err
        previous = est
    again = run_tracker(kind, frames, is_hidden)
    for a, b in zip(estimates, again, strict=True):
        np.testing.assert_array_equal(a.points, b.points)
        np.testing.assert_array_equal(a.spread, b.spread)
        np.testing.assert_array_equal(a.workspace_fraction, b.workspace_fraction)


@settings(max_examples=40, deadline=None)
@given(draws=stream, mode=st.sampled_from(["kalman", "bootstrap"]),
       resampling=st.sampled_from(["bootstrap", "systematic"]), hidden=st.booleans(),
       steps=st.lists(st.integers(1, 40), min_size=40, max_size=40))
def test_particle_filter_steps_stay_finite_and_repeat(draws, mode, resampling, hidden, steps):
    frames = build_frames(draws)
    is_hidden = hidden_in_front if hidden else None

    def run():
        pf = SkeletonParticleFilter(n_particles=30, rng=3, calibration_frames=3, measurement_std=STD,
                                    gate=GATE, tracked_update=mode, resampling=resampling)
        out = []
        with np.errstate(over="ignore", invalid="ignore"):
            for f, k in zip(frames, steps, strict=False):
                pf.step(f.points, f.tracked, is_hidden, steps=k)
                out.append((pf.means_.copy(), pf.particles_.copy(), pf.initialized_.copy()))
                seen = valid_rows(f.points, f.tracked)
                assert np.all(np.isfinite(pf.particles_)) and np.all(np.isfinite(pf.means_))
                assert np.all(pf.initialized_[seen])
                assert np.all(np.isfinite(pf.spread()))
                frac = pf.fraction_in_box(WS_CENTER, WS_SIZE)
                assert np.all((frac >= 0) & (frac <= 1))
                if mode == "kalman":  # seen points: the Kalman posterior, within the gate
                    err = np.linalg.norm(pf.means_[seen] - f.points[seen], axis=1)
                    assert np.all(err <= GATE * STD * math.sqrt(3) * (1 + 1e-6)), err
        return out

    first, second = run(), run()
    for a, b in zip(first, second, strict=True):
        for x, y in zip(a, b, strict=True):
            np.testing.assert_array_equal(x, y)


@settings(max_examples=80, deadline=None)
@given(draws=stream, order=st.integers(1, 4), sigma=st.floats(0.0, 5.0))
def test_kalman_filter_posterior_is_finite_and_no_wider_than_the_measurement(draws, order, sigma):
    frames = build_frames(draws)
    kf = KalmanFilter(ChainOfIntegrators(order, 1.0 / 30.0, sigma, dim=3), 8, STD, 0.5)
    for f in frames:
        before = kf.P_.copy()
        with np.errstate(over="ignore", invalid="ignore"):
            kf.step(f.points, f.tracked)
        seen = valid_rows(f.points, f.tracked)
        assert np.all(np.isfinite(kf.x_)) and np.all(np.isfinite(kf.P_))
        np.testing.assert_allclose(kf.P_, np.swapaxes(kf.P_, 1, 2), rtol=1e-12, atol=1e-300)
        assert np.all(kf.initialized_[seen])
        assert np.all(kf.x_[~kf.initialized_] == 0.0)
        var = np.diagonal(kf.position_covariances, axis1=1, axis2=2)
        # a measured position's posterior variance is at most the measurement's (R = STD^2 I)
        assert np.all(var[seen] <= STD**2 * (1 + 1e-6)), var[seen]
        assert np.all(var > 0)
        # open loop (missing measurement): the position variance does not shrink
        open_loop = kf.initialized_ & ~seen
        grown = np.diagonal(before[:, :3, :3], axis1=1, axis2=2)
        assert np.all(var[open_loop] >= grown[open_loop] * (1 - 1e-9))


@settings(max_examples=30, deadline=None)
@given(draws=stream, kind=st.sampled_from(["particle_filter", "kalman", "none"]), cut=st.integers(0, 40))
def test_a_clone_continues_like_the_original_and_leaves_it_alone(draws, kind, cut):
    frames = build_frames(draws)
    tracker = SkeletonTracker(kind, {"particles": 30, "display_particles": 5}, is_hidden=hidden_in_front,
                              seed=5)
    with np.errstate(over="ignore", invalid="ignore"):
        for f in frames[:cut]:
            tracker.update(f)
        copy = tracker.clone()  # copy-on-write state of the Drake system
        from_copy = [copy.update(f) for f in frames[cut:]]
        from_original = [tracker.update(f) for f in frames[cut:]]
    for a, b in zip(from_copy, from_original, strict=True):
        np.testing.assert_array_equal(a.points, b.points)
        np.testing.assert_array_equal(a.spread, b.spread)
        np.testing.assert_array_equal(a.workspace_fraction, b.workspace_fraction)
        if a.particles is not None:
            np.testing.assert_array_equal(a.particles, b.particles)
