"""tools/real_gpdm.py: reach segmentation, constant velocity, phase alignment, determinism."""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))

import real_gpdm as rg  # noqa: E402


def test_segment_reach_on_a_hand_made_profile():
    speed = np.array([0.0, 0.01, 0.02, 0.3, 0.8, 1.0, 0.6, 0.2, 0.05, 0.0, 0.12, 0.0])
    # 10 % of the peak (1.0): last frame below before the peak is 2, first after it is 8
    assert rg.segment_reach(speed, 0.1) == (2, 8)
    assert rg.segment_reach(speed, 0.25) == (2, 7)
    assert rg.segment_reach(np.array([1.0, 0.5, 0.0]), 0.1) == (0, 2)


def test_wrist_speed_of_a_uniform_line():
    track = np.outer(np.arange(10), [0.01, 0.0, 0.0])
    assert np.allclose(rg.wrist_speed(track, 30.0), 0.3)


def test_constant_velocity_is_exact_on_a_straight_constant_speed_line():
    step = np.array([[0.01, -0.02, 0.005], [0.0, 0.01, 0.0], [0.02, 0.0, 0.0]])
    line = np.arange(20)[:, None, None] * step + 0.3
    for window in (1, 3):
        predicted = rg.constant_velocity(line[:12], 8, window)
        assert predicted.shape == (8, 3, 3)
        assert np.allclose(predicted, line[12:20])


def test_phase_index_recovers_a_time_shift():
    s = np.linspace(0.0, 1.0, 40)
    phi = np.stack([np.sin(2 * s), s**2, np.cos(s)], axis=1)
    shift = 7
    observed = np.concatenate([np.repeat(phi[:1], shift, axis=0), phi])  # Phi started 7 frames late
    for t in (10, 20, 30):
        assert rg.phase_index(phi, observed[t - 2: t + 1]) == t - shift


def test_trial_errors_zero_for_a_perfect_model_and_begin_alignment():
    s = np.linspace(0.0, 1.0, 30)
    reach = np.stack([np.stack([0.1 * s, 0.2 * s**2, 0.05 * s], 1)] * 3, axis=1)  # (30, 3, 3)
    start = 5
    poses = np.concatenate([np.repeat(reach[:1], start, 0), reach, np.repeat(reach[-1:], 15, 0)])
    errors = rg.trial_errors(reach.reshape(30, -1), poses, start, start + 29, 9)
    assert np.allclose(errors["gpdm"]["horizon"], 0.0)
    assert np.allclose(errors["gpdm"]["remaining"], 0.0)
    assert errors["constant_velocity"]["horizon"].max() > 0.0
    # the same model started one frame late is wrong
    late = rg.trial_errors(reach.reshape(30, -1), poses, start + 1, start + 29, 9)
    assert late["gpdm"]["horizon"].max() > 0.0


def _toy_trials(seed):
    rng = np.random.default_rng(seed)
    out = []
    for person in ("a", "b"):
        for kind, goal in (("FR", [-0.2, 0.0, 0.05]), ("AR", [-0.15, -0.2, 0.05])):
            for index in range(1, 4):
                n = int(rng.integers(22, 28))
                s = np.concatenate([np.zeros(6), 0.5 - 0.5 * np.cos(np.linspace(0, np.pi, n)), np.ones(14)])
                wrist = np.array([0.8, 0.2, 0.8]) + s[:, None] * np.array(goal)
                shoulder = np.full_like(wrist, [1.0, 0.2, 1.2])
                poses = np.stack([shoulder, 0.5 * (wrist + shoulder), wrist], axis=1)
                poses = poses + rng.normal(0.0, 1e-3, (len(s), 3, 3))
                points = np.zeros((len(s), 8, 3))
                points[:, rg.ARM] = poses
                out.append(rg._trial(person, kind, index, points))
    return out


def test_same_seed_same_numbers():
    first = rg.evaluate(_toy_trials(1), seed=3)
    second = rg.evaluate(_toy_trials(1), seed=3)
    assert first["rms_m"] == second["rms_m"]
    other = "other_person"
    assert first[other]["constant_velocity_rms_m"] == second[other]["constant_velocity_rms_m"]
    assert first[other]["rms_m"] == second[other]["rms_m"]
    assert first["gpdm_fits"] == 12 + 4  # one per held-out trial, one per (person, kind)
    assert np.isfinite(first["rms_m"]) and first["rms_m"] < first["hold_rms_m"]
