import numpy as np

from hrc_drake.intention.bayes import GoalIntentionEstimator
from hrc_drake.intention.evaluation import reach_outcomes, run_estimator, table_3_1
from hrc_drake.intention.layouts import box_usb_layout, random_layout
from hrc_drake.intention.likelihood import DEFAULT_MODEL_PATH, default_model
from hrc_drake.intention.recording import reaches_of, record_reaches, training_samples
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


def test_recorded_reaches_are_labelled_and_give_finite_samples():
    rng = np.random.default_rng(123)
    layout = box_usb_layout()
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
