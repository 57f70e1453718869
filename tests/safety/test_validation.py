"""`validate` refuses a safety mode a cell cannot run, and a bad limits table."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from hrc_drake.cell.scenario import ScenarioError, Tagged, load_scenario, load_scenario_with

REPO = Path(__file__).resolve().parents[2]
TORCH = REPO / "diagrams" / "torch_clock.yaml"  # no tracker, no motion model
PCB = REPO / "diagrams" / "pcb_occlusion.yaml"  # a particle filter


def _refused(path, overrides) -> ScenarioError:
    with pytest.raises(ScenarioError) as err:
        load_scenario_with(path, overrides)
    return err.value


def test_z_d_from_a_tracker_needs_one():
    err = _refused(TORCH, {"safety": Tagged("SpeedSeparationMonitoring",
                                            {"position_uncertainty": "tracker"})})
    assert err.field == "safety.position_uncertainty" and "no tracker" in err.reason
    load_scenario_with(PCB, {"safety": Tagged("SpeedSeparationMonitoring",
                                              {"position_uncertainty": "tracker"})})


def test_swept_volumes_need_a_motion_model():
    err = _refused(TORCH, {"safety": Tagged("SpeedSeparationMonitoring",
                                            {"position_uncertainty": "camera",
                                             "human_motion": "swept_volumes"})})
    assert err.field == "safety.human_motion"


def test_a_hybrid_mode_needs_collaborative_zones():
    hybrid = Tagged("Hybrid", {"position_uncertainty": "camera"})
    err = _refused(TORCH, {"layout": {"collaborative_zones": []}, "safety": hybrid})
    assert err.field == "safety" and "collaborative_zones" in err.reason


def test_an_unknown_body_region_is_refused():
    err = _refused(TORCH, {"safety": Tagged("Hybrid", {"position_uncertainty": "camera",
                                                       "pfl_regions": ["hand_fingers", "tail"]})})
    assert err.field == "safety.pfl_regions[1]" and "tail" in err.reason
    err = _refused(TORCH, {"safety": Tagged("Hybrid", {"position_uncertainty": "camera",
                                                       "pfl_regions": ["face"]})})
    assert err.field == "safety.pfl_regions[0]"


@pytest.mark.parametrize("field, value", [("deceleration", 0.0), ("reaction_time", -0.1), ("rate", 80.0),
                                          ("position_uncertainty", "psychic"), ("robot_mass", "guess"),
                                          ("contact_reaction", "yes"), ("retreat_speed", 1.5),
                                          ("retreat_speed", -0.1), ("retreat_time", float("nan")),
                                          ("contact_hold", 61.0), ("speed_profile", "clairvoyant"),
                                          ("preview_step", 0.0), ("preview_horizon", 0.05),
                                          ("preview_horizon", 5.5), ("planning_deceleration", 0.0),
                                          ("planning_deceleration", 5.01), ("clamped_approach", "push"),
                                          ("preview_human", "oracle"), ("clamp_margin", 0.0199),
                                          ("clamp_margin", 0.5001)])
def test_bad_numbers_and_names_are_refused(field, value):
    err = _refused(TORCH, {"safety": Tagged("Hybrid", {"position_uncertainty": "camera", field: value})})
    assert err.field == f"safety.{field}"


def test_a_bad_limits_table_is_refused(tmp_path):
    from importlib import resources

    document = yaml.safe_load(resources.files("hrc_drake.safety").joinpath("iso_ts_15066.yaml").read_text())
    document["regions"]["hand_fingers"]["force"] = "a lot"
    bad = tmp_path / "limits.yaml"
    bad.write_text(yaml.safe_dump(document))
    err = _refused(TORCH, {"safety": Tagged("Hybrid", {"position_uncertainty": "camera",
                                                       "limits": str(bad)})})
    assert err.field == "safety.limits" and "regions.hand_fingers.force" in err.reason
    err = _refused(TORCH, {"safety": Tagged("Hybrid", {"position_uncertainty": "camera",
                                                       "limits": str(tmp_path / "missing.yaml")})})
    assert err.field == "safety.limits" and "no such" in err.reason


def test_the_cli_validate_refuses_what_simulate_would(tmp_path, capsys):
    from hrc_drake.cli import main

    scenario = tmp_path / "cell.yaml"
    scenario.write_text(f"extends: {TORCH}\nsafety: !SpeedSeparationMonitoring {{}}\n")
    assert main(["validate", str(scenario)]) == 2
    assert "safety.position_uncertainty" in capsys.readouterr().err


def test_every_shipped_cell_declares_a_safety_mode():
    from hrc_drake.safety.config import NoSafety

    for path in sorted((REPO / "diagrams").glob("*.yaml")):
        scenario = load_scenario(path)
        assert not isinstance(scenario.safety, NoSafety), f"{path.name} declares no safety mode"


def test_the_speed_profile_s_edges():
    """The planning deceleration may reach the stop's (5 m/s^2 here), not pass it; the horizon is at
    least one preview step and at most 20 of them."""
    def hybrid(**fields):
        return {"safety": Tagged("Hybrid", {"position_uncertainty": "camera", "speed_profile": "predictive",
                                            **fields})}

    assert load_scenario_with(TORCH, hybrid(planning_deceleration=5.0)).safety.preview_steps() == 5
    assert load_scenario_with(TORCH, hybrid(preview_horizon=0.1)).safety.preview_steps() == 1
    assert load_scenario_with(TORCH, hybrid(preview_horizon=2.0)).safety.preview_steps() == 20
    err = _refused(TORCH, hybrid(preview_horizon=2.1))
    assert err.field == "safety.preview_horizon" and "at most 20" in err.reason
    reactive = load_scenario_with(TORCH, {"safety": Tagged("Hybrid", {"position_uncertainty": "camera"})})
    assert reactive.safety.preview_steps() == 0


def test_swept_volumes_in_the_preview_need_a_motion_model():
    """torch_clock has no motion model: its preview cannot read swept volumes (refused, not ignored)."""
    err = _refused(TORCH, {"safety": Tagged("Hybrid", {"position_uncertainty": "camera",
                                                       "speed_profile": "predictive",
                                                       "preview_human": "swept_volumes"})})
    assert err.field == "safety.preview_human" and "motion_model" in err.reason


def test_the_clamp_margin_may_not_be_below_the_judges():
    """A scenario cannot weaken the controller's clamping tests below the judge's 2 cm margin: the
    edges of [0.02, 0.5] m are accepted, just outside them refused (above)."""
    from hrc_drake.safety.config import PowerForceLimiting

    for margin in (0.02, 0.5):
        PowerForceLimiting(clamp_margin=margin).validate("safety")
