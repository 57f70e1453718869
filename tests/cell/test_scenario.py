import copy
from dataclasses import replace

import pytest

from hrc_drake.cell.scenario import (  # tag-aware (the cells' !Hybrid)
    ScenarioError,
    _raw_document,
    dump_raw,
    load_scenario,
)
from hrc_drake.cli import main

SCENARIOS = ["torch_clock.yaml", "box_usb.yaml", "pcb_occlusion.yaml", "pcb_collab.yaml", "carts.yaml",
             "torch_clock_fuzzy.yaml"]


@pytest.fixture(scope="module")
def torch_raw(request):
    from tests.conftest import DIAGRAMS

    return _raw_document((DIAGRAMS / "torch_clock.yaml").read_text())


def write(tmp_path, raw, name="bad.yaml"):
    path = tmp_path / name
    path.write_text(dump_raw(raw))
    return path


@pytest.mark.parametrize("name", SCENARIOS)
def test_shipped_scenarios_load(diagrams_dir, name):
    path = diagrams_dir / name
    if not path.exists():
        pytest.skip(f"{name} not in diagrams/")
    scenario = load_scenario(path)
    assert scenario.robots and scenario.flow.actions


def mutate(raw, edit):
    raw = copy.deepcopy(raw)
    edit(raw)
    return raw


def _op_action(raw, name):
    return next(a for a in raw["operator"]["actions"] if a["name"] == name)


def _add_orphan_input(raw, action_name):
    """A buffer nothing ever fills, made an input of `action_name`."""
    raw["layout"]["buffers"].append({"name": "orphan", "capacity": 1, "position": [0.5, 0.0, 0.76]})
    action = next(a for a in raw["flow"]["actions"] if a["name"] == action_name)
    action["inputs"].append("orphan")


BAD = {
    "unknown key": (
        lambda r: _op_action(r, "H1").update(duraton={"kind": "fixed", "mean": 1.0}),
        "operator.actions[0].duraton",
        "unknown key",
    ),
    "unknown goal": (
        lambda r: _op_action(r, "H2")["goals"].__setitem__(1, "nowhere"),
        "operator.actions[1].goals[1]",
        "unknown goal or buffer 'nowhere'",
    ),
    "unknown buffer": (
        lambda r: r["flow"]["actions"][0]["outputs"].__setitem__(0, "no_such_buffer"),
        "flow.actions[0].outputs[0]",
        "unknown buffer 'no_such_buffer'",
    ),
    "unknown pose": (
        lambda r: r["robots"][0]["actions"][0]["poses"].__setitem__(0, "r_nowhere"),
        "robots[0].actions[0].poses[0]",
        "unknown pose 'r_nowhere'",
    ),
    "zero duration": (
        lambda r: _op_action(r, "H3")["duration"].update(kind="fixed", mean=0.0),
        "operator.actions[2].duration.mean",
        "must be positive",
    ),
    "negative duration": (
        lambda r: r["flow"]["actions"][1].update(duration={"kind": "normal", "mean": -3.0}),
        "flow.actions[1].duration.mean",
        "must be positive",
    ),
    "unsuppliable inputs": (
        lambda r: _add_orphan_input(r, "R2"),
        "flow.actions[4].inputs",
        "can never start",
    ),
    "wrong type": (
        lambda r: r.update(seed="seven"),
        "seed",
        "expected a number",
    ),
    "unknown robot model": (
        lambda r: r["robots"][0].update(model="ur5"),
        "robots[0].model",
        "unknown robot model 'ur5'; known models: cart, irb140, panda, ur5e, yumi (or give `urdf:`, your "
        "own robot)",
    ),
    "unknown arm of the model": (
        lambda r: r["robots"][0]["poses"][0].update(arm="arm"),
        "robots[0].poses[0].arm",
        "unknown arm 'arm' of yumi",
    ),
    "joints per arm from the registry": (
        lambda r: r["robots"][0]["poses"][0].update(joints=[0.0] * 6),
        "robots[0].poses[0].joints",
        "expected 7 joint values, got 6",
    ),
    "old spelling of an unknown scheduler": (
        lambda r: r.update(scheduler={"kind": "psychic"}),
        "scheduler",
        "the old spelling {kind: ..., params: ...} is no longer read",
    ),
    "old spelling of a scheduler": (
        lambda r: r.update(scheduler={"kind": "monte_carlo", "params": {"n_trials": 40, "wait_quantum": 2}}),
        "scheduler",
        "scheduler: !MonteCarloScheduler {wait_quantum: 2.0, n_trials: 40}",
    ),
    "a system without a tag": (
        lambda r: r.update(tracker={"particles": 30}),
        "tracker",
        "choose a kind with a tag",
    ),
}


TAGGED_BAD = {
    "unknown kind": ("tracker: !Psychic {}", "tracker", "unknown kind !Psychic"),
    "unknown field of a kind": (
        "scheduler: !MonteCarloScheduler {n_trails: 40}",
        "scheduler.n_trails",
        "unknown key 'n_trails'",
    ),
    "bad value of a kind": (
        "tracker: !ParticleFilterTracker {particles: 0}",
        "tracker.particles",
        "particles",
    ),
    "wrong type in a kind": (
        "predictor: !HigherOrderMarkovPredictor {order: 2.5}",
        "predictor.order",
        "integer",
    ),
    "feedback names a goal that is not there": (
        "intention: !GmmBayesIntention {feedback_sequence: [nowhere]}",
        "intention.feedback_sequence[0]",
        "unknown goal 'nowhere'",
    ),
    "a motion model's bad variant": (
        "motion_model: !GPMotionModel {variant: D}",
        "motion_model.variant",
        "D",
    ),
}


@pytest.mark.parametrize("case", sorted(TAGGED_BAD))
def test_bad_tagged_systems_name_file_field_and_reason(tmp_path, torch_raw, case):
    line, field, reason = TAGGED_BAD[case]
    path = write(tmp_path, torch_raw)
    path.write_text(path.read_text() + line + "\n")
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert str(path) in str(info.value)
    assert info.value.field == field
    assert reason in str(info.value)


def test_every_kind_of_every_system_is_reachable_by_its_tag(tmp_path, torch_raw):
    import typing

    from hrc_drake.cell.schema import SYSTEM_FIELDS, Scenario
    from hrc_drake.scheduling.config import COLLABORATION_SCHEDULERS

    hints = typing.get_type_hints(Scenario)
    for name in SYSTEM_FIELDS:
        for kind in typing.get_args(hints[name]):
            if name == "action_detector" and kind.__name__ != "NoActionDetector":
                continue  # torch_clock's actions reach buffers, not goal spheres: see the next test
            if kind in COLLABORATION_SCHEDULERS:
                continue  # the use case a robots name its actions: see test_use_case_a_robots_...
            path = write(tmp_path, {key: value for key, value in torch_raw.items() if key != name})
            path.write_text(path.read_text() + f"{name}: !{kind.__name__} {{}}\n")
            if name == "safety" and kind.__name__ != "NoSafety":  # read by its tag, then its own check
                with pytest.raises(ScenarioError, match="safety.position_uncertainty"):
                    load_scenario(path)  # Z_d from a tracker, and torch_clock has none
                continue
            if kind.__name__ == "BestScenarioScheduler":  # read by its tag, then its own check
                with pytest.raises(ScenarioError, match="scheduler.collaboration"):
                    load_scenario(path)
                continue
            if kind.__name__ == "ProactivePlanner":  # read by its tag, then its own check
                with pytest.raises(ScenarioError, match="proactive_planner.robot_action"):
                    load_scenario(path)
                continue
            assert type(getattr(load_scenario(path), name)) is kind, (name, kind)


def test_an_action_detector_is_reachable_by_its_tag(tmp_path, diagrams_dir):
    from hrc_drake.intention.config import GoalRegionActionDetector

    text = (diagrams_dir / "box_usb.yaml").read_text()
    text = text.replace("goals: [g4_station, g1_home],", "goals: [g4_station, g1_home], region: g1_home,")
    path = tmp_path / "box_usb_perceived.yaml"
    path.write_text(text + "action_detector: !GoalRegionActionDetector {min_dwell: 0.3}\n"
                    "human_events: perceived\n")
    scenario = load_scenario(path)
    assert scenario.action_detector == GoalRegionActionDetector(min_dwell=0.3)
    assert scenario.human_events == "perceived"
    path.write_text(text + "action_detector: !GoalRegionActionDetector {exit_scale: 0.5}\n")
    with pytest.raises(ScenarioError, match="action_detector.exit_scale"):
        load_scenario(path)


def test_use_case_a_robots_are_reachable_by_their_tags(tmp_path, diagrams_dir):
    from hrc_drake.scheduling.config import COLLABORATION_SCHEDULERS

    text = (diagrams_dir / "pcb_ic.yaml").read_text()
    assert "scheduler: !PredictiveRobotScheduler" in text
    for kind in COLLABORATION_SCHEDULERS:
        edited = text.replace("!PredictiveRobotScheduler", f"!{kind.__name__}")
        if not hasattr(kind(), "percentile"):
            edited = edited.replace("  percentile: 0.8\n", "")
        path = tmp_path / f"{kind.__name__}.yaml"
        path.write_text(edited)
        assert type(load_scenario(path).scheduler) is kind
    path.write_text(text.replace("autonomous_action: R_check", "autonomous_action: R_nothing"))
    with pytest.raises(ScenarioError, match="scheduler.autonomous_action"):
        load_scenario(path)
    path.write_text(text.replace("predictor: !HigherOrderMarkovPredictor {order: 2}", ""))
    with pytest.raises(ScenarioError, match="needs a predictor"):
        load_scenario(path)


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_scenarios_name_file_field_and_reason(tmp_path, torch_raw, case):
    edit, field, reason = BAD[case]
    path = write(tmp_path, mutate(torch_raw, edit))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert str(path) in message
    assert info.value.field == field
    assert reason in message


def test_target_out_of_reach_is_rejected(tmp_path, torch_raw):
    def edit(raw):
        pose = next(p for p in raw["robots"][0]["poses"] if p["name"] == "r_work")
        pose.pop("joints", None)  # torch_clock gives its poses in joints: this one a target
        pose["target"] = {"xyz": [2.5, 0.0, 0.9]}

    path = write(tmp_path, mutate(torch_raw, edit))
    load_scenario(path)  # structure is fine; reachability needs the robot model
    with pytest.raises(ScenarioError) as info:
        load_scenario(path, check_reachability=True)
    assert info.value.field.endswith(".target")
    assert "out of reach" in str(info.value)


def test_yaml_syntax_error_and_missing_file(tmp_path):
    bad = tmp_path / "broken.yaml"
    bad.write_text("seed: [1, 2\n")
    with pytest.raises(ScenarioError, match="not valid YAML"):
        load_scenario(bad)
    with pytest.raises(ScenarioError, match="no such file"):
        load_scenario(tmp_path / "missing.yaml")


def test_validate_command(tmp_path, torch_raw, diagrams_dir, capsys):
    assert main(["validate", str(diagrams_dir / "torch_clock.yaml")]) == 0
    assert "OK" in capsys.readouterr().out
    path = write(tmp_path, mutate(torch_raw, BAD["unknown goal"][0]))
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "operator.actions[1].goals[1]" in err and "nowhere" in err


def test_the_migrated_scenarios_keep_their_old_parameters(diagrams_dir):
    from hrc_drake.cell.legacy import translate

    old = {
        "box_pcb_coexistence.yaml": {
            "motion_model": {
                "kind": "gp_c",
                "params": {
                    "order": 2,
                    "horizon": 0.3,
                    "clearance": 0.05,
                    "reaction_time": 0.1,
                    "stopping_time": 0.15,
                    "robot_speed": 1.0,
                },
            }
        },
        "pcb_occlusion.yaml": {"tracker": {"kind": "particle_filter", "params": {"particles": 500}}},
        "box_usb.yaml": {
            "intention": {"kind": "gmm", "names": ["g4_station", "g1_home"]},
            "predictor": {"kind": "homm", "params": {"order": 2}},
        },
    }
    for file, fields in old.items():
        scenario = load_scenario(diagrams_dir / file)
        for field, raw in fields.items():
            for name, config in translate(field, raw):
                assert getattr(scenario, name) == config, (file, name)


def _child(tmp_path, diagrams_dir, text, name="child.yaml"):
    (tmp_path / "torch_clock.yaml").write_text((diagrams_dir / "torch_clock.yaml").read_text())
    path = tmp_path / name
    path.write_text(text)
    return path


def test_a_scenario_extends_another_field_by_field(tmp_path, diagrams_dir):
    text = ("extends: torch_clock.yaml\nseed: 99\nlayout: {camera: {rate: 15}}\n"
            "operator: {pattern: [H1, H2, H3]}\n")
    path = _child(tmp_path, diagrams_dir, text)
    base, child = load_scenario(tmp_path / "torch_clock.yaml"), load_scenario(path)
    assert (child.seed, base.seed) == (99, 7)
    # a mapping merges key by key: the camera keeps its position, the layout its buffers
    assert child.layout.camera.rate == 15 and child.layout.camera.position == base.layout.camera.position
    assert len(child.layout.buffers) == len(base.layout.buffers)
    # a list is replaced as a whole
    assert child.operator.pattern == ["H1", "H2", "H3"] and child.operator.actions == base.operator.actions
    assert child.extends == "" and child.flow == base.flow


@pytest.mark.parametrize(
    "text, reason",
    [
        ("extends: nowhere.yaml\n", "no such file"),
        ("extends: child.yaml\n", "extends itself"),
        ("extends: [torch_clock.yaml]\n", "expected a string"),
        ("extends: torch_clock.yaml\noperator: {pattern: [H9]}\n", "unknown operator action 'H9'"),
    ],
)
def test_bad_extends_are_refused(tmp_path, diagrams_dir, text, reason):
    path = _child(tmp_path, diagrams_dir, text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert reason in str(info.value) and str(path) in str(info.value)


def test_the_shipped_fuzzy_cell_is_torch_clock_with_its_scheduler(diagrams_dir):
    from hrc_drake.scheduling.config import FuzzyScheduler

    base = load_scenario(diagrams_dir / "torch_clock.yaml")
    fuzzy = load_scenario(diagrams_dir / "torch_clock_fuzzy.yaml")
    assert isinstance(fuzzy.scheduler, FuzzyScheduler) and fuzzy.scheduler.horizon == 50.0
    assert fuzzy.scheduler.wait_quantum == 5.0 and fuzzy.robots == base.robots
    # the same flow, with the scheduler's priors patched in by name
    assert [replace(a, duration=None) for a in fuzzy.flow.actions] == base.flow.actions
    assert all(a.duration is None for a in base.flow.actions)
    assert all(a.duration is not None for a in fuzzy.flow.actions)


def test_a_tagged_system_given_by_the_extending_file_replaces_the_base_one(tmp_path, diagrams_dir):
    """!WorstCaseMotionModel is a parent type of the base's GPMotionModel: it must not be read
    as a GP model with the base's fields."""
    from hrc_drake.motion.config import GPMotionModel, WorstCaseMotionModel

    path = tmp_path / "worst.yaml"
    path.write_text(f"extends: {diagrams_dir / 'box_pcb_coexistence.yaml'}\n"
                    "motion_model: !WorstCaseMotionModel {}\n")
    base = load_scenario(diagrams_dir / "box_pcb_coexistence.yaml")
    assert isinstance(base.motion_model, GPMotionModel)
    model = load_scenario(path).motion_model
    assert type(model) is WorstCaseMotionModel and model == WorstCaseMotionModel()


def test_a_proactive_planner_names_real_actions_and_poses(tmp_path, diagrams_dir):
    text = (diagrams_dir / "box_usb_proactive.yaml").read_text()
    for old, new, field in [
        ("robot_action: move_to_check_2", "robot_action: fly", "proactive_planner.robot_action"),
        ("start_pose: l_check1", "start_pose: r_home", "proactive_planner.start_pose"),
        ("human_actions: [cover_b1, cover_b2]", "human_actions: [cover_b1, dance]",
         "proactive_planner.human_actions[1]"),
        ("human_actions: [cover_b1, cover_b2]", "human_actions: [cover_b1, fill]",
         "proactive_planner.human_actions[1]"),
        ("human_actions: [cover_b1, cover_b2]", "human_actions: []", "proactive_planner.human_actions"),
    ]:
        assert old in text
        path = tmp_path / "bad_proactive.yaml"
        path.write_text(text.replace(old, new))
        with pytest.raises(ScenarioError, match=field.replace("[", r"\[").replace("]", r"\]")):
            load_scenario(path)


def test_an_arm_without_a_program_or_a_scheduler_is_refused(tmp_path, diagrams_dir):
    text = (diagrams_dir / "box_usb_proactive.yaml").read_text()
    old = "program: [rest]}"
    assert old in text
    path = tmp_path / "idle_arm.yaml"
    path.write_text(text.replace(old, "program: []}"))
    with pytest.raises(ScenarioError, match=r"arms\[1\].program"):
        load_scenario(path)


def test_a_scheduler_whose_net_cannot_be_compiled_fails_validation(tmp_path, diagrams_dir):
    # box_pcb_coexistence's pattern has 'foam', which its flow lacks: harmless without a scheduler,
    # but a scheduler's net is compiled from the pattern, and the build would fail on it.
    base = diagrams_dir / "box_pcb_coexistence.yaml"
    assert load_scenario(base).operator.pattern == ["fill", "foam", "bring", "tape"]
    path = tmp_path / "coexistence_scheduled.yaml"
    path.write_text(f"extends: {base}\nscheduler: !MonteCarloScheduler {{}}\n")
    with pytest.raises(ScenarioError, match=r"scheduler: .*unknown action 'foam'"):
        load_scenario(path)
