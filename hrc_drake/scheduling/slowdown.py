"""Robot actions slowed by where the operator is (issue 52, item 3: safety-aware scheduling).

Under ISO/TS 15066 a robot action near the operator runs slower (the safety controller scales
its speed) or stops; the thesis's schedulers (7.1-7.4) learn one delay distribution per
transition and so cannot tell an action the operator slows from one they do not. Here the
operator's activity is read off the net's marking (the human action in progress, else the one
the human waits to start, else the pattern step the human goes to next), and a robot action's
observed durations are kept per activity at its start. When the Monte Carlo trials enable the
action while their simulated operator is in that activity, they draw its delay from those
durations: the trials forecast the operator (the net's pattern), so the scheduler sees which
work the operator's presence will slow.

This departs from 7.3.1, whose trials draw each delay from the transition's one distribution;
it is the `durations_by_operator` variant of `MonteCarloScheduler` (off by default).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from hrc_drake.messages import shallow_copy
from hrc_drake.scheduling.learning import MIN_OBSERVED_DELAY
from hrc_drake.scheduling.petri import PcTPN

#: the places that tell the operator's activity, in order of precedence (a token in an earlier
#: kind wins): an action in progress, a wait to start one, the next step of the pattern
_KINDS = ("busy:", "hwait:", "step:")


@dataclass(frozen=True)
class OperatorActivities:
    """The operator's activities of a net (its human actions) and the places that show them.

    names: C human action names; places: K place indices in order of precedence; activity:
    (K,) the activity index each of those places shows."""

    names: tuple[str, ...]
    places: np.ndarray
    activity: np.ndarray

    @classmethod
    def of(cls, net: PcTPN) -> OperatorActivities:
        """The human actions of `net` (those with an intention transition) and their places."""
        step_action = {}
        for j, name in enumerate(net.transitions):
            if net.role[j] == "intent" and name.startswith("intent:"):
                step_action[name.removeprefix("intent:")] = net.action[j]
        names = tuple(dict.fromkeys(step_action.values()))
        index = {a: c for c, a in enumerate(names)}
        places, activity = [], []
        for kind in _KINDS:
            for i, place in enumerate(net.places):
                if not place.startswith(kind):
                    continue
                key = place.removeprefix(kind)
                if kind == "busy:":
                    action = key.split("#", 1)[0] if "#" in key or key in index else None
                else:
                    action = step_action.get(key)
                if action in index:
                    places.append(i)
                    activity.append(index[action])
        return cls(names, np.asarray(places, dtype=np.int64), np.asarray(activity, dtype=np.int64))

    def of_marking(self, marking) -> int:
        """The activity index the marking shows, or -1 (no token on an operator's place)."""
        m = np.asarray(marking)
        for place, activity in zip(self.places, self.activity, strict=True):
            if m[place] > 0:
                return int(activity)
        return -1

    def name_of_marking(self, marking) -> str | None:
        c = self.of_marking(marking)
        return None if c < 0 else self.names[c]


def robot_action_ends(net: PcTPN) -> np.ndarray:
    """(T,) bool: the ends of actions only robots do (their duration is the robot's motion,
    which the safety controller slows)."""
    human = set(OperatorActivities.of(net).names)
    return np.array(
        [net.role[j] == "end" and bool(net.agents[j]) and net.action[j] not in human
         and not net.controllable[j] for j in range(net.n_transitions)],
        dtype=bool,
    )


class DurationsByOperator:
    """Observed durations of robot actions per operator activity at their start (a sliding
    window of `window` per action and activity). A pair with `min_samples` observations is
    learned: the trials draw that action's delay, when they enable it while their operator is in
    that activity, from these durations (empirical, as `DurationModel`), else from the action's
    one distribution."""

    def __init__(self, net: PcTPN, window: int = 30, min_samples: int = 3):
        if window < 1 or min_samples < 1:
            raise ValueError(
                f"DurationsByOperator: window and min_samples must be >= 1, got {window}, {min_samples}"
            )
        self.net = net
        self.window, self.min_samples = int(window), int(min_samples)
        self.activities = OperatorActivities.of(net)
        self.robot_ends = robot_action_ends(net)
        self.samples_: dict[tuple[int, int], deque] = {}

    def partial_fit(self, transition, delay: float, activity: str | None) -> DurationsByOperator:
        """Record one observed duration of a robot action begun while the operator was in
        `activity` (None: unknown; ignored, as are other transitions)."""
        j = self.net.index_of(transition)
        delay = float(delay)
        if not math.isfinite(delay) or delay < 0:
            raise ValueError(
                f"DurationsByOperator: delay of {self.net.transitions[j]!r} must be finite and >= 0, "
                f"got {delay}"
            )
        if activity is None or not self.robot_ends[j] or activity not in self.activities.names:
            return self
        delay = max(delay, MIN_OBSERVED_DELAY)  # as DurationModel: a learned delay is positive
        key = (j, self.activities.names.index(activity))
        samples = deque(self.samples_.get(key, ()), maxlen=self.window)  # copy-on-write
        samples.append(delay)
        self.samples_ = {**self.samples_, key: samples}
        return self

    def clone(self) -> DurationsByOperator:
        """A copy that `partial_fit` may change without touching this one."""
        return shallow_copy(self)

    def learned_pairs(self) -> list[tuple[int, int]]:
        """The (transition, activity) pairs with `min_samples` observations, in a fixed order."""
        return sorted(key for key, s in self.samples_.items() if len(s) >= self.min_samples)

    def pair_index(self, pairs: list[tuple[int, int]]) -> np.ndarray:
        """(T, C + 1) int64: the index in `pairs` of (j, c), -1 where not learned (the last
        column, no activity known, is all -1)."""
        index = np.full((self.net.n_transitions, len(self.activities.names) + 1), -1, dtype=np.int64)
        for k, (j, c) in enumerate(pairs):
            index[j, c] = k
        return index

    def sample_pools(self, pairs, rng: np.random.Generator, n_trials: int, depth: int) -> np.ndarray:
        """(n_trials, len(pairs), depth) delays drawn from each pair's observed durations."""
        pools = np.zeros((n_trials, len(pairs), depth))
        for k, key in enumerate(pairs):
            samples = np.asarray(self.samples_[key], dtype=float)
            pools[:, k, :] = samples[rng.integers(0, samples.size, size=(n_trials, depth))]
        return pools

    def means(self) -> dict[tuple[str, str], float]:
        """{(transition name, activity): mean observed duration} of the learned pairs."""
        return {(self.net.transitions[j], self.activities.names[c]): float(np.mean(self.samples_[(j, c)]))
                for j, c in self.learned_pairs()}
