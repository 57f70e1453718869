"""The body calibrated as a cell would, from the operator's first seconds (`human.calibration`):
a seated person fits, nothing after the first seconds counts, and what the frames do not show keeps
the default."""

import numpy as np
import pytest

from hrc_drake.datasets import dataset_dir
from hrc_drake.human.body import BodyModel
from hrc_drake.human.calibration import CALIBRATION_SECONDS, calibrate_body, fit_errors
from hrc_drake.human.config import Segments
from hrc_drake.messages import L_ELBOW, L_WRIST, R_ELBOW, R_WRIST

RATE = 30.0


def _seated_motion(frames=150, seed=0):
    """A seated person (hip 0.55 m, their own arms) reaching about: points (T, 8, 3)."""
    body = BodyModel(Segments(upper_arm=0.29, forearm=0.24, shoulder_width=0.38, hip_height=0.55))
    rng = np.random.default_rng(seed)
    q = np.tile(body.rest_q(base_xy=(1.0, 0.0), yaw=np.pi), (frames, 1))
    t = np.arange(frames) / RATE
    q[:, 4:] += 0.4 * np.sin(2 * np.pi * 0.4 * t[:, None] + rng.uniform(0, 6, 8))
    q = np.clip(q, body.q_lower, body.q_upper)
    return body, body.points(q)


def test_a_seated_person_fits_once_calibrated():
    truth, points = _seated_motion()
    calibration = calibrate_body(points, RATE)
    assert calibration.seated and calibration.frames == int(CALIBRATION_SECONDS * RATE)
    segments = calibration.segments
    assert segments.hip_height == pytest.approx(0.55, abs=0.01)
    assert segments.upper_arm == pytest.approx(0.29, abs=1e-6)
    assert segments.forearm == pytest.approx(0.24, abs=1e-6)
    calibrated = np.nanmedian(fit_errors(BodyModel(segments), points))
    standing = np.nanmedian(fit_errors(BodyModel(), points))
    assert calibrated < 0.005 < 0.02 < standing


def test_a_real_seated_recording_fits_within_3_cm():
    from hrc_drake.human.importers import Placement, place_in_cell, read_ue_adl, resample, synthesize_missing

    path = dataset_dir("ue_adl") / "ADL004" / "ADL004FR1.csv"
    placed, _, _ = place_in_cell(synthesize_missing(read_ue_adl(path)), Placement())
    points = resample(placed, RATE).points
    calibration = calibrate_body(points, RATE)
    assert calibration.seated
    calibrated = np.nanmedian(fit_errors(BodyModel(calibration.segments), points))
    assert calibrated < 0.03 and calibrated < np.nanmedian(fit_errors(BodyModel(), points))


def test_only_the_first_seconds_count():
    _, points = _seated_motion()
    before = calibrate_body(points, RATE)
    later = points.copy()
    cut = int(CALIBRATION_SECONDS * RATE)
    later[cut:] += np.array([0.0, 0.0, -0.3])  # the person stands up, slides away, changes
    later[cut:, [L_WRIST, R_WRIST]] = later[cut:, [L_ELBOW, R_ELBOW]] + 0.5
    assert calibrate_body(later, RATE) == before
    earlier = points.copy()
    earlier[: cut // 2, [L_WRIST, R_WRIST]] += 0.05
    assert calibrate_body(earlier, RATE).segments.forearm != before.segments.forearm


def test_what_the_first_seconds_do_not_show_keeps_the_default():
    _, points = _seated_motion()
    points[:60, [L_WRIST, R_WRIST]] = np.nan
    calibration = calibrate_body(points, RATE)
    assert calibration.defaulted == ("forearm",) and calibration.segments.forearm == Segments().forearm
    points[:60] = np.nan
    nothing = calibrate_body(points, RATE)
    assert set(nothing.defaulted) == {"upper_arm", "forearm", "shoulder_width", "hip_height"}
    assert not nothing.seated
    with pytest.raises(ValueError, match="must be"):
        calibrate_body(points[:, :6], RATE)
    with pytest.raises(ValueError, match="positive"):
        calibrate_body(points, 0.0)


def test_a_hip_height_outside_a_person_is_refused():
    with pytest.raises(ValueError, match="hip_height"):
        BodyModel(Segments(hip_height=0.1))
    with pytest.raises(ValueError, match="hip_height"):
        BodyModel(Segments(hip_height=float("nan")))
    assert BodyModel(Segments(hip_height=0.0)).hip_height == BodyModel().hip_height


@pytest.mark.parametrize("hip, refused", [(0.0, False), (0.3, False), (1.5, False), (0.299, True),
                                          (1.51, True), (float("nan"), True), (-0.5, True)])
def test_validate_takes_a_seated_hip_only_within_a_persons_range(diagrams_dir, hip, refused):
    from hrc_drake.cell.scenario import ScenarioError, load_scenario_with

    overrides = {"operator": {"segments": {"hip_height": hip}}}
    if refused:
        with pytest.raises(ScenarioError, match="operator.segments.hip_height"):
            load_scenario_with(diagrams_dir / "pcb_ic.yaml", overrides)
    else:
        scenario = load_scenario_with(diagrams_dir / "pcb_ic.yaml", overrides)
        assert scenario.operator.segments.hip_height == hip
