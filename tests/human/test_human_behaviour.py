"""The realistic operator (`RealisticBehaviour`): each quirk measured on the operator's own
output at its configured size, determinism, clones, bad configs, and the ideal default
reproducing the operator as it was before behaviours existed."""

import math
from dataclasses import replace

import numpy as np
import pytest

from hrc_drake.distributions import Distribution
from hrc_drake.errors import ConfigError
from hrc_drake.human.behaviour import GLANCE_TURN, SmoothNoise, person_speed
from hrc_drake.human.body import BodyModel
from hrc_drake.human.config import IdealBehaviour, RealisticBehaviour
from hrc_drake.human.operator import OperatorTask, SyntheticOperator
from hrc_drake.messages import HEAD, R_WRIST
from tests.human.test_human_operator import DT, FakeWorld, make_operator

#: right-hand goals in front of the operator (at x = 1.05 facing -x, its right is +y)
GOALS = {
    "a": np.array([0.68, 0.30, 0.80]),
    "b": np.array([0.62, 0.00, 0.80]),
    "c": np.array([0.66, 0.18, 1.00]),
    "d": np.array([0.75, -0.05, 0.95]),
}
ROBOT = np.array([0.0, 0.0, 1.1])
ACTION = 3.0  # s, every action
#: every quirk off: the eye-hand lead stays, drawn as configured
QUIET = RealisticBehaviour(glance_rate=0.0, gaze_noise_std=0.0, hand_noise_std=0.0,
                           hesitation_probability=0.0, abort_probability=0.0, speed_std=0.0)


@pytest.fixture(scope="module")
def person():
    """One person (seed 0, the IK solved once); `with_behaviour` gives it any behaviour."""
    return _operator(0, QUIET)


def _operator(seed, behaviour):
    body = BodyModel()
    tasks = {name: OperatorTask(name, [goal], "right", lambda rng: ACTION) for name, goal in GOALS.items()}
    return SyntheticOperator(body, tasks, list(GOALS), body.rest_q((1.05, 0.0), np.pi),
                             np.random.default_rng(seed), behaviour=behaviour, robot_points=[ROBOT])


def _as(person, **changes):
    return person.with_behaviour(replace(QUIET, **changes), robot_points=[ROBOT])


def _trace(op, n_actions, dt=0.02, span=ACTION):
    """The first `span` s of each of n_actions actions, sampled every dt: dicts of arrays."""
    actions, events, t = [], [], 0.0
    while len(actions) < n_actions:
        new = op.update(t)
        events += new
        for event in (e for e in new if e.kind == "begin"):
            times = event.time + np.arange(0.0, span, dt)
            points = np.array([op.points(x) for x in times])
            actions.append({"t": times, "wrist": points[:, R_WRIST], "head": points[:, HEAD],
                            "gaze": np.array([op.gaze(x) for x in times]), "goal": op.current_goal("right")})
        t += 0.1
    return actions, events


def _angle(a, b):
    return np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0))


def _onset(values, threshold):
    """Index of the first sample farther than threshold from the first one."""
    gap = values - values[0]
    distance = np.linalg.norm(gap, axis=-1) if gap.ndim > 1 else np.abs(gap)
    return int(np.argmax(distance > threshold))


def _still_runs(wrist, dt, speed=0.02):
    """Lengths (s) of the stops strictly inside the movement of one reach."""
    moving = np.linalg.norm(np.diff(wrist, axis=0), axis=1) / dt > speed
    idx = np.flatnonzero(moving)
    if idx.size == 0:
        return []
    inner = moving[idx[0]:idx[-1] + 1]
    runs, count = [], 0
    for m in inner:
        if m:
            if count:
                runs.append(count * dt)
            count = 0
        else:
            count += 1
    return runs


# ---------------------------------------------------------------------------- the default
def test_default_behaviour_is_the_operator_as_before():
    """Values of the seeded cell of tests/test_human_operator.py computed before behaviours
    existed: the default (and an explicit IdealBehaviour) must reproduce them (joint angles to
    1e-6 rad: the wrist IK's batched Jacobian of issue 18 rounds differently from scipy's own
    differences and moves the solutions along the IK's flat directions by ~3e-8 rad)."""
    expected_events = [
        ("begin", "pick_place", 0.0), ("end", "pick_place", 3.0046831172), ("begin", "screw", 3.0046831172),
        ("end", "screw", 5.0046831172), ("wait_begin", "pick_place", 5.02), ("wait_end", "pick_place", 7.0),
        ("begin", "pick_place", 7.0), ("end", "pick_place", 10.1930677302), ("begin", "screw", 10.1930677302),
        ("end", "screw", 12.1930677302), ("begin", "pick_place", 12.1930677302),
    ]
    expected = {  # step -> (q[3:], head yaw/pitch)
        20: ([-0.0207851937, 0.0975428813, -0.0372743501, -0.0598251281, 0.8707299564, 0.1038885252,
              -0.0347925125, -0.0596758292, 0.8620038634], [-0.6908015572, 0.9635694854]),
        125: ([0.3304735603, 0.0975428813, -0.0372743501, -0.0598251281, 0.8707299564, 0.8024767721,
               -0.3129720135, -0.0677472338, 0.0807249799], [0.0, 0.9795083777]),
        260: ([0.3001466398, 0.4176434198, 0.0648228246, -0.0081680162, 0.9738056253, 0.8160688599,
               -0.4706846628, -0.0748104322, 0.1191446147], [-0.3489497534, 0.9831428067]),
        405: ([0.1745691075, 0.0975428813, -0.0372743501, -0.0598251281, 0.8707299564, 0.6275871897,
               0.1700302434, -0.047353343, 0.1418494456], [-0.6908015572, 0.9635694854]),
        560: ([0.3262379022, 0.2988170334, 0.0269227374, -0.0273439538, 0.9355423055, 0.8356654095,
               -0.4368097522, -0.0731335865, 0.0821569454], [0.3656193033, 0.9316613074]),
        690: ([0.1832287028, 0.0975428813, -0.0372743501, -0.0598251281, 0.8707299564, 0.650801516,
               0.1791095529, -0.0468071162, 0.1099266993], [-0.6908015572, 0.9635694854]),
    }
    for explicit in (False, True):
        world = FakeWorld(closed=(5.0, 7.0), action="pick_place")
        op = make_operator(seed=11, world=world)
        if explicit:
            op = op.with_behaviour(IdealBehaviour())
        events = []
        for k in range(int(round(14.0 / DT)) + 1):
            world.now = k * DT
            events += op.update(k * DT)
            if k in expected:
                q, head = expected[k]
                np.testing.assert_allclose(op.q(k * DT)[3:], q, atol=1e-6)
                np.testing.assert_allclose(op.head_yaw_pitch(k * DT), head, atol=1e-6)
        assert [(e.kind, e.action) for e in events] == [e[:2] for e in expected_events]
        np.testing.assert_allclose([e.time for e in events], [e[2] for e in expected_events], atol=1e-9)


# ---------------------------------------------------------------------------- each quirk
def test_gaze_leads_the_hand_by_the_configured_random_time(person):
    lead = Distribution("lognormal", mean=0.6, std=0.2)
    actions, _ = _trace(_as(person, eye_hand_lead=lead), 30, dt=0.01, span=1.5)
    leads = []
    for a in actions:
        gaze_onset = _onset(a["gaze"], np.deg2rad(0.5))
        hand_onset = _onset(a["wrist"], 1e-3)
        leads.append(a["t"][hand_onset] - a["t"][gaze_onset])
    # the 1 mm / 0.5 deg onset thresholds are crossed ~0.09 s late for the hand, ~0.04 s for the head
    assert np.mean(leads) - 0.06 == pytest.approx(0.6, abs=0.08)
    assert np.std(leads) == pytest.approx(0.2, abs=0.08)  # random, not the ideal fixed 0.3 s


def _expected_glances(rate, window, length):
    """Mean count of the glances of a renewal process in a window: the k-th is made when its
    k waits (each Exp(rate)) and k - 1 glances before it leave it time to end (length) in the
    window: P(Gamma(k, rate) <= window - k length) = P(Poisson(rate (window - k length)) >= k)."""
    total = 0.0
    for k in range(1, int(window / length) + 1):
        mean = rate * (window - k * length)
        total += 1.0 - sum(math.exp(-mean) * mean**j / math.factorial(j) for j in range(k))
    return total


def test_glances_at_other_goals_and_the_robot(person):
    rate, fixation, lead = 1.0, 0.33, 0.3
    op = _as(person, glance_rate=rate, glance_at_robot=0.5, eye_hand_lead=Distribution("fixed", mean=lead))
    actions, _ = _trace(op, 40, dt=0.02)
    glances, lengths, at_robot = 0, [], 0
    for a in actions:
        to_goal = (a["goal"] - a["head"]) / np.linalg.norm(a["goal"] - a["head"], axis=1, keepdims=True)
        away = _angle(a["gaze"], to_goal) > np.deg2rad(8.0)
        settled = np.flatnonzero(~away)[0]  # the first turn to the goal is not a glance
        edges = np.flatnonzero(np.diff(away[settled:].astype(int)))
        for s, e in zip(edges[0::2], edges[1::2], strict=False):
            glances += 1
            lengths.append((e - s) * 0.02)
            mid = settled + (s + e) // 2
            to_robot = (ROBOT - a["head"][mid]) / np.linalg.norm(ROBOT - a["head"][mid])
            at_robot += _angle(a["gaze"][mid], to_robot) < np.deg2rad(10.0)
    # glances happen while the gaze is on the task: from the hand's start to the action's end
    expected = _expected_glances(rate, ACTION - lead, fixation + 2 * GLANCE_TURN)
    assert glances / len(actions) == pytest.approx(expected, rel=0.25)
    assert np.mean(lengths) == pytest.approx(fixation + GLANCE_TURN, abs=0.08)  # half of each turn is away
    assert at_robot / glances == pytest.approx(0.5, abs=0.15)
    quiet, _ = _trace(person.with_behaviour(QUIET, robot_points=[ROBOT]), 4, dt=0.05)
    for a in quiet:  # without glances the gaze stays on the goal once it got there
        to_goal = (a["goal"] - a["head"]) / np.linalg.norm(a["goal"] - a["head"], axis=1, keepdims=True)
        assert _angle(a["gaze"][30:], to_goal[30:]).max() < np.deg2rad(3.0)


def test_smooth_noise_in_hand_and_gaze(person):
    hand_std, gaze_std, tau = 0.01, 0.04, 0.3
    noisy = _as(person, hand_noise_std=hand_std, hand_noise_time=tau, gaze_noise_std=gaze_std,
                gaze_noise_time=tau)
    clean = person.with_behaviour(QUIET, robot_points=[ROBOT])  # the same person's plan, no noise
    steps = np.arange(0.0, 24.0, 0.02)
    wrist_gap, head_gap = [], []
    for op in (noisy, clean):
        op.update(0.0)
    for t in steps:
        noisy.update(t)
        clean.update(t)
        wrist_gap.append(noisy.points(t)[R_WRIST] - clean.points(t)[R_WRIST])
        head_gap.append(noisy.head_yaw_pitch(t) - clean.head_yaw_pitch(t))
    wrist_gap, head_gap = np.array(wrist_gap), np.array(head_gap)
    assert np.std(wrist_gap, axis=0).mean() == pytest.approx(hand_std, rel=0.4)
    assert np.std(head_gap, axis=0).mean() == pytest.approx(gaze_std, rel=0.3)
    lag = int(round(tau / 0.02))
    for gap in (wrist_gap, head_gap):
        gap = gap - gap.mean(axis=0)
        corr = lambda k: np.mean(np.sum(gap[:-k] * gap[k:], 1)) / np.mean(np.sum(gap**2, 1))  # noqa: E731,B023
        assert corr(1) > 0.95  # smooth: white noise would give ~0
        assert corr(lag) == pytest.approx(np.exp(-0.5), abs=0.2)  # the configured correlation time


def test_smooth_noise_correlation():
    noise = SmoothNoise([2.0] * 200, 0.5, np.random.default_rng(1))
    a, b = noise.at(3.0), noise.at(3.5)
    assert np.std(a) == pytest.approx(2.0, rel=0.15)
    assert np.corrcoef(a, b)[0, 1] == pytest.approx(np.exp(-0.5), abs=0.1)


def test_hesitations_pause_reaches_at_the_configured_rate(person):
    pause = Distribution("lognormal", mean=0.4, std=0.1)
    op = _as(person, hesitation_probability=0.5, hesitation_duration=pause)
    actions, _ = _trace(op, 40, dt=0.01, span=2.5)
    stops = [_still_runs(a["wrist"], 0.01) for a in actions]
    paused = [s for s in stops if s]
    assert len(paused) / len(actions) == pytest.approx(0.5, abs=0.17)
    assert all(len(s) == 1 for s in paused)
    # a min-jerk stop reads as still (< 2 cm/s) ~0.08 s longer than the pause itself
    assert np.mean([s[0] for s in paused]) - 0.08 == pytest.approx(0.4, abs=0.08)
    quiet, _ = _trace(person.with_behaviour(QUIET, robot_points=[ROBOT]), 8, dt=0.01, span=2.5)
    assert not any(_still_runs(a["wrist"], 0.01) for a in quiet)


def test_aborted_reaches_start_towards_a_wrong_goal_and_emit_nothing(person):
    op = _as(person, abort_probability=0.5)
    clean = person.with_behaviour(QUIET, robot_points=[ROBOT])
    actions, events = _trace(op, 32)
    plain, plain_events = _trace(clean, 32)
    assert events == plain_events  # same begin/end events: an aborted reach is motion only
    aborted = 0
    for a, p in zip(actions, plain, strict=True):
        np.testing.assert_allclose(a["goal"], p["goal"])  # the goal is the action's, throughout
        np.testing.assert_allclose(a["wrist"][-1], p["wrist"][-1], atol=1e-6)  # and it gets there
        if np.abs(a["wrist"] - p["wrist"]).max() < 1e-6:
            continue
        aborted += 1
        # on the way the hand came closer to another goal than the plain reach ever did
        others = [g for g in GOALS.values() if np.linalg.norm(g - a["goal"]) > 0.1]
        closest = [np.linalg.norm(a["wrist"] - g, axis=1).min() for g in others]
        plain_closest = [np.linalg.norm(p["wrist"] - g, axis=1).min() for g in others]
        assert min(c - pc for c, pc in zip(closest, plain_closest, strict=True)) < -0.03
    assert aborted / len(actions) == pytest.approx(0.5, abs=0.2)


def test_person_speed_factor(person):
    speeds = [person_speed(RealisticBehaviour(speed_std=0.15), np.random.default_rng([s, 0, 2]))
              for s in range(2000)]
    assert np.mean(speeds) == pytest.approx(1.0, abs=0.02)
    assert np.std(speeds) == pytest.approx(0.15, abs=0.015)
    fast = _as(person, speed_std=0.15)
    assert fast.speed == person_speed(fast.behaviour, np.random.default_rng([fast.seed, 0, 2]))
    assert abs(fast.speed - 1.0) > 0.05, "pick a seed whose person is not of speed 1"
    reach_times = {}
    for name, op in (("fast", fast), ("plain", person.with_behaviour(QUIET, robot_points=[ROBOT]))):
        actions, events = _trace(op, 6, dt=0.01)
        moves = []
        for a in actions:
            moving = np.flatnonzero(np.linalg.norm(np.diff(a["wrist"], axis=0), axis=1) > 1e-5)
            moves.append((moving[-1] - moving[0]) * 0.01)
        reach_times[name] = np.array(moves)
        ends = [e.time for e in events if e.kind == "end"][:4]
        assert ends == pytest.approx([ACTION * k for k in range(1, 5)])  # the speed changes no event
    np.testing.assert_allclose(reach_times["fast"] * fast.speed, reach_times["plain"], rtol=0.05)


# ---------------------------------------------------------------------------- runs and copies
def _run(op, t_end, dt=0.05):
    events, samples = [], []
    for t in np.arange(0.0, t_end, dt):
        events += op.update(t)
        samples.append(np.concatenate([op.points(t).ravel(), op.gaze(t)]))
    return events, np.array(samples)


def test_same_seed_same_run_and_clones_agree(person):
    behaviour = RealisticBehaviour(glance_rate=1.0, hesitation_probability=0.3, abort_probability=0.3)
    a = person.with_behaviour(behaviour, robot_points=[ROBOT])
    b = person.with_behaviour(behaviour, robot_points=[ROBOT])
    events_a, samples_a = _run(a, 8.0)
    clone = a.clone()  # mid-run: the clone continues exactly as the original
    events_b, samples_b = _run(b, 8.0)
    assert events_a == events_b
    np.testing.assert_array_equal(samples_a, samples_b)
    later_a = [a.update(t) + [a.points(t).tobytes()] for t in np.arange(8.0, 14.0, 0.05)]
    later_clone = [clone.update(t) + [clone.points(t).tobytes()] for t in np.arange(8.0, 14.0, 0.05)]
    assert later_a == later_clone


def test_other_seed_other_person():
    ops = [_operator(seed, RealisticBehaviour()) for seed in (1, 2)]
    assert ops[0].speed != ops[1].speed
    runs = [_run(op, 4.0)[1] for op in ops]
    assert np.abs(runs[0] - runs[1]).max() > 0.01


# ---------------------------------------------------------------------------- configs
@pytest.mark.parametrize("field, value, message", [
    ("glance_rate", -1.0, "glance_rate: must be a number in"),
    ("gaze_noise_time", 0.0, "gaze_noise_time: must be a time"),
    ("abort_probability", 1.5, "abort_probability: must be a probability"),
    ("abort_fraction", 1.0, "abort_fraction: must be in"),
    ("hand_noise_std", float("nan"), "hand_noise_std"),
    ("eye_hand_lead", Distribution("gamma"), "eye_hand_lead.kind: unknown distribution"),
])
def test_bad_behaviour_names_the_field(person, field, value, message):
    bad = replace(RealisticBehaviour(), **{field: value})
    with pytest.raises(ConfigError, match=message) as err:
        bad.validate("operator.behaviour")
    assert err.value.field.startswith(f"operator.behaviour.{field}")
    with pytest.raises(ValueError, match=field):
        person.with_behaviour(bad)
    with pytest.raises(ValueError, match="behaviour must be"):
        person.with_behaviour("realistic")


def test_scenario_reads_and_checks_the_behaviour(tmp_path):
    from pathlib import Path

    from hrc_drake.cell.scenario import ScenarioError, load_scenario

    text = (Path(__file__).resolve().parents[2] / "diagrams" / "box_usb.yaml").read_text()
    anchor = "operator:\n  name: human\n"
    assert anchor in text

    def load(line):
        path = tmp_path / "cell.yaml"
        path.write_text(text.replace(anchor, anchor + line + "\n"))
        return load_scenario(path)

    assert isinstance(load("").operator.behaviour, IdealBehaviour)
    realistic = "  behaviour: !RealisticBehaviour"
    behaviour = load(realistic + " {glance_rate: 0.5, eye_hand_lead: {std: 0.1}}").operator.behaviour
    assert behaviour.glance_rate == 0.5 and behaviour.eye_hand_lead.mean == 0.56
    for line, field in ((realistic + " {glance_rate: -1}", "operator.behaviour.glance_rate"),
                        (realistic + " {hesitation: 1}", "operator.behaviour.hesitation"),
                        ("  behaviour: !Careless {}", "operator.behaviour"),
                        ("  recorded: x.csv\n" + realistic + " {}", "operator.behaviour")):
        with pytest.raises(ScenarioError) as err:
            load(line)
        assert err.value.field.startswith(field), err.value


def test_a_realistic_operator_source_keeps_its_run_in_the_context(person):
    """The contract of tests/test_system_contract.py on a realistic operator: two contexts stay
    independent and a restart on a reset context reproduces the run."""
    from hrc_drake.human.systems import OperatorSource
    from hrc_drake.messages import HUMAN_AGENT, WorldSnapshot
    from tests.contract import SystemExample, new_context, output_values, simulate, values_equal

    behaviour = RealisticBehaviour(glance_rate=2.0, hesitation_probability=0.5, abort_probability=0.5)
    system = OperatorSource(person.with_behaviour(behaviour, robot_points=[ROBOT]), rate=50.0)
    idle = {HUMAN_AGENT: "idle"}
    granting = WorldSnapshot(time=0.0, buffers={}, activity=idle, granted={HUMAN_AGENT: 10**6})
    refusing = WorldSnapshot(time=0.0, buffers={}, activity=idle, refused={HUMAN_AGENT: 10**6})
    example = SystemExample(system, {"world": granting}, {"world": refusing}, duration=1.5)
    context_a, context_b = new_context(example, example.inputs_a), new_context(example, example.inputs_b)
    simulate(example, context_b, example.duration)
    simulator = simulate(example, context_a, example.duration)
    first = output_values(example, context_a)
    alone = new_context(example, example.inputs_a)
    simulate(example, alone, example.duration)
    assert all(values_equal(first[n], v) for n, v in output_values(example, alone).items())
    context_a.SetTime(0.0)
    system.SetDefaultContext(context_a)
    simulator.Initialize()
    simulator.AdvanceTo(example.duration)
    assert all(values_equal(first[n], v) for n, v in output_values(example, context_a).items())
