"""Issue 54 item 2: each action's time has one place, and `extends:` patches list items by name.

The operator's time is `operator.actions[..].duration`, a robot's its motion plus the dwell; a
flow `duration` is only a timed scheduler's prior, refused where nothing reads it. A mapping
given for a list of named items patches the parent's items of those names."""

from dataclasses import replace

import pytest

from hrc_drake.cell.scenario import ScenarioError, load_scenario, load_scenario_with
from hrc_drake.cli import EXIT_BAD_INPUT, main
from hrc_drake.scheduling.compiler import net_from_scenario
from hrc_drake.scheduling.config import MonteCarloScheduler
from tests.conftest import DIAGRAMS


def _parent(tmp_path, name="torch_clock.yaml"):
    """A shipped scenario copied into `tmp_path` (a parent a child file extends by its name)."""
    path = tmp_path / name
    path.write_text((DIAGRAMS / name).read_text())
    return path


def _child(tmp_path, text, parent="torch_clock.yaml", name="child.yaml"):
    _parent(tmp_path, parent)
    path = tmp_path / name
    path.write_text(f"extends: {parent}\n{text}")
    return path


def _refused(path) -> ScenarioError:
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert info.value.file == str(path)
    return info.value


# ---------------------------------------------------------------- patches by name: the hard cases


def test_a_name_two_items_share_is_refused_naming_both(tmp_path):
    # pcb_collab's robot has a 'check' motion on each arm (one name per arm, not per robot)
    err = _refused(_child(tmp_path, "robots: {yumi: {actions: {check: {dwell: 1.0}}}}\n", "pcb_collab.yaml"))
    assert err.field == "robots.yumi.actions.check"
    assert "'check' names 2 items of robots.yumi.actions ([1], [2])" in err.reason
    assert "give the whole list" in err.reason


def test_a_mapping_for_a_list_of_plain_values_is_refused(tmp_path):
    err = _refused(_child(tmp_path, "operator: {pattern: {H1: H2}}\n"))
    assert err.field == "operator.pattern"
    assert "list of plain values ['H1', 'H4', 'H2', 'H5', ...]" in err.reason
    assert "give the whole list" in err.reason


def test_a_nested_list_is_patched_inside_the_item_patched(tmp_path):
    base = load_scenario(_parent(tmp_path))
    joints = [0.1, -2.27, 2.36, 0.52, 0.0, 0.69, 0.0]
    child = load_scenario(_child(tmp_path, "robots:\n  yumi:\n    actions: {R1: {dwell: 2.5}}\n"
                                           f"    poses: {{r_clear: {{joints: {joints}}}}}\n"))
    robot, parent = child.robots[0], base.robots[0]
    assert [(a.name, a.dwell) for a in robot.actions][0] == ("R1", 2.5) != (parent.actions[0].name,
                                                                            parent.actions[0].dwell)
    assert robot.actions[0].poses == parent.actions[0].poses and robot.actions[1:] == parent.actions[1:]
    pose = next(p for p in robot.poses if p.name == "r_clear")
    assert pose.joints == joints and len(robot.poses) == len(parent.poses)
    assert [p for p in robot.poses if p.name != "r_clear"] == [p for p in parent.poses if p.name != "r_clear"]
    assert robot.arms == parent.arms and child.operator == base.operator


@pytest.mark.parametrize("text, field, reason", [
    ("operator: {actions: {H1: {name: H9}}}\n", "operator.actions.H1.name", "cannot rename"),
    ("operator: {actions: {H1: fast}}\n", "operator.actions.H1", "expected a mapping of the fields"),
    ("layout: {occluders: {shelf: {size: [1, 1, 1]}}}\n", "layout.occluders.shelf", "the list is empty"),
])
def test_bad_patches_are_refused(tmp_path, text, field, reason):
    err = _refused(_child(tmp_path, text))
    assert err.field == field and reason in err.reason


def test_a_mapping_for_a_list_without_a_parent_says_patches_need_extends(tmp_path):
    path = tmp_path / "alone.yaml"
    path.write_text("operator: {actions: {H1: {duration: {kind: fixed, mean: 3.0}}}}\n")
    err = _refused(path)
    assert err.field == "operator.actions" and "expected a list, got dict" in err.reason
    assert "only in a file that `extends:`" in err.reason


# ------------------------------------------------------------------------ patches by name: the use


def test_an_item_patched_by_name_keeps_its_other_fields_and_the_other_items(tmp_path):
    base = load_scenario(_parent(tmp_path))
    patch = "operator: {actions: {H1: {duration: {kind: fixed, mean: 3.0}}}}\n"
    child = load_scenario(_child(tmp_path, patch))
    h1, parent_h1 = child.operator.actions[0], base.operator.actions[0]
    assert (h1.name, h1.duration.kind, h1.duration.mean) == ("H1", "fixed", 3.0)
    assert parent_h1.duration.kind == "normal"
    assert replace(h1, duration=parent_h1.duration) == parent_h1  # goals, hand, region kept
    assert child.operator.actions[1:] == base.operator.actions[1:]
    assert child.operator.pattern == base.operator.pattern and child.flow == base.flow


def test_an_unknown_name_is_refused_naming_the_field_and_the_known_names(tmp_path):
    err = _refused(_child(tmp_path, "operator: {actions: {H9: {duration: {kind: fixed, mean: 3.0}}}}\n"))
    assert err.field == "operator.actions.H9"
    assert "no item of operator.actions is named 'H9' (its names: H1, H2, H3, H4, H5)" in err.reason


def test_a_robots_arms_are_patched_by_agent(tmp_path):
    base = load_scenario(_parent(tmp_path))
    patch = "robots: {yumi: {arms: {yumi_right: {program: [R1, R3, R2, R4, R1]}}}}\n"
    child = load_scenario(_child(tmp_path, patch))
    arms = {arm.agent: arm for arm in child.robots[0].arms}
    assert arms["yumi_right"].program == ["R1", "R3", "R2", "R4", "R1"]
    assert arms["yumi_left"] == next(a for a in base.robots[0].arms if a.agent == "yumi_left")


def test_an_error_after_a_list_was_replaced_says_extends_replaced_it(tmp_path):
    """The new user's first try: one operator action given as a list drops the other four."""
    one = ("operator:\n  actions:\n    - {name: H1, hand: left, goals: [torch_front, body_feeder, bench, "
           "torch_body], duration: {kind: fixed, mean: 9.0}}\n")
    err = _refused(_child(tmp_path, one))
    assert err.field == "operator.pattern[1]" and "unknown operator action 'H4'" in err.reason
    assert "the whole list operator.actions (without the parent's H2, H3, H4, H5)" in err.reason
    assert "replaced the one of torch_clock.yaml" in err.reason
    assert "a mapping by name patches" in err.reason and "operator: {actions: {H1: {...}}}" in err.reason


def test_an_error_unrelated_to_a_list_given_whole_and_complete_has_no_note(tmp_path):
    base = load_scenario(_parent(tmp_path))
    pattern = ", ".join(base.operator.pattern)
    err = _refused(_child(tmp_path, f"operator: {{pattern: [{pattern}]}}\nseed: -1\n"))
    assert err.field == "seed" and "note" not in err.reason


def test_overrides_patch_items_by_name_too(tmp_path):
    path = _parent(tmp_path)
    scenario = load_scenario_with(path, {"operator": {"actions": {"H2": {"hand": "left"}}}})
    assert [a.hand for a in scenario.operator.actions] == ["left", "left", "left", "left", "right"]
    with pytest.raises(ScenarioError) as info:
        load_scenario_with(path, {"operator": {"actions": {"H7": {"hand": "left"}}}})
    assert info.value.field == "operator.actions.H7" and "(in the overrides)" in info.value.reason


# ------------------------------------------------------------------------- one place for each time


def _flow_duration(tmp_path, action, scheduler="", parent="torch_clock.yaml"):
    """A child of `parent` whose flow gives `action` a duration (and `scheduler`, if any)."""
    text = f"flow: {{actions: {{{action}: {{duration: {{kind: fixed, mean: 4.0}}}}}}}}\n" + scheduler
    return _child(tmp_path, text, parent)


@pytest.mark.parametrize("action, parent, scheduler, field, said", [
    ("R1", "torch_clock.yaml", "", "flow.actions[0].duration",
     ["'R1' is a robot action", "yumi_right's motion through robots[0].actions[0].poses plus "
      "robots[0].actions[0].dwell at each", "the cell has no scheduler", "or set the dwell"]),
    ("H1", "torch_clock.yaml", "", "flow.actions[1].duration",
     ["'H1' is an operator action", "its time is operator.actions[0].duration", "the cell has no scheduler"]),
    ("H1", "torch_clock.yaml", "scheduler: !RoundRobinScheduler {wait_quantum: 5.0}\n",
     "flow.actions[1].duration", ["!RoundRobinScheduler reads none"]),
    ("R_check", "pcb_ic.yaml", "", "flow.actions[1].duration",
     ["'R_check' is a robot action", "!PredictiveRobotScheduler reads none"]),
    ("L1", "torch_clock.yaml", "scheduler: !RandomEnabledScheduler {}\n", "flow.actions[2].duration",
     ["'L1' is a robot action", "!RandomEnabledScheduler reads none"]),
])
def test_a_flow_duration_nothing_reads_is_refused_saying_where_the_time_comes_from(tmp_path, action, parent,
                                                                                  scheduler, field, said):
    err = _refused(_flow_duration(tmp_path, action, scheduler, parent))
    assert err.field == field, err
    for text in said:
        assert text in err.reason, err
    assert "only the prior of a timed scheduler (!MonteCarloScheduler" in err.reason
    assert f"clears it with flow: {{actions: {{{action}: {{duration: null}}}}}}" in err.reason


def test_a_shared_action_under_a_round_robin_names_both_times(tmp_path):
    robin = "scheduler: !RoundRobinScheduler {programs: {yumi_left: [fuse, check]}}\n"
    err = _refused(_child(tmp_path, robin, "pcb_collab.yaml"))
    assert err.field == "flow.actions[0].duration"  # the first of its four: fuse
    cleared = "flow: {actions: {fuse: {duration: null}, ic: {duration: null}, check: {duration: null}}}\n"
    err = _refused(_child(tmp_path, robin + cleared, "pcb_collab.yaml"))
    assert err.field == "flow.actions[3].duration"
    assert "'collab' is an action of the operator and robots" in err.reason
    assert "operator.actions[1].duration and yumi_left's motion" in err.reason
    assert "yumi_right's motion" in err.reason
    # the fourth cleared too: the round robin runs the flow's structure alone
    everything = cleared.replace("}}}\n", "}, collab: {duration: null}}}\n")
    scenario = load_scenario(_child(tmp_path, robin + everything, "pcb_collab.yaml"))
    assert all(a.duration is None for a in scenario.flow.actions)


def test_a_timed_scheduler_keeps_the_flow_durations_as_its_prior(tmp_path):
    scenario = load_scenario(_flow_duration(tmp_path, "R1", "scheduler: !MonteCarloScheduler {}\n"))
    net = net_from_scenario(scenario, scenario.scheduler)
    prior = net.delays[net.transition_index["R1:end"]]
    assert (prior.kind, prior.mean) == ("fixed", 4.0)


def test_without_a_flow_duration_the_prior_is_the_operators_duration(tmp_path):
    scenario = load_scenario(_child(tmp_path, "scheduler: !MonteCarloScheduler {}\n"))
    net = net_from_scenario(scenario, MonteCarloScheduler())
    operator = {a.name: a.duration for a in scenario.operator.actions}
    assert net.delays[net.transition_index["H1#0:end"]] == operator["H1"]
    assert net.delays[net.transition_index["H3#4:end"]] == operator["H3"]
    robot = net.delays[net.transition_index["R1:end"]]
    assert (robot.kind, robot.mean) == ("fixed", 1.0)  # a robot's prior, when the flow gives none


def test_validate_and_simulate_refuse_the_same_file(tmp_path, capsys):
    path = _flow_duration(tmp_path, "R1")
    capsys.readouterr()
    assert main(["validate", str(path)]) == EXIT_BAD_INPUT
    refused = capsys.readouterr().err
    assert main(["simulate", str(path), "--duration", "1", "--out", str(tmp_path / "out")]) == EXIT_BAD_INPUT
    assert "flow.actions[0].duration" in refused and capsys.readouterr().err == refused


@pytest.mark.slow
def test_the_durations_refused_change_nothing_in_a_run(tmp_path):
    """What validation refuses is what the cell never reads: the same run with and without them
    (a scenario made in code is not validated, so it can carry them)."""
    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.run import simulate
    from hrc_drake.distributions import Distribution

    scenario = load_scenario(DIAGRAMS / "torch_clock.yaml")
    odd = Distribution(kind="fixed", mean=0.5)  # far from any real time of the cell
    timed = replace(scenario, flow=replace(scenario.flow, actions=[replace(a, duration=odd)
                                                                   for a in scenario.flow.actions]))
    timed.source_path = scenario.source_path
    runs = [simulate(build_cell(s, s.source_path), 40.0, progress=None) for s in (scenario, timed)]
    events = [[(e.time, e.agent, e.action, e.kind) for e in run.log.events] for run in runs]
    assert len(events[0]) > 10 and events[0] == events[1]


# ------------------------------------------------------------------------------ shipped examples


def _shipped(folder=""):
    return sorted((DIAGRAMS / folder).glob("*.yaml"))


@pytest.mark.parametrize("path", _shipped() + _shipped("variants"), ids=lambda p: p.name)
def test_every_shipped_scenario_validates(path):
    scenario = load_scenario(path)
    assert scenario.flow.actions


@pytest.mark.parametrize("path", _shipped("campaigns"), ids=lambda p: p.name)
def test_every_shipped_campaign_validates_with_its_variants(path):
    from hrc_drake.campaign.spec import load_campaign

    assert load_campaign(path).variants  # loads every scenario with every variant


@pytest.mark.parametrize("path", _shipped("searches"), ids=lambda p: p.name)
def test_every_shipped_search_validates(path):
    from hrc_drake.search.spec import load_search

    assert load_search(path).parameters


def test_the_shipped_timed_cells_give_their_schedulers_priors():
    """Where a timed scheduler runs, the flow durations are its priors: torch_clock_fuzzy gives
    torch_clock's former ones by name, so its runs are as before."""
    fuzzy = load_scenario(DIAGRAMS / "torch_clock_fuzzy.yaml")
    priors = {a.name: (a.duration.kind, a.duration.mean) for a in fuzzy.flow.actions}
    assert priors["R1"] == ("fixed", 9.0) and priors["H5"] == ("normal", 11.0) and len(priors) == 12

