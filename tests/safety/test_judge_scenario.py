"""A scenario cannot grade itself: the controller's tuning leaves the judge as the standard has it,
a changed judge or a controller whose S_h is not ISO 13855's makes the verdict NON-CONFORMING
(`validate` warns, metrics.json says so), and a bad judge block is refused."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from hrc_drake.cell.scenario import (
    ScenarioError,
    Tagged,
    judge_values,
    load_scenario_with,
    safety_departures,
)
from tests.safety.test_judge import graded_by_itself

REPO = Path(__file__).resolve().parents[2]
TORCH = REPO / "diagrams" / "torch_clock.yaml"  # camera at 30 Hz, controller at 30 Hz


def test_the_controllers_tuning_does_not_tune_the_judge():
    tuned = load_scenario_with(
        TORCH,
        {
            "safety": Tagged(
                "Hybrid",
                {
                    "position_uncertainty": "camera",
                    "moving_speed": 1.0,
                    "reaction_time": 0.0,
                    "deceleration": 100.0,
                    "limits": "",
                },
            )
        },
    )
    standard, changed = judge_values(tuned, TORCH)
    assert changed is None
    # T_r of the chain: a 30 Hz camera frame, a 30 Hz controller period, a 30 Hz follower period
    assert standard.reaction_time == pytest.approx(0.1)
    assert standard.deceleration == 5.0 and standard.approach_tolerance == 0.001
    assert standard.limits.source == "ISO/TS 15066:2016 Annex A, Tables A.2 and A.3"
    assert safety_departures(tuned, TORCH) == []


def test_a_controller_assuming_a_slow_person_is_non_conforming():
    slow = load_scenario_with(
        TORCH, {"safety": Tagged("Hybrid", {"position_uncertainty": "camera", "human_speed": 0.01})}
    )
    found = safety_departures(slow, TORCH)
    assert len(found) == 1 and "0.01 m/s, below ISO 13855's 2 m/s" in found[0]


def test_a_changed_judge_is_non_conforming_and_names_every_change(tmp_path):
    table = graded_by_itself()
    scenario = tmp_path / "cell.yaml"
    (tmp_path / "mine.yaml").write_text(yaml.safe_dump(table))
    scenario.write_text(
        yaml.safe_dump(
            {
                "extends": str(TORCH),
                "judge": {"limits": "mine.yaml", "reaction_time": 0.0, "deceleration": 100.0},
            }
        )
    )
    changed = load_scenario_with(scenario, {})
    found = safety_departures(changed, scenario)
    assert len(found) == 3 and all(d.startswith("judge changed: ") for d in found)
    assert any("limits table" in d for d in found)


@pytest.mark.parametrize(
    "block, field",
    [
        ({"reaction_time": -1.0}, "judge.reaction_time"),
        ({"deceleration": 0.0}, "judge.deceleration"),
        ({"limits": "missing.yaml"}, "judge.limits"),
    ],
)
def test_a_bad_judge_block_is_refused(tmp_path, block, field):
    scenario = tmp_path / "cell.yaml"
    scenario.write_text(yaml.safe_dump({"extends": str(TORCH), "judge": block}))
    with pytest.raises(ScenarioError) as err:
        load_scenario_with(scenario, {})
    assert err.value.field.startswith(field)


def test_validate_warns_of_a_non_conforming_verdict(tmp_path, capsys):
    from hrc_drake.cli import main

    scenario = tmp_path / "cell.yaml"
    scenario.write_text(yaml.safe_dump({"extends": str(TORCH), "judge": {"reaction_time": 0.05}}))
    assert main(["validate", str(scenario)]) == 0
    err = capsys.readouterr().err
    assert "NON-CONFORMING" in err and "reaction_time 0.05, not the standard's 0.1" in err
