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


def test_the_begin_is_detected_from_the_past_only():
    rate = 30.0
    wrist = np.zeros((60, 3))
    wrist[20:, 0] = np.arange(40) * 0.5 / rate  # 0.5 m/s from frame 20
    begin = rg.causal_start(wrist, rate)
    assert begin is not None and 20 <= begin <= 20 + rg.CAUSAL_WINDOW
    later = wrist.copy()
    later[begin + 1 :] = 9.0
    assert rg.causal_start(later, rate) == begin
    assert rg.causal_start(np.zeros((60, 3)), rate) is None


def test_the_mean_of_other_reaches_is_time_aligned_at_their_begins():
    a = np.zeros((4, 3, 3))
    b = np.ones((6, 3, 3))
    c = np.full((8, 3, 3), 2.0)
    mean = rg.mean_of_reaches([a, b, c])
    assert mean.shape == (6, 3, 3)  # the median length
    assert np.allclose(mean[0], 1.0) and np.allclose(mean[5], 1.0)  # a holds its last pose


def test_the_differences_are_negative_when_the_gpdm_wins_and_have_intervals_over_people():
    def errors(gpdm, other):
        block = lambda v: {"horizon": np.full((4, 3), v), "remaining": np.zeros((0, 3))}  # noqa: E731
        return {"gpdm": block(gpdm), "constant_velocity": block(other), "mean_of_other_reaches": block(other)}

    by_person = {"p1": [errors(0.01, 0.04)], "p2": [errors(0.02, 0.05)], "p3": [errors(0.01, 0.04)]}
    out = rg.person_differences(by_person)
    assert out["rms_m_minus_constant_velocity"] < 0
    low, high = out["rms_m_minus_constant_velocity.ci95"]
    assert low <= out["rms_m_minus_constant_velocity"] <= high < 0
    alone = rg.person_differences({"p1": by_person["p1"]})
    assert alone["rms_m_minus_constant_velocity.ci95"] is None
