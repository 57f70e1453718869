"""A synthetic operator: repeats a cyclic pattern of actions, reaching goals with min-jerk motions.

Each action (thesis Ch. 2: an action a reaches the goal regions G_a) has one goal per phase,
reached in order (e.g. pick at a buffer, then place at a goal). Its duration D is drawn from
the task's sampler and split evenly over the n phases; in each phase of length P = D / n the
head first turns towards the goal (HEAD_LEAD s, gaze leads the hand as in thesis 3.1.2),
then the wrist reaches it along a minimum-jerk joint-space motion (75 % of what is left),
then dwells. Between actions, while the world says the action cannot start (parts missing),
the operator waits with the wrists resting in front of the torso at table height.

In a cell the operator does not touch the world: it sends a start `WorldRequest` and begins
when the world's snapshot says the request was granted (it waits, hands at rest, once the world
says it cannot start yet), and a finish request when it ends (`update(t, view)`). Given a
synchronous world object instead (`world=`), it starts and finishes in place.

Arm configurations come from a small inverse kinematics on wrist position only (torso
flexion + the arm(s) of the action, base fixed), solved once per goal and cached, so that
`q(t)` is closed-form minimum-jerk interpolation between cached configurations.

That is the ideal behaviour (`IdealBehaviour`, the default). With `RealisticBehaviour` (see
`behaviour.py`) the gaze leads the hand by a random time and glances at other goals and at the
robot; a reach may pause half-way or start towards a wrong goal and turn back; the person's
speed factor divides the reach times (the action's duration, hence every event, stays the
sampled one); and smooth noise wobbles the head angles and the arm joints. The wrist noise is
added to the joints, not to the points: the skeleton keeps its segment lengths, and `q`, the
points and the gaze stay one body.
"""

from __future__ import annotations

import math
import warnings
from bisect import bisect_right
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from hrc_drake.distributions import sample_duration, validate_distribution
from hrc_drake.human.behaviour import (
    ABORT_MIN_SEPARATION,
    GLANCE_TURN,
    SmoothNoise,
    draw_glances,
    draw_phase,
    person_speed,
)
from hrc_drake.human.body import ARM_DOFS, BodyModel
from hrc_drake.human.config import IdealBehaviour, RealisticBehaviour
from hrc_drake.messages import (
    HEAD,
    HUMAN_AGENT,
    THORAX,
    WRIST_OF_HAND,
    HumanEvent,
    WorldRequest,
    shallow_copy,
)

#: the head starts turning towards a goal this long before the hand starts moving (s)
HEAD_LEAD = 0.3
#: fraction of a phase (after the head lead) spent reaching; the rest is a dwell
REACH_FRACTION = 0.75
#: time to bring the hands back to rest when the operator has to wait (s)
RETURN_TIME = 1.0
#: for two-handed actions each wrist goes this far (m) to its side of the goal
BOTH_HANDS_OFFSET = 0.08
#: where the resting wrists are: ahead of the hip and to each side of the body axis (m)
REST_FORWARD = 0.25
REST_LATERAL = 0.17
MIN_DURATION = 0.05
_HEAD_LOWER = np.array([-1.4, -0.6])
_HEAD_UPPER = np.array([1.4, 1.1])
_HANDS_OF = {"left": ("left",), "right": ("right",), "both": ("left", "right")}
#: relative forward-difference step of the IK's Jacobian (scipy's "2-point" default, sqrt(eps))
_FD_STEP = float(np.finfo(float).eps) ** 0.5
#: the third word of the seed of the generators of an action's quirks, and of the person's
#: (a seed [s, k] is the k-th action's duration; numpy reads [s, k, 0] as [s, k])
_QUIRKS_STREAM = 1
_PERSON_STREAM = 2


@dataclass
class OperatorTask:
    """One action of the operator: goals (3,) reached in order with `hand` (left|right|both).

    duration_sampler(rng) -> float gives the whole action's duration (s).
    """

    name: str
    goals: list = field(default_factory=list)
    hand: str = "right"
    duration_sampler: Callable[[np.random.Generator], float] | None = None


def sampler_from_distribution(dist) -> Callable[[np.random.Generator], float]:
    """A duration sampler from a `schema.Distribution` (see `hrc_drake.distributions`),
    floored at MIN_DURATION. Raises ValueError for a distribution that cannot be sampled."""
    validate_distribution(dist)
    return lambda rng: max(sample_duration(dist, rng), MIN_DURATION)


def tasks_from_schema(operator_schema, goal_positions: dict) -> dict:
    """OperatorTask per `schema.OperatorAction`; goal_positions maps goal/buffer name -> (3,)."""
    tasks = {}
    for i, action in enumerate(operator_schema.actions):
        goals = []
        for name in action.goals:
            if name not in goal_positions:
                raise ValueError(f"operator.actions[{i}] ({action.name}): unknown goal {name!r}; "
                                 f"known: {sorted(goal_positions)}")
            goals.append(np.asarray(goal_positions[name], dtype=float))
        sampler = sampler_from_distribution(action.duration)
        tasks[action.name] = OperatorTask(action.name, goals, action.hand, sampler)
    return tasks


@dataclass
class _Segment:
    t0: float
    duration: float
    start: np.ndarray
    end: np.ndarray


class _Plan:
    """Piecewise minimum-jerk trajectory: segments sorted by start time, holding between them."""

    def __init__(self, value: np.ndarray, t0: float):
        self.segments = [_Segment(t0, 1.0, value.copy(), value.copy())]
        self._starts = [t0]

    def reset(self, t: float, segments: list[_Segment]):
        now = self.at(t)
        self.segments = [_Segment(t, 1.0, now, now)] + segments
        self._starts = [s.t0 for s in self.segments]

    def last_value(self) -> np.ndarray:
        return self.segments[-1].end

    def at(self, t: float) -> np.ndarray:
        i = bisect_right(self._starts, t) - 1
        if i < 0:
            return self.segments[0].start.copy()
        return _segment_at(self.segments[i], t)


def _segment_at(seg: _Segment, t: float) -> np.ndarray:
    """The closed-form minimum-jerk position of `trajectories.minimum_jerk` at scalar time t."""
    u = min(max((t - seg.t0) / seg.duration, 0.0), 1.0)
    return seg.start + (seg.end - seg.start) * (u * u * u * (10.0 + u * (-15.0 + 6.0 * u)))


def _chained(value: np.ndarray, moves) -> list[_Segment]:
    """Segments of the moves (start time, duration, end value), in time order, each starting
    where the previous one is at its start (a move may cut the previous one short)."""
    segments: list[_Segment] = []
    for t0, duration, end in sorted(moves, key=lambda move: move[0]):
        if segments:
            value = _segment_at(segments[-1], t0)
        segments.append(_Segment(t0, max(duration, 1e-6), value, np.asarray(end, dtype=float)))
    return segments


class SyntheticOperator:
    """Simulated operator following a cyclic action pattern (see module docstring).

    body: BodyModel; tasks: action name -> OperatorTask; pattern: cyclic list of action
    names; rest_q (12,): base pose and torso flexion (its arm values are replaced by the
    resting configuration); rng: numpy Generator or seed (the duration of the k-th action
    started is drawn from a generator seeded with (seed, k), so a copy of the operator needs no
    copy of a generator); world: synchronous object with `try_start(agent, action) -> bool`
    and `finish(agent, action)` (None: always starts, or the request protocol of `update`);
    rest_height: wrist height at rest (default: median goal height + 5 cm).
    behaviour: `IdealBehaviour` (default) or `RealisticBehaviour`; with the latter, other_goals
    (points (3,); default: the tasks' goals) are where the gaze glances and an aborted reach
    may start towards, robot_points where a glance at the robot looks (its k-th action's
    quirks are drawn from a generator seeded with (seed, k, 1), the person's from (seed, 0, 2)).

    The description (body, tasks, IK cache) is shared by copies (`clone`); the run state
    (plans, indices, events) is what an update changes.
    """

    def __init__(self, body: BodyModel, tasks: dict, pattern, rest_q, rng: np.random.Generator,
                 world=None, agent: str = HUMAN_AGENT, rest_height: float | None = None,
                 behaviour: IdealBehaviour | RealisticBehaviour | None = None, other_goals=None,
                 robot_points=()):
        self.body = body
        generator = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        self.seed = int(generator.integers(2**62))
        self.world = world
        self.agent = agent
        self.pattern = list(pattern)
        if not self.pattern:
            raise ValueError("SyntheticOperator: pattern must name at least one action")
        self.tasks = {}
        for name, task in tasks.items():
            if task.hand not in _HANDS_OF:
                raise ValueError(f"SyntheticOperator: task {name!r} hand must be left|right|both, "
                                 f"got {task.hand!r}")
            if not task.goals:
                raise ValueError(f"SyntheticOperator: task {name!r} has no goals")
            goals = []
            for k, goal in enumerate(task.goals):
                g = np.asarray(goal, dtype=float).reshape(-1)
                if g.shape != (3,) or not np.all(np.isfinite(g)):
                    raise ValueError(f"SyntheticOperator: task {name!r} goals[{k}] must be 3 finite numbers, "
                                     f"got {goal!r}")
                goals.append(g)
            if task.duration_sampler is None:
                raise ValueError(f"SyntheticOperator: task {name!r} has no duration_sampler")
            self.tasks[name] = OperatorTask(task.name, goals, task.hand, task.duration_sampler)
        missing = [name for name in self.pattern if name not in self.tasks]
        if missing:
            raise ValueError(f"SyntheticOperator: pattern names unknown actions {missing}; "
                             f"known: {sorted(self.tasks)}")

        q = np.asarray(rest_q, dtype=float).reshape(-1)
        if q.shape != (12,) or not np.all(np.isfinite(q)):
            raise ValueError(f"SyntheticOperator: rest_q must be 12 finite numbers, got shape {q.shape}")
        self._base_q = body._clip(q)
        yaw = self._base_q[2]
        self._forward = np.array([np.cos(yaw), np.sin(yaw), 0.0])
        self._left = np.array([-np.sin(yaw), np.cos(yaw), 0.0])
        if rest_height is None:
            all_goals = np.array([g for t in self.tasks.values() for g in t.goals])
            rest_height = float(np.median(all_goals[:, 2])) + 0.05
        self.rest_height = float(rest_height)
        self.unreachable: list[tuple[str, np.ndarray, float]] = []
        self._cache: dict = {}
        hip = np.array([self._base_q[0], self._base_q[1], 0.0])
        self.rest_wrists = {
            hand: hip + REST_FORWARD * self._forward + sign * REST_LATERAL * self._left
            + np.array([0.0, 0.0, self.rest_height])
            for hand, sign in (("left", 1.0), ("right", -1.0))
        }
        rest_targets = [self.rest_wrists["left"], self.rest_wrists["right"]]
        self.rest_config = self._solve(("left", "right"), rest_targets, self._base_q)
        self._rest_look = 0.5 * (self.rest_wrists["left"] + self.rest_wrists["right"])

        self._time = None
        self._seq = 0
        self._index = 0
        self._started = 0
        self._state = "idle"
        self._action: str | None = None
        self._action_end = 0.0
        self._phase_starts: list[float] = []
        self._phase_goals: list[dict] = []
        self.events: tuple[HumanEvent, ...] = ()
        #: the world requests of the last update (request protocol), and their count so far
        self.new_requests: tuple[WorldRequest, ...] = ()
        self._request_seq = 0
        self._joints = _Plan(self.rest_config, 0.0)
        self._head = _Plan(self._head_angles(self.rest_config, self._rest_look), 0.0)
        self._set_behaviour(behaviour, other_goals, robot_points)

    def _set_behaviour(self, behaviour, other_goals, robot_points) -> None:
        """The realistic behaviour's description: places, the person's speed and noise."""
        if behaviour is None or isinstance(behaviour, IdealBehaviour):
            self.behaviour, self.speed = None, 1.0
            return
        if not isinstance(behaviour, RealisticBehaviour):
            raise ValueError(f"SyntheticOperator: behaviour must be an IdealBehaviour or a "
                             f"RealisticBehaviour, got {type(behaviour).__name__}")
        behaviour.validate("behaviour")
        self.behaviour = behaviour
        if other_goals is None:
            other_goals = [g for task in self.tasks.values() for g in task.goals]
        self.other_goals = _unique_points(other_goals, "other_goals")
        self.robot_points = _unique_points(robot_points, "robot_points")
        person = np.random.default_rng([self.seed, 0, _PERSON_STREAM])
        self.speed = person_speed(behaviour, person)
        # both noises are drawn even when off, so that turning one off leaves the other as it was
        head_noise = SmoothNoise([behaviour.gaze_noise_std] * 2, behaviour.gaze_noise_time, person)
        arm_noise = SmoothNoise(self._arm_joint_noise_std(behaviour.hand_noise_std),
                                behaviour.hand_noise_time, person)
        self._head_noise = head_noise if behaviour.gaze_noise_std > 0 else None
        self._arm_noise = arm_noise if behaviour.hand_noise_std > 0 else None

    def _arm_joint_noise_std(self, wrist_std: float) -> np.ndarray:
        """Per arm joint (8,): the std that moves each wrist by about `wrist_std` per coordinate
        at rest, sigma_q = wrist_std sqrt(3 / trace(J J^T)) with J the wrist's Jacobian (3, 4)."""
        stds = np.zeros(8)
        step = 1e-6
        for hand in ("left", "right"):
            dofs = range(12)[ARM_DOFS[hand]]
            wrist = self.body._points(self.rest_config)[WRIST_OF_HAND[hand]]
            jacobian = np.empty((3, 4))
            for j, dof in enumerate(dofs):
                q = self.rest_config.copy()
                q[dof] += step
                jacobian[:, j] = (self.body._points(q)[WRIST_OF_HAND[hand]] - wrist) / step
            stds[dofs.start - 4:dofs.stop - 4] = wrist_std * math.sqrt(3.0 / max(np.sum(jacobian**2), 1e-12))
        return stds

    def with_behaviour(self, behaviour, other_goals=None, robot_points=()) -> SyntheticOperator:
        """This person (seed, body, tasks, IK cache) with another behaviour, before its first update."""
        if self._time is not None:
            raise ValueError("SyntheticOperator.with_behaviour: only before the first update")
        other = self.clone()
        other._set_behaviour(behaviour, other_goals, robot_points)
        return other

    def clone(self) -> SyntheticOperator:
        """A copy whose run state an update may change; shares the description and IK cache
        (plans and phase lists are replaced, never changed in place)."""
        other = shallow_copy(self)
        other._joints = shallow_copy(self._joints)
        other._head = shallow_copy(self._head)
        return other

    # ------------------------------------------------------------------ kinematics helpers
    def _wrist_problem(self, hands, targets, q_start):
        """The IK of `_solve` as a bounded least-squares problem over the free joints: (free,
        wrist_rows, target, residual, jacobian, lower, upper). residual: wrist errors and a pull
        towards q_start."""
        free = [3] + [i for hand in hands for i in range(12)[ARM_DOFS[hand]]]
        wrist_rows = [WRIST_OF_HAND[hand] for hand in hands]
        target = np.asarray(targets, dtype=float)
        reference = q_start[free].copy()
        # leaning costs more than moving the arm: lean only when the arm alone cannot reach
        weights = np.array([0.03] + [0.003] * (len(free) - 1))
        lower, upper = self.body.q_lower[free], self.body.q_upper[free]

        def residual(x):
            q = q_start.copy()
            q[free] = x
            err = (self.body._points(q)[wrist_rows] - target).ravel()
            return np.concatenate([err, weights * (x - reference)])

        # Forward differences as least_squares's default "2-point" takes them (step sqrt(eps)
        # relative to |x|, backwards where the forward step would leave the bounds), all the
        # perturbed configurations in one batched forward kinematics instead of one call each.
        n_free = len(free)
        regularisation = np.diag(weights)

        def jacobian(x):
            step = _FD_STEP * np.where(x >= 0, 1.0, -1.0) * np.maximum(1.0, np.abs(x))
            outside = (x + step > upper) | (x + step < lower)
            step = np.where(outside, -step, step)
            step = (x + step) - x  # the step as represented, as scipy takes it
            qs = np.repeat(q_start[None, :], n_free + 1, axis=0)
            qs[:, free] = x
            qs[np.arange(1, n_free + 1), free] = x + step
            wrists = self.body._points(qs)[:, wrist_rows].reshape(n_free + 1, -1)
            return np.vstack([((wrists[1:] - wrists[0]) / step[:, None]).T, regularisation])

        return free, wrist_rows, target, residual, jacobian, lower, upper

    def _solve(self, hands, targets, q_start, report: bool = True) -> np.ndarray:
        """IK on wrist positions only: torso flexion + the hands' arms free, base fixed; a target
        out of reach is recorded in `unreachable` (with `report`)."""
        problem = self._wrist_problem(hands, targets, q_start)
        free, wrist_rows, target, residual, jacobian, lower, upper = problem
        reference = q_start[free]
        best = None
        reach_arm = np.array([1.0, 0.2, 0.0, 1.2])
        for guess_arm in (None, reach_arm):
            x0 = reference.copy()
            if guess_arm is not None:
                x0[1:] = np.tile(guess_arm, len(hands))
            x0 = np.clip(x0, lower + 1e-6, upper - 1e-6)
            from scipy.optimize import least_squares  # lazily: scipy.optimize costs ~1 s to import

            result = least_squares(residual, x0, jac=jacobian, bounds=(lower, upper), xtol=1e-10, ftol=1e-10,
                                   max_nfev=300)
            if best is None or result.cost < best.cost:
                best = result
        q = q_start.copy()
        q[free] = best.x
        error = float(np.linalg.norm(self.body._points(q)[wrist_rows] - target, axis=1).max())
        if error > 0.01 and report:
            self.unreachable.append((",".join(hands), target.copy(), error))
            warnings.warn(f"SyntheticOperator: goal {target.tolist()} out of reach by {error:.3f} m",
                          stacklevel=3)
        return q

    def _goal_config(self, hand: str, goal: np.ndarray, aside: bool = False) -> np.ndarray:
        """The configuration reaching `goal`; aside: a goal only started towards by mistake
        (an aborted reach: not reaching it is no problem, and is not reported)."""
        key = (hand, tuple(np.round(goal, 6))) + (("aside",) if aside else ())
        if key not in self._cache:
            hands = _HANDS_OF[hand]
            if hand == "both":
                targets = [goal + BOTH_HANDS_OFFSET * self._left, goal - BOTH_HANDS_OFFSET * self._left]
            else:
                targets = [goal]
            self._cache[key] = self._solve(hands, targets, self.rest_config, report=not aside)
        return self._cache[key]

    def _head_angles(self, q: np.ndarray, look_at: np.ndarray) -> np.ndarray:
        """Head yaw (left +) and pitch (down +) relative to the torso that look at `look_at`."""
        head = self.body._points(q)[HEAD]
        yaw, lean = q[2], q[3]
        c, s = np.cos(yaw), np.sin(yaw)
        d = look_at - head
        d_yawed = np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2]])
        cl, sl = np.cos(lean), np.sin(lean)
        d_torso = np.array([cl * d_yawed[0] - sl * d_yawed[2], d_yawed[1], sl * d_yawed[0] + cl * d_yawed[2]])
        yaw_to = np.arctan2(d_torso[1], d_torso[0])
        angles = np.array([yaw_to, np.arctan2(-d_torso[2], np.hypot(d_torso[0], d_torso[1]))])
        return np.clip(angles, _HEAD_LOWER, _HEAD_UPPER)

    # ------------------------------------------------------------------ planning
    def _plan_action(self, t0: float, task: OperatorTask, duration: float):
        if self.behaviour is not None:
            self._plan_realistic(t0, task, duration)
            return
        hands = _HANDS_OF[task.hand]
        n = len(task.goals)
        phase = duration / n
        lead = min(HEAD_LEAD, 0.2 * phase)
        reach = REACH_FRACTION * (phase - lead)
        joint_segments, head_segments = [], []
        q_prev = self._joints.at(t0)
        head_prev = self._head.at(t0)
        self._phase_starts, self._phase_goals = [], []
        for k, goal in enumerate(task.goals):
            start = t0 + k * phase
            q_goal = self._goal_config(task.hand, goal)
            head_goal = self._head_angles(q_goal, goal)
            head_segments.append(_Segment(start, lead, head_prev, head_goal))
            joint_segments.append(_Segment(start + lead, reach, q_prev, q_goal))
            q_prev, head_prev = q_goal, head_goal
            self._phase_starts.append(start)
            self._phase_goals.append({hand: goal for hand in hands})
        self._joints.reset(t0, joint_segments)
        self._head.reset(t0, head_segments)

    def _plan_realistic(self, t0: float, task: OperatorTask, duration: float) -> None:
        """The phases of `_plan_action` with the quirks of `RealisticBehaviour` (module docstring)."""
        # _begin counted this action already: it is the (_started - 1)-th
        rng = np.random.default_rng([self.seed, self._started - 1, _QUIRKS_STREAM])
        phase = duration / len(task.goals)
        joint_moves, head_moves, windows = [], [], []
        q_prev = self._joints.at(t0)
        self._phase_starts, self._phase_goals = [], []
        for k, goal in enumerate(task.goals):
            start = t0 + k * phase
            wrong_goals = self._wrong_goals(goal, q_prev, task.hand)
            timing = draw_phase(self.behaviour, rng, phase, self.speed, len(wrong_goals), REACH_FRACTION)
            q_goal = self._goal_config(task.hand, goal)
            look = self._head_angles(q_goal, goal)
            settled = self._plan_phase(start, timing, task.hand, q_prev, q_goal, look,
                                       wrong_goals, joint_moves, head_moves)
            windows.append((settled, start + phase))
            q_prev = q_goal
            self._phase_starts.append(start)
            self._phase_goals.append({hand: goal for hand in _HANDS_OF[task.hand]})
        self._joints.reset(t0, _chained(self._joints.at(t0), joint_moves))
        head_moves += self._glance_moves(rng, windows, task)
        self._head.reset(t0, _chained(self._head.at(t0), head_moves))

    def _wrong_goals(self, goal: np.ndarray, q_now: np.ndarray, hand: str) -> list[np.ndarray]:
        """The goals an aborted reach may start towards: away from the right one and from the hands."""
        wrists = self.body._points(q_now)[[WRIST_OF_HAND[h] for h in _HANDS_OF[hand]]]
        return [g for g in self.other_goals
                if np.linalg.norm(g - goal) >= ABORT_MIN_SEPARATION
                and np.linalg.norm(wrists - g, axis=1).min() >= ABORT_MIN_SEPARATION]

    def _plan_phase(self, start, timing, hand, q_prev, q_goal, look, wrong_goals, joint_moves,
                    head_moves) -> float:
        """Adds the joint and head moves of one phase; returns when the gaze is on the goal for good."""
        hand_start = start + timing.lead
        turn = min(timing.lead, HEAD_LEAD)
        q_from, reach_start, settled = q_prev, hand_start, max(start + turn, hand_start)
        if timing.wrong_goal is None:
            head_moves.append((start, turn, look))
        else:
            wrong = wrong_goals[timing.wrong_goal]
            q_wrong = self._goal_config(hand, wrong, aside=True)
            head_moves.append((start, turn, self._head_angles(q_wrong, wrong)))
            q_from = q_prev + self.behaviour.abort_fraction * (q_wrong - q_prev)
            joint_moves.append((hand_start, timing.wrong_time, q_from))
            reach_start = hand_start + timing.wrong_time
            # half-way the person sees the mistake: the gaze goes to the right goal, then the hand
            notice = hand_start + 0.5 * timing.wrong_time
            head_moves.append((notice, min(HEAD_LEAD, 0.5 * timing.wrong_time), look))
            settled = max(notice + min(HEAD_LEAD, 0.5 * timing.wrong_time), reach_start)
        if timing.hesitate_at is None:
            joint_moves.append((reach_start, timing.reach, q_goal))
            return settled
        first = timing.hesitate_at * timing.reach
        q_pause = q_from + timing.hesitate_at * (q_goal - q_from)
        joint_moves.append((reach_start, first, q_pause))
        joint_moves.append((reach_start + first + timing.pause, timing.reach - first, q_goal))
        return settled

    def _glance_moves(self, rng, windows, task) -> list:
        """Head moves of the glances: away to another goal or the robot, and back to the phase's goal."""
        moves = []
        for t, fixation, (kind, index) in draw_glances(self.behaviour, rng, windows, len(self.other_goals),
                                                       len(self.robot_points)):
            k = max(bisect_right(self._phase_starts, t) - 1, 0)
            goal = task.goals[k]
            if kind == "robot":
                target = self.robot_points[index]
            else:
                others = [g for g in self.other_goals if np.linalg.norm(g - goal) > 1e-6] or [goal]
                target = others[index % len(others)]
            q_then = self._joints.at(t + GLANCE_TURN)
            moves.append((t, GLANCE_TURN, self._head_angles(q_then, target)))
            back = self._head_angles(self._goal_config(task.hand, goal), goal)
            moves.append((t + GLANCE_TURN + fixation, GLANCE_TURN, back))
        return moves

    def _plan_rest(self, t0: float, look_at: np.ndarray):
        q_now = self._joints.at(t0)
        self._joints.reset(t0, [_Segment(t0, RETURN_TIME, q_now, self.rest_config)])
        head_now = self._head.at(t0)
        head_goal = self._head_angles(self.rest_config, look_at)
        self._head.reset(t0, [_Segment(t0, HEAD_LEAD, head_now, head_goal)])

    def _emit(self, time: float, action: str, kind: str, out: list):
        self._seq += 1
        event = HumanEvent(time=float(time), action=action, kind=kind, seq=self._seq, agent=self.agent)
        self.events = self.events + (event,)
        out.append(event)

    def _request(self, time: float, action: str, kind: str, requests: list) -> None:
        self._request_seq += 1
        requests.append(WorldRequest(time=float(time), agent=self.agent, action=action, kind=kind,
                                     seq=self._request_seq))

    # ------------------------------------------------------------------ logic
    def busy_until(self, t: float) -> bool:
        """Whether the operator is still doing an action at time t (an update would do nothing)."""
        return self._state == "busy" and t < self._action_end

    def will_change(self, t: float, view=None) -> bool:
        """Whether `update(t, view)` would change anything (cheap; lets a system skip a copy)."""
        if self._state == "busy":
            return t >= self._action_end
        if self._state == "idle" or view is None or self.world is not None:
            return True
        granted = view.granted.get(self.agent, 0) >= self._request_seq
        refused = view.refused.get(self.agent, 0) >= self._request_seq
        return granted or (refused and self._state == "requesting")

    def update(self, t: float, view=None) -> list[HumanEvent]:
        """Advance the operator to time t; returns the events emitted (begin/end/wait_begin/wait_end).

        view: the world's `WorldSnapshot` (request protocol: the requests of this update are
        left in `new_requests`); None with no world or a synchronous `world`.
        """
        t = float(t)
        if not np.isfinite(t):
            raise ValueError(f"SyntheticOperator.update: time must be finite, got {t}")
        if self._time is not None and t < self._time - 1e-12:
            raise ValueError(f"SyntheticOperator.update: time went backwards ({t} < {self._time})")
        out: list[HumanEvent] = []
        requests: list[WorldRequest] = []
        protocol = view is not None and self.world is None
        start_time = t
        while True:
            if self._state == "busy":
                if t < self._action_end:
                    break
                if self.world is not None:
                    self.world.finish(self.agent, self._action)
                elif protocol:
                    self._request(self._action_end, self._action, "finish", requests)
                self._emit(self._action_end, self._action, "end", out)
                start_time = self._action_end
                self._action = None
                self._state = "idle"
                self._index = (self._index + 1) % len(self.pattern)
            name = self.pattern[self._index]
            if protocol:
                if self._state == "idle":
                    self._request(t, name, "start", requests)
                    self._state = "requesting"
                    break
                can_start = view.granted.get(self.agent, 0) >= self._request_seq
                if not can_start and self._state == "requesting":
                    if view.refused.get(self.agent, 0) >= self._request_seq:
                        self._begin_wait(t, name, out)
                    break
            else:
                can_start = self.world is None or self.world.try_start(self.agent, name)
            if can_start:
                if self._state == "waiting":
                    self._emit(t, name, "wait_end", out)
                if self._state in ("waiting", "requesting"):
                    start_time = t
                self._begin(start_time, name, out)
                continue
            if self._state != "waiting":
                self._begin_wait(t, name, out)
            break
        self._time = t
        self.new_requests = tuple(requests)
        return out

    def _begin(self, start_time: float, name: str, out: list) -> None:
        task = self.tasks[name]
        duration = float(task.duration_sampler(np.random.default_rng([self.seed, self._started])))
        self._started += 1
        if not np.isfinite(duration) or duration <= 0:
            raise ValueError(f"SyntheticOperator: duration sampler of {name!r} returned {duration!r}")
        self._emit(start_time, name, "begin", out)
        self._state = "busy"
        self._action = name
        self._action_end = start_time + duration
        self._plan_action(start_time, task, duration)

    def _begin_wait(self, t: float, name: str, out: list) -> None:
        self._emit(t, name, "wait_begin", out)
        self._state = "waiting"
        self._phase_starts, self._phase_goals = [], []
        self._plan_rest(t, self.tasks[name].goals[0])

    # ------------------------------------------------------------------ pose
    @property
    def state(self) -> str:
        """'idle' (before the first update), 'requesting' (asked the world, no answer yet),
        'busy' or 'waiting'."""
        return self._state

    @property
    def current_action(self) -> str | None:
        return self._action

    def current_goal(self, hand: str) -> np.ndarray | None:
        """The goal the given hand is reaching in the current phase, or None."""
        if hand not in ("left", "right"):
            raise ValueError(f"current_goal: hand must be 'left' or 'right', got {hand!r}")
        if self._action is None or not self._phase_starts:
            return None
        k = max(bisect_right(self._phase_starts, self._time) - 1, 0)
        goal = self._phase_goals[k].get(hand)
        return None if goal is None else goal.copy()

    def q(self, t: float) -> np.ndarray:
        """True configuration (12,) at time t (closed-form min-jerk, no IK).

        Only the current plan is kept: for t before the last replanning (an action start or
        a wait start) it returns the pose at that replanning.
        """
        q = self._joints.at(float(t))
        if self.behaviour is not None and self._arm_noise is not None:
            q[4:] += self._arm_noise.at(t)
            q = self.body._clip(q)
        return q

    def head_yaw_pitch(self, t: float) -> np.ndarray:
        """Head yaw and pitch (2,) relative to the torso at time t (as `q`: the current plan)."""
        angles = self._head.at(float(t))
        if self.behaviour is not None and self._head_noise is not None:
            angles = np.clip(angles + self._head_noise.at(t), _HEAD_LOWER, _HEAD_UPPER)
        return angles

    def points(self, t: float) -> np.ndarray:
        """True skeletal points (8, 3) at time t."""
        return self.body._points(self.q(t))

    def gaze(self, t: float) -> np.ndarray:
        """True unit gaze direction (3,) at time t: R_z(yaw) R_y(lean) R_z(head yaw) R_y(head pitch) e_x."""
        q = self.q(t)
        head_yaw, head_pitch = self.head_yaw_pitch(t)
        cp = math.cos(head_pitch)
        x, y, z = math.cos(head_yaw) * cp, math.sin(head_yaw) * cp, -math.sin(head_pitch)
        cl, sl = math.cos(q[3]), math.sin(q[3])
        x, z = cl * x + sl * z, -sl * x + cl * z
        cy, sy = math.cos(q[2]), math.sin(q[2])
        return np.array([cy * x - sy * y, sy * x + cy * y, z])

    def thorax(self, t: float) -> np.ndarray:
        return self.points(t)[THORAX]


def _unique_points(points, what: str) -> list[np.ndarray]:
    """Finite points (3,), each once."""
    out: list[np.ndarray] = []
    for k, point in enumerate(points):
        p = np.asarray(point, dtype=float).reshape(-1)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ValueError(f"SyntheticOperator: {what}[{k}] must be 3 finite numbers, got {point!r}")
        if all(np.linalg.norm(p - other) > 1e-9 for other in out):
            out.append(p)
    return out
