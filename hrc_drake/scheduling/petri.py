"""Partially controllable timed Petri nets (pcTPN), thesis 6.1-6.2.

A net is <P, T, Pre, Post, m0> with T = T_c U T_u. Pre and Post are (P, T) int arrays so that
enabling (eq. 6.1 read as Pre^ij <= m^i) is one numpy comparison over all transitions, and
firing (eq. 6.2) is m + Post^j - Pre^j. Controllable transitions fire at once or never
(6.2.1); uncontrollable ones fire after a random delay from their enabling, unless another
firing disables them first. `cost` gives each place a weight per token and second: the
"coloured" places where a token means an idle robot (c_R) or a waiting human (c_H).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hrc_drake.distributions import Distribution, validate_distribution
from hrc_drake.scheduling import _kernels

#: transition roles produced by the flow compiler
ROLES = ("begin", "end", "wait", "wait_end", "intent", "commit", "giveup", "hold", "join", "other")


@dataclass
class PcTPN:
    """A partially controllable timed Petri net.

    places: P names; transitions: T names.
    pre, post: (P, T) int incidence matrices.
    controllable: (T,) bool, True for T_c.
    delays: T firing-delay distributions (controllable ones are ignored: they fire at once).
    m0: (P,) int initial marking.
    cost: (P,) float cost per token per second (idle robot c_R, waiting human c_H, else 0).
    idle_agent: P agent names whose idleness a token in the place records ("" for none).
    agents: T tuples of the robot agents a controllable transition commands.
    action: T flow action names ("" for waits and human intentions).
    role: T roles, one of ROLES.
    """

    places: list[str]
    transitions: list[str]
    pre: np.ndarray
    post: np.ndarray
    controllable: np.ndarray
    delays: list[Distribution]
    m0: np.ndarray
    cost: np.ndarray
    idle_agent: list[str] = field(default_factory=list)
    agents: list[tuple[str, ...]] = field(default_factory=list)
    action: list[str] = field(default_factory=list)
    role: list[str] = field(default_factory=list)

    def __post_init__(self):
        self.pre = np.asarray(self.pre, dtype=np.int64)
        self.post = np.asarray(self.post, dtype=np.int64)
        self.controllable = np.asarray(self.controllable, dtype=bool)
        self.m0 = np.asarray(self.m0, dtype=np.int64)
        self.cost = np.asarray(self.cost, dtype=float)
        n_p, n_t = len(self.places), len(self.transitions)
        if self.pre.shape != (n_p, n_t) or self.post.shape != (n_p, n_t):
            raise ValueError(
                f"PcTPN: pre/post must be ({n_p}, {n_t}) (places x transitions), "
                f"got {self.pre.shape} and {self.post.shape}"
            )
        if np.any(self.pre < 0) or np.any(self.post < 0):
            raise ValueError("PcTPN: pre/post entries must be >= 0")
        if self.controllable.shape != (n_t,):
            raise ValueError(f"PcTPN: controllable must have shape ({n_t},), got {self.controllable.shape}")
        if self.m0.shape != (n_p,) or np.any(self.m0 < 0):
            raise ValueError(f"PcTPN: m0 must be ({n_p},) and >= 0, got {self.m0}")
        if self.cost.shape != (n_p,):
            raise ValueError(f"PcTPN: cost must have shape ({n_p},), got {self.cost.shape}")
        if len(self.delays) != n_t:
            raise ValueError(f"PcTPN: {len(self.delays)} delays for {n_t} transitions")
        if len(set(self.places)) != n_p or len(set(self.transitions)) != n_t:
            raise ValueError("PcTPN: place and transition names must be unique")
        for name, dist, ctrl in zip(self.transitions, self.delays, self.controllable, strict=True):
            if not ctrl:
                validate_distribution(dist, where=f"delay of transition {name!r}")
        self.idle_agent = list(self.idle_agent) or [""] * n_p
        self.agents = [tuple(a) for a in self.agents] or [()] * n_t
        self.action = list(self.action) or [""] * n_t
        self.role = list(self.role) or ["other"] * n_t
        self.incidence = self.post - self.pre
        self.place_index = {p: i for i, p in enumerate(self.places)}
        self.transition_index = {t: j for j, t in enumerate(self.transitions)}

    @property
    def n_places(self) -> int:
        return len(self.places)

    @property
    def n_transitions(self) -> int:
        return len(self.transitions)

    def enabled(self, marking) -> np.ndarray:
        """(T,) bool: transition j is enabled iff Pre^ij <= m^i for every place i (eq. 6.1)."""
        m = np.asarray(marking)
        return np.all(self.pre <= m[:, None], axis=0)

    def enabled_batch(self, markings: np.ndarray) -> np.ndarray:
        """(N, T) bool enabling of N markings (N, P) at once (eq. 6.1).

        Counted as missing preconditions, sum over the arc weights v of [m_i < v] [Pre^ij = v],
        one small matrix product per distinct weight (usually only 1) instead of an (N, P, T)
        comparison."""
        if not hasattr(self, "_pre_levels"):
            levels = [v for v in np.unique(self.pre) if v > 0]
            self._pre_levels = [(int(v), (self.pre == v).astype(float)) for v in levels]
        missing = np.zeros((markings.shape[0], self.n_transitions))
        for v, mask in self._pre_levels:
            missing += (markings < v).astype(float) @ mask
        return missing == 0

    def arcs(self) -> tuple[np.ndarray, ...]:
        """The arcs by transition in CSR form (`_kernels.petri_arcs`), computed once: the net's
        Pre and incidence never change."""
        if not hasattr(self, "_arcs"):
            self._arcs = _kernels.petri_arcs(self.pre, self.incidence)
        return self._arcs

    def fire(self, marking, transition) -> np.ndarray:
        """The marking reached by firing `transition` (name or index): m + Post^j - Pre^j (eq. 6.2)."""
        j = self.index_of(transition)
        m = np.asarray(marking, dtype=np.int64)
        if not np.all(self.pre[:, j] <= m):
            missing = [self.places[i] for i in np.flatnonzero(self.pre[:, j] > m)]
            raise ValueError(
                f"transition {self.transitions[j]!r} is not enabled: places {missing} lack tokens"
            )
        return m + self.incidence[:, j]

    def index_of(self, transition) -> int:
        if isinstance(transition, str):
            if transition not in self.transition_index:
                raise ValueError(f"unknown transition {transition!r}")
            return self.transition_index[transition]
        j = int(transition)
        if not 0 <= j < self.n_transitions:
            raise ValueError(f"transition index {j} out of range [0, {self.n_transitions})")
        return j

    def marking_dict(self, marking) -> dict[str, int]:
        """Non-zero places of a marking, for messages and debugging."""
        return {self.places[i]: int(v) for i, v in enumerate(marking) if v}

    def cost_rate(self, marking) -> float:
        """Cost per second accrued in `marking`: sum_i cost_i m_i."""
        return float(np.dot(self.cost, marking))

    def agent_choices(self, marking, agent: str, who: str = "PcTPN") -> np.ndarray:
        """Indices of the controllable transitions of robot `agent` enabled in `marking` (a
        scheduler's choices); ValueError naming `who` when there is none (the robot is busy)."""
        choices = self.agent_transitions(agent)
        choices = choices[self.enabled(marking)[choices]]
        if choices.size == 0:
            raise ValueError(f"{who}.decide: robot {agent!r} has no enabled transition (is it free?)")
        return choices

    def agent_transitions(self, agent: str) -> np.ndarray:
        """Indices of the controllable transitions that command robot agent `agent`."""
        return np.array(
            [j for j in range(self.n_transitions) if self.controllable[j] and agent in self.agents[j]],
            dtype=int,
        )
