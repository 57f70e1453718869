"""tools/real_tracking.py: occlusion windows, scoring and seeding of the real-motion tracking part."""

from __future__ import annotations

import io
from contextlib import redirect_stdout

import numpy as np
import pytest

from hrc_drake.human.camera import DepthCameraModel
from hrc_drake.messages import L_ELBOW, L_WRIST, R_ELBOW, R_WRIST
from tests.conftest import load_tool


@pytest.fixture(scope="module")
def rt():
    module = load_tool("real_tracking")
    return module


def camera(noise=0.01):
    """pcb_occlusion.yaml's camera pose, no shelves."""
    return DepthCameraModel([0.05, 0.0, 1.85], [1.0, 0.0, 1.0], [], noise_std=noise)


def person(frames=240, reach=0.1):
    """A seated person at x = 1 facing -x (left = -y); the right wrist swings by `reach` m in x."""
    base = np.array([[1.0, 0.0, 1.25], [1.0, 0.0, 1.5], [1.0, -0.2, 1.4], [1.0, 0.2, 1.4],
                     [0.9, -0.25, 1.15], [0.9, 0.25, 1.15], [0.7, -0.2, 1.0], [0.7, 0.2, 1.0]])
    pts = np.repeat(base[None], frames, axis=0)
    pts[:, R_WRIST, 0] -= reach * np.sin(np.arange(frames) / 10.0) ** 2
    return pts


def test_windows_hide_their_targets_only_in_the_window(rt):
    truth, cam = person(), camera()
    windows = rt.occlusion_windows(truth, cam, np.random.default_rng(3))
    assert windows and windows[0].start >= int(rt.WARMUP_S * rt.RATE)
    _, seen, cams, by_panel = rt.camera_frames(truth, cam, windows, np.random.default_rng(4))
    inside = np.zeros(len(truth), dtype=bool)
    for w in windows:
        assert w.side == "right"  # the moving arm
        assert 30 <= w.stop - w.start <= 90
        assert not np.any(seen[w.start:w.stop][:, list(w.targets)])
        # nothing but that arm's elbow and wrist is hidden (cases 1-3 of 9.1.2)
        others = np.setdiff1d(np.arange(8), [R_ELBOW, R_WRIST])
        assert np.all(seen[w.start:w.stop][:, others])
        assert all(c is cams[w.start] for c in cams[w.start:w.stop])
        inside[w.start:w.stop] = True
    assert np.all(seen[~inside])
    assert np.array_equal(~seen, by_panel)


def test_occluder_for_covers_the_targets(rt):
    cam = camera()
    targets = np.array([[0.7, 0.2, 1.0], [0.6, 0.25, 1.05], [0.9, 0.25, 1.15]])
    box = rt.occluder_for(cam, targets)
    assert np.all(rt.with_boxes(cam, [box]).is_hidden(targets))
    assert not np.any(cam.is_hidden(targets))


def test_nan_truth_is_never_scored(rt):
    truth, cam = person(), camera()
    truth[100:140, R_WRIST] = np.nan  # untracked in the recording, partly inside windows
    truth[:5, L_WRIST] = np.nan
    windows = rt.occlusion_windows(truth, cam, np.random.default_rng(0))
    points, seen, cams, _ = rt.camera_frames(truth, cam, windows, np.random.default_rng(1))
    assert np.all(np.isnan(points[100:140, R_WRIST])) and not np.any(seen[100:140, R_WRIST])
    for name in ("hold", "kf2"):
        rows = rt.run_tracker(name, points, seen, cams, truth, 0)
        assert rows["error"].size
        assert np.all(np.isfinite(truth[rows["frame"], rows["point"]]))
        assert np.all(np.isfinite(rows["error"]))
        assert not np.any((rows["point"] == R_WRIST) & (rows["frame"] >= 100) & (rows["frame"] < 140))


def test_a_still_held_point_gives_hold_zero_error_and_full_coverage(rt):
    truth, cam = person(reach=0.0), camera(noise=0.0)
    windows = rt.occlusion_windows(truth, cam, np.random.default_rng(5))
    points, seen, cams, _ = rt.camera_frames(truth, cam, windows, np.random.default_rng(6))
    rows = rt.run_tracker("hold", points, seen, cams, truth, 0)
    s = rt.stats([rows])
    assert s["hidden_point_frames"] == int((~seen).sum()) > 0
    assert s["rms_hidden_m"] == pytest.approx(0.0, abs=1e-12)
    assert s["coverage"] == 1.0


def test_arm_cases(rt):
    lost = np.zeros((3, 8), dtype=bool)
    lost[0, L_WRIST] = True
    lost[1, L_ELBOW] = True
    lost[2, [R_ELBOW, R_WRIST, 0]] = True
    case = rt.arm_cases(lost)
    assert case[0, L_WRIST] == 0 and case[1, L_ELBOW] == 1
    assert case[2, R_ELBOW] == case[2, R_WRIST] == 2 and case[2, 0] == 3
    assert np.all(case[~lost] == -1)


def test_same_seed_same_figures(rt):
    cam = camera()
    seqs = [("lego:a", person(150)), ("ue:b", person(120, reach=0.2))]
    trackers = {"hold": ("none", {}), "pf": ("particle_filter", {"particles": 100})}

    def run(seed):
        with redirect_stdout(io.StringIO()):
            return rt.tracking_figures(seqs, person(150, reach=0.3), seed=seed, camera=cam, trackers=trackers)

    a, b, c = run(1), run(1), run(2)
    assert a == b
    assert a != c
    assert set(a["tracking"]) == {"hold", "pf"} and set(a["tracking_by_set"]) == {"lego", "ue"}
    for key in ("rms_hidden_m", "coverage", "mean_volume_cm3", "volume_radius_m", "hidden_point_frames"):
        assert key in a["tracking"]["pf"] and key in a["tracking_synthetic"]["pf"]
