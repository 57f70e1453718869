"""Firing-delay models learned online from observed firings (thesis 7.1: the scheduler records
the durations of the tasks and refines the distributions d; 7.3.1: empirical distributions;
7.5.2, Scheduler B: uniform distributions on the measured supports)."""

from __future__ import annotations

import json
import math
from collections import deque

import numpy as np

from hrc_drake.distributions import mean_duration, sample_duration
from hrc_drake.messages import shallow_copy
from hrc_drake.scheduling.best_scenario import delay_support
from hrc_drake.scheduling.petri import PcTPN

#: the shortest firing delay learned (s): a pcTPN delay is positive (6.1), the cell cannot observe an
#: action shorter than a third of its 30 Hz tick, and a zero delay would let a Monte Carlo trial fire
#: round a loop of actions without its time advancing
MIN_OBSERVED_DELAY = 0.01

class DurationModel:
    """Per-transition delay distributions: the net's prior until `min_samples` observations,
    then the empirical distribution of the last `window` observed delays (sliding window,
    so non-stationary durations, Fig. 7.20, are tracked)."""

    def __init__(self, net: PcTPN, window: int = 30, min_samples: int = 3):
        if window < 1 or min_samples < 1:
            raise ValueError(
                f"DurationModel: window and min_samples must be >= 1, got {window}, {min_samples}"
            )
        self.net = net
        self.window = int(window)
        self.min_samples = int(min_samples)
        self.samples_: list[deque] = [deque(maxlen=self.window) for _ in range(net.n_transitions)]

    def partial_fit(self, transition, delay: float) -> DurationModel:
        """Record one observed firing delay (s) of `transition` (name or index); one shorter than
        `MIN_OBSERVED_DELAY` counts as that."""
        j = self.net.index_of(transition)
        delay = float(delay)
        if not math.isfinite(delay) or delay < 0:
            raise ValueError(
                f"DurationModel: delay of {self.net.transitions[j]!r} must be finite and >= 0, got {delay}"
            )
        # a new deque, not an append: clones share the other transitions' (copy-on-write)
        samples = deque(self.samples_[j], maxlen=self.window)
        samples.append(max(delay, MIN_OBSERVED_DELAY))
        self.samples_[j] = samples
        return self

    def clone(self) -> DurationModel:
        """A copy that `partial_fit` may change without touching this one (copy-on-write)."""
        new = shallow_copy(self)
        new.samples_ = list(self.samples_)
        return new

    def is_learned(self, j: int) -> bool:
        return len(self.samples_[j]) >= self.min_samples

    def mean(self, j: int) -> float:
        """Mean delay of transition j under the current model (0 for controllable ones)."""
        if self.net.controllable[j]:
            return 0.0
        if self.is_learned(j):
            return float(np.mean(self.samples_[j]))
        return mean_duration(self.net.delays[j])

    def is_deterministic(self, j: int) -> bool:
        if self.net.controllable[j]:
            return True
        if self.is_learned(j):
            s = self.samples_[j]
            return max(s) == min(s)
        d = self.net.delays[j]
        return (
            d.kind == "fixed"
            or (d.kind == "normal" and d.std == 0)
            or (d.kind == "uniform" and d.low == d.high)
        )

    def sample(self, j: int, rng: np.random.Generator, size) -> np.ndarray:
        """Delays of transition j, array of shape `size`."""
        if self.net.controllable[j]:
            return np.zeros(size)
        if self.is_learned(j):
            s = np.asarray(self.samples_[j], dtype=float)
            return s[rng.integers(0, s.size, size=size)]
        return sample_duration(self.net.delays[j], rng, size=size)

    def sample_pools(self, rng: np.random.Generator, n_trials: int, depth: int) -> np.ndarray:
        """(n_trials, T, depth) delays: the k-th firing of transition j in trial n uses [n, j, k]."""
        pools = np.zeros((n_trials, self.net.n_transitions, depth))
        for j in np.flatnonzero(~self.net.controllable):
            if self.is_deterministic(j):
                pools[:, j, :] = self.mean(j)
            else:
                pools[:, j, :] = self.sample(j, rng, (n_trials, depth))
        return pools

    def to_json(self) -> str:
        return json.dumps(
            {
                "window": self.window,
                "min_samples": self.min_samples,
                "samples": {self.net.transitions[j]: list(s) for j, s in enumerate(self.samples_) if s},
            }
        )

    @classmethod
    def from_json(cls, net: PcTPN, text: str) -> DurationModel:
        data = json.loads(text)
        model = cls(net, window=data["window"], min_samples=data["min_samples"])
        for name, values in data["samples"].items():
            for v in values:
                model.partial_fit(name, v)
        return model


class UniformSupportDurationModel(DurationModel):
    """Scheduler B of use case b (7.5.2): every uncontrollable delay uniform on its support,
    the real PDFs neglected. The text: "the extremals of the support of the modelling uniform
    distributions are the maximum firing times measured from the system"; we read the
    extremals as the smallest and the largest measured firing time of the transition.

    Once a transition has `min_samples` observations its delay is U[min, max] of the last
    `window` observed delays (the same sliding window as `DurationModel`); before, U on the
    support of the net's prior (`best_scenario.delay_support`: a normal N(mu, sigma) gives
    [mu - 3 sigma, mu + 3 sigma] clipped below at its truncation point, >= 0; a fixed delay
    stays fixed), our choice, as the text does not say what B assumes before any measure.
    """

    def support(self, j: int) -> tuple[float, float]:
        """[low, high] of the uniform delay of transition j ((0, 0) for controllable ones)."""
        if self.net.controllable[j]:
            return 0.0, 0.0
        if self.is_learned(j):
            s = self.samples_[j]
            return float(min(s)), float(max(s))
        low, high = delay_support(self.net.delays[j])
        return float(low), float(high)

    def mean(self, j: int) -> float:
        """Mean of the uniform delay of transition j (0 for controllable ones)."""
        low, high = self.support(j)
        return 0.5 * (low + high)

    def is_deterministic(self, j: int) -> bool:
        low, high = self.support(j)
        return low == high

    def sample(self, j: int, rng: np.random.Generator, size) -> np.ndarray:
        """Delays of transition j, U[low, high] of `support`, array of shape `size`."""
        low, high = self.support(j)
        if low == high:
            return np.full(size, low)
        return rng.uniform(low, high, size=size)
