"""Duration distributions: the `Distribution` type of scenarios, its one validator and its
sampler, used by the human model (action durations) and by scheduling (pcTPN firing delays,
thesis 6.2: delays as random variables).

Kinds: fixed (mean) | normal (mean, std, truncated below at `low`) | uniform (low, high) |
triangular (low, mode, high) | lognormal (mean, std of the duration itself) |
empirical (samples, drawn with replacement).
"""

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.special import ndtr, ndtri

from hrc_drake.config_common import MAX_ACTION_DURATION
from hrc_drake.errors import ConfigError

KINDS = ("fixed", "normal", "uniform", "triangular", "lognormal", "empirical")


@dataclass
class Distribution:
    """A duration distribution (s).

    kind: fixed (mean) | normal (mean, std, truncated at `low`) | uniform (low, high) |
    triangular (low, mode, high) | lognormal (mean, std of the duration itself) |
    empirical (samples).
    """

    #: one of KINDS
    kind: str = "fixed"
    #: mean duration (s): fixed, normal (before truncation), lognormal
    mean: float = 1.0
    #: standard deviation (s): normal, lognormal
    std: float = 0.0
    #: lower bound (s): uniform, triangular; the truncation point of the normal
    low: float = 0.0
    #: upper bound (s): uniform, triangular
    high: float = 0.0
    #: mode (s): triangular
    mode: float = 0.0
    #: observed durations (s): empirical
    samples: list[float] = field(default_factory=list)

    def validate(self, path: str = "duration", positive: bool = True) -> None:
        """See `validate_distribution`."""
        validate_distribution(self, path, positive)


def validate_distribution(dist: Distribution, where: str = "duration", positive: bool = False) -> None:
    """Raise `ConfigError` naming the field under `where` when `dist` cannot be sampled as a
    duration: every duration must be >= 0, and > 0 with `positive` (an action's duration; a
    firing delay of a net may be 0)."""
    if not isinstance(dist, Distribution):
        raise ConfigError(where, f"expected a Distribution, got {type(dist).__name__}")
    kind = dist.kind
    if kind not in KINDS:
        raise ConfigError(f"{where}.kind", f"unknown distribution '{kind}' (one of {', '.join(KINDS)})")
    numbers = {"mean": dist.mean, "std": dist.std, "low": dist.low, "high": dist.high, "mode": dist.mode}
    for name, value in numbers.items():
        if not math.isfinite(float(value)):
            raise ConfigError(f"{where}.{name}", f"{value} is not finite")
    if positive:
        _check_positive(dist, where)
    if kind == "fixed":
        if dist.mean < 0:
            raise ConfigError(where, f"fixed duration mean = {dist.mean} is negative")
    elif kind == "normal":
        if dist.std < 0:
            raise ConfigError(where, f"normal std = {dist.std} is negative")
        if dist.low < 0:
            raise ConfigError(where, f"normal truncation low = {dist.low} is negative")
        if dist.std == 0 and dist.mean < dist.low:
            raise ConfigError(where, f"normal with std 0 has mean {dist.mean} below low {dist.low}")
    elif kind == "uniform":
        if not 0 <= dist.low <= dist.high:
            raise ConfigError(where, f"uniform needs 0 <= low <= high, got low={dist.low}, high={dist.high}")
    elif kind == "triangular":
        if not (0 <= dist.low <= dist.mode <= dist.high) or dist.low == dist.high:
            raise ConfigError(
                where,
                f"triangular needs 0 <= low <= mode <= high and low < high, "
                f"got low={dist.low}, mode={dist.mode}, high={dist.high}"
            )
    elif kind == "lognormal":
        if dist.mean <= 0 or dist.std < 0:
            raise ConfigError(where, f"lognormal needs mean > 0 and std >= 0, got {dist.mean}, {dist.std}")
    elif kind == "empirical":
        samples = np.asarray(dist.samples, dtype=float)
        if samples.ndim != 1 or samples.size == 0:
            raise ConfigError(where, "empirical distribution has no samples")
        if not np.all(np.isfinite(samples)) or np.any(samples < 0):
            raise ConfigError(where, "empirical samples must be finite and >= 0")


def _check_positive(dist: Distribution, where: str) -> None:
    """A duration of an action: every value it can take is > 0, and no parameter exceeds
    `MAX_ACTION_DURATION` (plausibility)."""
    for name in ("mean", "std", "low", "high", "mode"):
        value = getattr(dist, name)
        if value > MAX_ACTION_DURATION:
            raise ConfigError(f"{where}.{name}", f"{value:g} s is implausible for one action (at most "
                                                 f"{MAX_ACTION_DURATION:g} s)")
    if dist.samples and max(dist.samples) > MAX_ACTION_DURATION:
        raise ConfigError(f"{where}.samples", f"a sample above {MAX_ACTION_DURATION:g} s is implausible for "
                                              "one action")
    kind = dist.kind
    if kind in ("fixed", "normal", "lognormal") and dist.mean <= 0:
        raise ConfigError(f"{where}.mean", f"a duration must be positive, got {dist.mean}")
    if kind in ("uniform", "triangular") and dist.low <= 0:
        raise ConfigError(f"{where}.low", f"a duration must be positive, got low={dist.low}")
    if kind == "empirical" and dist.samples and min(dist.samples) <= 0:
        raise ConfigError(f"{where}.samples", "durations must be positive")


def sample_duration(dist: Distribution, rng: np.random.Generator, size=None):
    """Draw durations (s) from `dist`; a float when `size` is None, else an array of shape `size`.

    Every draw is >= 0. The truncated normal is sampled by inverse CDF (one uniform per draw),
    so the number of generator calls does not depend on the values drawn.
    """
    validate_distribution(dist)
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"sample_duration: rng must be a numpy.random.Generator, got {type(rng).__name__}")
    kind = dist.kind
    if kind == "fixed":
        out = np.full(() if size is None else size, float(dist.mean))
    elif kind == "normal":
        if dist.std == 0:
            out = np.full(() if size is None else size, float(dist.mean))
        else:
            lower_cdf = ndtr((dist.low - dist.mean) / dist.std)
            u = rng.uniform(lower_cdf, 1.0, size=size)
            out = dist.mean + dist.std * ndtri(u)
            out = np.maximum(out, dist.low)  # guards ndtri round-off at the bound
    elif kind == "uniform":
        out = rng.uniform(dist.low, dist.high, size=size)
    elif kind == "triangular":
        out = rng.triangular(dist.low, dist.mode, dist.high, size=size)
    elif kind == "lognormal":
        sigma2 = math.log1p((dist.std / dist.mean) ** 2)
        mu = math.log(dist.mean) - 0.5 * sigma2
        out = rng.lognormal(mu, math.sqrt(sigma2), size=size)
    else:  # empirical
        samples = np.asarray(dist.samples, dtype=float)
        out = samples[rng.integers(0, samples.size, size=size)]
    if size is None:
        return float(out)
    return np.asarray(out, dtype=float)


def mean_duration(dist: Distribution) -> float:
    """Expected value of `dist` (the truncated normal's mean includes the truncation)."""
    validate_distribution(dist)
    kind = dist.kind
    if kind in ("fixed", "lognormal"):
        return float(dist.mean)
    if kind == "normal":
        if dist.std == 0:
            return float(dist.mean)
        alpha = (dist.low - dist.mean) / dist.std
        tail = 1.0 - ndtr(alpha)
        if tail <= 0:
            return float(dist.low)
        pdf = math.exp(-0.5 * alpha * alpha) / math.sqrt(2 * math.pi)
        return float(dist.mean + dist.std * pdf / tail)
    if kind == "uniform":
        return 0.5 * (dist.low + dist.high)
    if kind == "triangular":
        return (dist.low + dist.mode + dist.high) / 3.0
    return float(np.mean(dist.samples))


def duration_support(dist: Distribution) -> tuple[float, float]:
    """Support [d_low, d_high] of `dist` (the interval Algorithm 3 and 6.2.1 propagate);
    the upper end is inf for the normal and lognormal kinds."""
    validate_distribution(dist)
    kind = dist.kind
    if kind == "fixed" or (kind == "normal" and dist.std == 0):
        value = float(max(dist.mean, dist.low)) if kind == "normal" else float(dist.mean)
        return value, value
    if kind == "normal":
        return float(dist.low), math.inf
    if kind in ("uniform", "triangular"):
        return float(dist.low), float(dist.high)
    if kind == "lognormal":
        return (float(dist.mean), float(dist.mean)) if dist.std == 0 else (0.0, math.inf)
    samples = np.asarray(dist.samples, dtype=float)
    return float(samples.min()), float(samples.max())


def duration_cdf(dist: Distribution, x) -> np.ndarray:
    """P(d <= x) for an array of x (s), used to discretise firing delays (6.2.1 arrival times)."""
    validate_distribution(dist)
    x = np.asarray(x, dtype=float)
    kind = dist.kind
    lo, hi = duration_support(dist)
    if lo == hi:
        return (x >= lo).astype(float)
    if kind == "normal":
        lower = ndtr((dist.low - dist.mean) / dist.std)
        z = ndtr((np.maximum(x, dist.low) - dist.mean) / dist.std)
        return np.where(x < dist.low, 0.0, (z - lower) / (1.0 - lower))
    if kind == "uniform":
        return np.clip((x - lo) / (hi - lo), 0.0, 1.0)
    if kind == "triangular":
        c = dist.mode
        left = (x - lo) ** 2 / ((hi - lo) * (c - lo)) if c > lo else np.zeros_like(x)
        right = 1.0 - (hi - x) ** 2 / ((hi - lo) * (hi - c)) if hi > c else np.ones_like(x)
        out = np.where(x <= c, left, right)
        return np.where(x <= lo, 0.0, np.where(x >= hi, 1.0, out))
    if kind == "lognormal":
        sigma2 = math.log1p((dist.std / dist.mean) ** 2)
        mu = math.log(dist.mean) - 0.5 * sigma2
        with np.errstate(divide="ignore"):
            z = (np.log(np.maximum(x, 0.0)) - mu) / math.sqrt(sigma2)
        return np.where(x <= 0, 0.0, ndtr(z))
    samples = np.sort(np.asarray(dist.samples, dtype=float))
    return np.searchsorted(samples, x, side="right") / samples.size
