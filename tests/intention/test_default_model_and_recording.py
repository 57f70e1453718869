import numpy as np
import pytest

from hrc_drake.cell.intention_data import (
    box_usb_layout,
    random_layout,
    record_reaches,
    record_task_cycles,
)
from hrc_drake.intention.bayes import GoalIntentionEstimator
from hrc_drake.intention.dataset import reaches_of, training_samples
from hrc_drake.intention.evaluation import reach_outcomes, rises, run_estimator, table_3_1
from hrc_drake.intention.likelihood import DEFAULT_MODEL_PATH, default_model
from tests.intention.intention_reaches import GOALS, straight_reach


def test_shipped_model_loads_from_json_and_recognises_a_reach():
    assert DEFAULT_MODEL_PATH.suffix == ".json"
    model = default_model()
    assert model.gmm4d.n_features == 4 and model.gmm2d.n_features == 2
    assert np.isclose(model.gmm4d.weights.sum(), 1.0)
    estimator = GoalIntentionEstimator(GOALS, method="M3")  # default model
    times, points, gaze = straight_reach([0.85, 0.15, 0.9], GOALS[2], duration=1.0, noise=0.005, rng=0)
    for t, p, g in zip(times, points, gaze, strict=True):
        probabilities = estimator.update(t, p, g, True)
    assert probabilities[1].argmax() == 2


def test_recorded_reaches_are_labelled_and_give_finite_samples(diagrams_dir):
    rng = np.random.default_rng(123)
    layout = box_usb_layout(diagrams_dir / "box_usb.yaml")
    recording = record_reaches(layout, None, 4, rng, pattern=[0, 3, 0, 3])
    assert recording.points.shape == (len(recording.times), 8, 3)
    reaches = reaches_of(recording)
    assert [r.goal for r in reaches] == [0, 3, 0, 3]
    assert all(r.hand == 0 for r in reaches)  # goals 1 and 4 are left-hand goals
    phi = training_samples(recording)
    assert len(phi) > 20 and np.all(np.isfinite(phi))
    outcomes = reach_outcomes(recording, run_estimator(GoalIntentionEstimator(layout.centers), recording))
    row = table_3_1(outcomes, 3)
    assert row["reaches"] == 2 and 0.0 <= row["false_positives_pct"] <= 100.0


def test_random_layout_keeps_goals_apart():
    layout = random_layout(np.random.default_rng(0))
    gaps = np.linalg.norm(layout.centers[:, None] - layout.centers[None], axis=-1)
    assert np.all(gaps[~np.eye(5, dtype=bool)] >= 0.25)


def test_box_usb_layout_reads_the_scenario(diagrams_dir):
    layout = box_usb_layout(diagrams_dir / "box_usb.yaml")
    assert layout.name == "box_usb"
    assert layout.goal_names == ("g1_home", "g2_foam_a", "g3_foam_b", "g4_station", "g5_boxes")
    assert layout.index("g1_home") == 0 and layout.index("g4_station") == 3
    np.testing.assert_allclose(layout.centers[3], [0.52, 0.05, 0.82])
    assert layout.operator_base[:2] == (1.0, 0.0)
    assert layout.operator_base[2] == pytest.approx(np.pi, abs=1e-4)
    # facing -x the operator's left is -y: the foam feeders are on its left, the boxes on its right
    assert layout.hands[1] == "left" and layout.hands[4] == "right"
    assert layout.pattern == ("fill", "foam", "bring", "tape")
    bring = {t.name: t for t in layout.tasks}["bring"]
    assert bring.hand == "both" and bring.labels == (3,) and bring.duration[0] == 3.0
    tape = {t.name: t for t in layout.tasks}["tape"]
    assert tape.labels == (3, 0)
    # the face-height camera of the scenario (flag F valid most of the time)
    np.testing.assert_allclose(layout.camera_position, [0.05, 0.0, 1.45])
    with pytest.raises(ValueError, match="no goal"):
        layout.index("g9")


def test_task_cycles_label_two_handed_reaches_and_their_arrival(diagrams_dir):
    layout = box_usb_layout(diagrams_dir / "box_usb.yaml")
    assert layout.tasks
    rng = np.random.default_rng(5)
    recording = record_task_cycles(layout, None, 1, rng, noise_std=0.005)
    reaches = reaches_of(recording)
    station = [r for r in reaches if r.goal == 3]
    # bring reaches the station with both hands, each wrist beside the centre; tape starts there
    assert sorted(r.hand for r in station) == [0, 1]
    for r in station:
        arrived = recording.true_wrists[r.arrival, r.hand]
        assert 0.04 < np.linalg.norm(arrived - layout.centers[3]) < 0.2
        assert r.arrival > r.start + 3
    phi, flag = training_samples(recording, with_gaze_flag=True)
    assert phi.shape == (len(flag), 4) and flag.dtype == bool and np.all(np.isfinite(phi))
    # the approach phase only: no sample of a wrist lingering at its goal after the arrival
    everything = training_samples(recording, approach_only=False)
    assert len(everything) > len(phi)
    in_reach = sum(r.arrival + 1 - r.start for r in reaches)
    assert len(phi) <= in_reach


def test_rises_need_a_release_before_counting_again():
    p = np.array([0.2, 0.85, 0.79, 0.82, 0.4, 0.81, 0.9])
    assert rises(p[:, None])[:, 0].tolist() == [False, True, False, False, False, True, False]
