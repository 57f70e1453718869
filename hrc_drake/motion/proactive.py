"""Proactive robot paths around the operator's predicted motion, thesis 8.2 (Fig. 8.11).

The pipeline of one robot action r_j crossing the shared area:
  1. each realisation of a human action a_Si in A_S (the arm points of its moving arm, from
     the skeleton estimate between its begin and end events) joins a FIFO database of that
     action (capacity 3 in 8.2.4);
  2. P_RH (eq. 8.20-8.23) from the robot's and the human's activity over the window T;
  3. per a_Si, a GPDM (`motion.gpdm`) of its database and the regressed trajectory Phi_i
     (eq. 8.26), its probability cloud C_i (eq. 8.27-8.28, `motion.clouds`);
  4. the weighted union varsigma_j of the clouds with weights P_ji (eq. 8.29-8.30);
  5. STOMP on the cost (8.31)-(8.32) from the nominal path Q_j (`motion.stomp`).
The loop starts once every database is full and replans every `replan_period` s (20 s in
8.2.4). No pydrake: the robot's kinematics is a `robots.chain.SerialChain`.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass

import numpy as np

from hrc_drake.messages import L_ELBOW, L_SHOULDER, L_WRIST, R_ELBOW, R_SHOULDER, R_WRIST, shallow_copy
from hrc_drake.motion.clouds import InteractionModel, probability_cloud, weighted_union
from hrc_drake.motion.config import ProactivePlanner
from hrc_drake.motion.gpdm import GPDM
from hrc_drake.motion.stomp import Box, ProactiveCost, plan_proactive_path
from hrc_drake.rng import clone_generator

#: skeleton rows of the shoulder, elbow and wrist of each arm (thesis Fig. 9.1)
ARM_POINTS = {"left": (L_SHOULDER, L_ELBOW, L_WRIST), "right": (R_SHOULDER, R_ELBOW, R_WRIST)}
#: fewest poses a recorded realisation needs to join its database
MIN_POSES = 5


def nominal_path(q_start, q_end, n_waypoints: int = 43) -> np.ndarray:
    """Q_j of eq. (8.19): n_waypoints joint configurations evenly spaced from q_start to q_end."""
    q_start, q_end = np.asarray(q_start, dtype=float), np.asarray(q_end, dtype=float)
    if q_start.shape != q_end.shape or q_start.ndim != 1 or n_waypoints < 3:
        raise ValueError(f"nominal_path: need two (n,) configurations and >= 3 waypoints, got "
                         f"{q_start.shape}, {q_end.shape}, {n_waypoints}")
    return q_start + np.linspace(0.0, 1.0, int(n_waypoints))[:, None] * (q_end - q_start)


@dataclass(frozen=True)
class PlanReport:
    """One replanning: its time, the row P_j of P_RH, the costs and the time each step took."""

    time: float
    weights: tuple[float, ...]
    nominal_cost: float
    proactive_cost: float
    cloud_points: int
    gpdm_s: float
    cloud_s: float
    stomp_s: float


class ProactivePlannerCore:
    """The 8.2 pipeline for one robot action r (agent, action) and the human actions A_S.

    human_actions: names of A_S, in the order of P_RH's columns; human_arms: action -> "left" or
    "right", the arm that moves in it (8.2.2: one arm per action). nominal: Q_j (N+1, n).
    chain: the robot arm's `SerialChain` (capsules and control points elbow, tool). boxes:
    fixed obstacles of J_Ob. settings: the scenario's `ProactivePlanner` config (window,
    replan period, capacity, grid, arm radius, GPDM and STOMP parameters; its names of r and
    A_S are the caller's). rng: seed or Generator of GPDM and STOMP.
    `path_` is the current proactive path (None until the first replanning); `reports_` the
    replannings so far.
    """

    def __init__(self, robot_agent: str, robot_action: str, human_actions, human_arms: dict, nominal, chain,
                 boxes=(), settings: ProactivePlanner | None = None, rng=None):
        self.robot_agent, self.robot_action = str(robot_agent), str(robot_action)
        self.human_actions = tuple(human_actions)
        if not self.human_actions:
            raise ValueError("ProactivePlannerCore: A_S (human_actions) is empty")
        missing = [a for a in self.human_actions if human_arms.get(a) not in ARM_POINTS]
        if missing:
            raise ValueError(f"ProactivePlannerCore: no moving arm ('left' or 'right') for {missing}")
        self.human_arms = {a: human_arms[a] for a in self.human_actions}
        self.nominal = np.asarray(nominal, dtype=float)
        if self.nominal.ndim != 2 or self.nominal.shape[1] != chain.num_joints or len(self.nominal) < 3:
            raise ValueError(f"ProactivePlannerCore: nominal path must be (N+1 >= 3, {chain.num_joints}), "
                             f"got {self.nominal.shape}")
        self.chain = chain
        self.boxes = tuple(boxes)
        self.settings = settings or ProactivePlanner()
        self.rng = np.random.default_rng(rng)
        self.interaction = InteractionModel(1, len(self.human_actions), self.settings.window)
        self.databases: dict[str, tuple] = {a: () for a in self.human_actions}
        self._recording: tuple[str, list] | None = None
        self._last_event = -np.inf
        self.last_plan_ = -np.inf
        self.path_: np.ndarray | None = None
        self.seq_ = 0
        self.reports_: tuple[PlanReport, ...] = ()

    def clone(self) -> ProactivePlannerCore:
        """A copy for copy-on-write state (databases and reports are tuples, never written)."""
        new = shallow_copy(self)
        new.interaction = self.interaction.copy()
        new.databases = dict(self.databases)
        new._recording = None if self._recording is None else (self._recording[0], list(self._recording[1]))
        new.rng = clone_generator(self.rng)
        return new

    # ----------------------------------------------------------------- observation (8.2.1)
    def _clock(self, time: float) -> float:
        """Event times as P_RH needs them, never decreasing (a late event counts from now)."""
        self._last_event = max(float(time), self._last_event)
        return self._last_event

    def human_event(self, time: float, action: str, kind: str) -> None:
        """A begin/end event of the human: A(t) of eq. (8.21) and the recording of a_Si."""
        if action not in self.human_actions:
            return
        time = self._clock(time)
        if kind == "begin":
            self.interaction.set_human(time, self.human_actions.index(action))
            self._recording = (action, [])
        elif kind == "end":
            self.interaction.set_human(time, None)
            if self._recording is not None and self._recording[0] == action:
                self._store(action, self._recording[1])
            self._recording = None

    def robot_event(self, time: float, agent: str, action: str, kind: str) -> None:
        """A begin/end event of the robot: R(t) of eq. (8.21)."""
        if agent != self.robot_agent or action != self.robot_action:
            return
        time = self._clock(time)
        if kind == "begin":
            self.interaction.set_robot(time, 0)
        elif kind == "end":
            self.interaction.set_robot(time, None)

    def observe_points(self, points) -> None:
        """Skeleton points (8, 3) of one estimate: the moving arm's joins the recording."""
        if self._recording is None:
            return
        action, frames = self._recording
        arm = np.asarray(points, dtype=float)[list(ARM_POINTS[self.human_arms[action]])]
        if np.all(np.isfinite(arm)):
            frames.append(arm)

    def _store(self, action: str, frames: list) -> None:
        if len(frames) < MIN_POSES:
            return
        kept = self.databases[action][-(self.settings.capacity - 1):] if self.settings.capacity > 1 else ()
        self.databases[action] = (*kept, np.array(frames))  # FIFO: the oldest leaves

    @property
    def ready(self) -> bool:
        """Every database is full: the proactive loop may run (8.2.4)."""
        return all(len(d) >= self.settings.capacity for d in self.databases.values())

    # ----------------------------------------------------------------- planning (8.2.2-8.2.3)
    def clouds(self) -> tuple[list, float, float]:
        """C_i of every a_Si from its database (GPDM Phi_i, eq. 8.26; cloud, eq. 8.27-8.28),
        and the seconds the GPDMs and the clouds took."""
        out, gpdm_s, cloud_s = [], 0.0, 0.0
        for action in self.human_actions:
            sequences = [s.reshape(len(s), -1) for s in self.databases[action]]
            start = _time.perf_counter()
            model = GPDM(self.settings.latent_dim, max_iter=self.settings.gpdm_iterations,
                         random_state=self.rng).fit(sequences)
            phi = model.regressed_trajectory().reshape(-1, 3, 3)
            gpdm_s += _time.perf_counter() - start
            start = _time.perf_counter()
            out.append(probability_cloud(phi, self.settings.arm_radius, self.settings.grid,
                                         self.settings.cloud_threshold))
            cloud_s += _time.perf_counter() - start
        return out, gpdm_s, cloud_s

    def busy(self, time: float) -> bool:
        """Whether an estimate or a replanning could change anything now (a realisation is being
        recorded, or a replanning is due): lets a system skip its copy of the core."""
        return self._recording is not None or (
            self.ready and time - self.last_plan_ >= self.settings.replan_period)

    def maybe_replan(self, time: float) -> bool:
        """Replan when the databases are full, the period has passed and P_RH's row of r is
        defined (the robot did r within the window); True when a new path was made."""
        if not self.ready or time - self.last_plan_ < self.settings.replan_period:
            return False
        weights = self.interaction.matrix(time)[0]
        if not np.all(np.isfinite(weights)):
            return False
        self.plan(time, weights)
        return True

    def plan(self, time: float, weights) -> np.ndarray:
        """The proactive path for the P_RH row `weights` (eq. 8.29-8.32); stores and returns it."""
        clouds, gpdm_s, cloud_s = self.clouds()
        union = weighted_union(clouds, weights)
        s = self.settings
        cost = ProactiveCost(self.chain.capsules, self.chain.points, self.nominal, union.points, union.gamma,
                             self.boxes, s.lambda1, s.lambda2, s.alpha, dtype=np.dtype(s.potential_precision))
        start = _time.perf_counter()
        result = plan_proactive_path(self.nominal, cost, self.chain.joint_limits, self.rng,
                                     n_rollouts=s.n_rollouts, max_iterations=s.iterations,
                                     noise_std=s.noise_std)
        stomp_s = _time.perf_counter() - start
        self.path_ = np.asarray(result.path)
        self.last_plan_ = float(time)
        self.seq_ += 1
        self.reports_ = (*self.reports_, PlanReport(
            float(time), tuple(float(w) for w in weights), float(cost.total(self.nominal)),
            float(cost.total(self.path_)), len(union.points), gpdm_s, cloud_s, stomp_s))
        return self.path_


def table_box(center, size, height) -> Box:
    """The table top as an obstacle of J_Ob (8.32): center (x, y, .), size (x, y, thickness)."""
    thickness = float(size[2])
    return Box(np.array([center[0], center[1], height - thickness / 2.0]),
               np.array([size[0] / 2.0, size[1] / 2.0, thickness / 2.0]))
