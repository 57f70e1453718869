"""Simulated operators like the volunteers of thesis 7.5.2-7.5.3, and the between-subjects design
the thesis ran with them.

The thesis measured people: 20 volunteers in 4 groups of 5 (pattern x scheduler, 9 products each)
in use case b, 10 volunteers (5 per scheduler) in use case c. Their action durations were skewed
("clearly not exponentially distributed") and not stationary: Fig. 7.20 shows them shifted between
the middle (about 5 cycles) and the end of a run, which 7.5.2 ascribes to the operators' learning.
The thesis prints no numbers for those distributions, so a `Volunteer` takes its shape from the
text and its numbers from the sources named on `VolunteerPopulation`:

- a learning curve, the power law of practice (Wright 1936; Newell and Rosenbloom 1981): the n-th
  execution of an action has the mean ``speed * mean_a * (n / reference) ** -b`` with
  ``b = -log2(learning_rate)`` (each doubling of practice takes ``learning_rate`` of the time);
  ``mean_a`` is the flow's mean duration, the time at the `reference` execution (the thesis's
  "middle" of a run);
- a right-skewed spread around it: a log-normal factor of mean 1 whose coefficient of variation is
  that of the flow's duration of the action (our reconstruction's spread, skewed);
- each person their own `speed` and `learning_rate`, drawn from the population.

`between_subjects_p` is the thesis's test (one-sided Wilcoxon rank-sum, i.e. Mann-Whitney U, on the
samples pooled over each group's people, 7.5.2 and 7.5.3); `power_by_resampling` draws groups of
people from simulated pools again and again and counts how often that test finds p < alpha.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import mannwhitneyu

from hrc_drake.distributions import Distribution, sample_duration


@dataclass(frozen=True)
class VolunteerPopulation:
    """Where the simulated volunteers come from (each number an assumption, named here).

    learning_rates: the range of a person's learning rate (uniform): 0.80-0.95, our assumption:
    from Wright's 0.80 for aircraft assembly (1936), near where surveys of industrial learning
    curves centre (Dutton and Thomas 1984), to slower learners of a short, simple task.
    speed_cv: the coefficient of variation of a person's overall speed (log-normal, mean 1):
    0.15, our assumption (the thesis reports none; students new to the task).
    reference: the execution whose mean is the flow's mean duration (5: the thesis's "middle").
    """

    learning_rates: tuple[float, float] = (0.80, 0.95)
    speed_cv: float = 0.15
    reference: int = 5

    def __post_init__(self):
        low, high = self.learning_rates
        if not 0 < low <= high <= 1:
            raise ValueError(f"VolunteerPopulation.learning_rates: need 0 < low <= high <= 1, "
                             f"got {self.learning_rates}")
        if not (math.isfinite(self.speed_cv) and 0 <= self.speed_cv <= 2):
            raise ValueError(f"VolunteerPopulation.speed_cv: {self.speed_cv} must be in [0, 2]")
        if not (isinstance(self.reference, int) and self.reference >= 1):
            raise ValueError(f"VolunteerPopulation.reference: {self.reference} must be an integer >= 1")


def _lognormal_sigma(cv: float) -> float:
    """sigma of a log-normal factor with coefficient of variation `cv`."""
    return math.sqrt(math.log1p(cv * cv))


@dataclass(frozen=True)
class Volunteer:
    """One simulated person: the durations of their actions along a learning curve (module
    docstring). means, cvs: action -> the flow's mean duration (s) and coefficient of variation."""

    speed: float
    learning_rate: float
    means: dict
    cvs: dict
    reference: int = 5

    @property
    def exponent(self) -> float:
        """b of the power law T_n = T_ref (n / ref)^-b, from the learning rate (b = -log2 rate)."""
        return -math.log2(self.learning_rate)

    def mean_duration(self, action: str, repetition: int) -> float:
        """E[T_n]: the mean duration of the person's `repetition`-th execution (1-based) of `action`."""
        if repetition < 1:
            raise ValueError(f"Volunteer: repetition must be >= 1, got {repetition}")
        return self.speed * self.means[action] * (repetition / self.reference) ** -self.exponent

    def duration(self, action: str, repetition: int, rng: np.random.Generator) -> float:
        """A draw of the `repetition`-th execution of `action`: E[T_n] times a log-normal factor of
        mean 1 and the action's coefficient of variation (right-skewed)."""
        sigma = _lognormal_sigma(self.cvs[action])
        return self.mean_duration(action, repetition) * float(rng.lognormal(-0.5 * sigma * sigma, sigma))


def _moments(dist: Distribution, rng: np.random.Generator, n: int = 4000) -> tuple[float, float]:
    """Mean and coefficient of variation of a flow duration (from draws: truncation included)."""
    draws = np.array([sample_duration(dist, rng) for _ in range(n)])
    mean = float(draws.mean())
    return mean, float(draws.std() / mean) if mean > 0 else 0.0


def action_moments(durations: dict, seed: int = 0) -> tuple[dict, dict]:
    """The mean and coefficient of variation of each human action's flow duration (action ->
    Distribution), as a `Volunteer` takes them."""
    rng = np.random.default_rng(seed)
    means, cvs = {}, {}
    for action, dist in sorted(durations.items()):
        means[action], cvs[action] = _moments(dist, rng)
    return means, cvs


def draw_volunteer(population: VolunteerPopulation, means: dict, cvs: dict,
                   rng: np.random.Generator) -> Volunteer:
    """A person of `population`: their speed (log-normal, mean 1, CV speed_cv) and learning rate
    (uniform over learning_rates)."""
    sigma = _lognormal_sigma(population.speed_cv)
    speed = float(rng.lognormal(-0.5 * sigma * sigma, sigma)) if sigma > 0 else 1.0
    rate = float(rng.uniform(*population.learning_rates))
    return Volunteer(speed=speed, learning_rate=rate, means=dict(means), cvs=dict(cvs),
                     reference=population.reference)


#: the units `between_subjects_p` ranks: "samples", every sample of every person pooled (the
#: thesis's test, which treats a person's successive samples as independent), or "people", one
#: median per person (the design's real unit)
UNITS = ("samples", "people")


def between_subjects_p(group_a, group_b, unit: str = "samples") -> float:
    """One-sided Wilcoxon rank-sum (Mann-Whitney U), A below B, between two groups of people
    (group_a, group_b: one sequence of samples per person). unit "samples" is the thesis's test of
    7.5.2-7.5.3, on the samples pooled over each group's people (it printed 1 - p for use case b,
    "p = 0.9971"; this is p); "people" ranks each person's median instead (`UNITS`)."""
    if unit not in UNITS:
        raise ValueError(f"between_subjects_p: unit must be one of {UNITS}, got {unit!r}")
    groups = []
    for group in (group_a, group_b):
        people = [np.asarray(x, dtype=float) for x in group if len(x)]
        if not people:
            raise ValueError("between_subjects_p: each group needs a person with at least one sample")
        pooled = np.concatenate(people) if unit == "samples" else np.array([np.median(x) for x in people])
        groups.append(pooled)
    return float(mannwhitneyu(groups[0], groups[1], alternative="less").pvalue)


def power_by_resampling(pool_a, pool_b, group_size: int, rng: np.random.Generator, draws: int = 1000,
                        alpha: float = 0.05, unit: str = "samples") -> float:
    """The share of `draws` between-subjects experiments, `group_size` people per group drawn
    without replacement from the simulated pools (one sequence of samples per person), whose
    `between_subjects_p` (on `unit`) is below `alpha`. The estimate is conditional on the pools:
    two finite pools of one population differ by chance, so pools should be large (tens of people)."""
    if not 1 <= group_size <= min(len(pool_a), len(pool_b)):
        largest = min(len(pool_a), len(pool_b))
        raise ValueError(f"power_by_resampling: group_size {group_size} must be in 1..{largest} "
                         "(the pools' sizes)")
    hits = 0
    for _ in range(draws):
        a = [pool_a[i] for i in rng.choice(len(pool_a), group_size, replace=False)]
        b = [pool_b[i] for i in rng.choice(len(pool_b), group_size, replace=False)]
        hits += between_subjects_p(a, b, unit) < alpha
    return hits / draws


def people_needed(pool_a, pool_b, rng: np.random.Generator, sizes=(5, 10, 15, 20, 30),
                  target: float = 0.8, draws: int = 400, alpha: float = 0.05,
                  unit: str = "samples") -> tuple[int | None, dict]:
    """The smallest group size of `sizes` (people per group) whose power (`power_by_resampling`)
    reaches `target` (0.8, the usual convention), and the power at each size tried; sizes above
    half the smaller pool are skipped (drawn again and again from a pool that small, groups would
    mostly repeat the same people). None when none reaches it."""
    powers = {}
    largest = max(min(len(pool_a), len(pool_b)) // 2, min(sizes))
    for n in sizes:
        if n > largest or n > min(len(pool_a), len(pool_b)):
            break
        powers[n] = power_by_resampling(pool_a, pool_b, n, rng, draws, alpha, unit)
        if powers[n] >= target:
            return n, powers
    return None, powers


def cycle_times(run) -> np.ndarray:
    """The times between successive products of a `cellsim.CellRun` (Fig. 7.19, 7.28)."""
    return np.diff(np.asarray(run.product_times, dtype=float))


def human_wait_per_product(run, human: str = "human") -> np.ndarray:
    """The operator's waiting time (from each wait_begin to its wait_end) within each interval
    from the previous product (or t = 0) to a product (Fig. 7.21, 7.27), one sample per product."""
    spans, start = [], None
    for t, agent, _action, kind in run.events:
        if agent != human:
            continue
        if kind == "wait_begin" and start is None:
            start = t
        elif kind == "wait_end" and start is not None:
            spans.append((start, t))
            start = None
    if start is not None:
        spans.append((start, run.end_time))
    edges = np.concatenate([[0.0], np.asarray(run.product_times, dtype=float)])
    return np.array([sum(max(0.0, min(b, hi) - max(a, lo)) for a, b in spans)
                     for lo, hi in zip(edges[:-1], edges[1:], strict=True)])
