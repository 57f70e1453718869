"""Waiting time before an action begins, thesis 5.3 (Algorithm 1 and eq. 5.37).

The reachability tree starts at the running action; each node is a possible next action with
p_branch = product of the arc probabilities (from a sequence model) and a start time
tau_branch = residual of the running action + durations of the actions in between. Durations
are the empirical distributions of recent samples per action, discretised on a time grid;
tails past the horizon are dropped. A node is not expanded when its least start time
(sum of minimum durations) exceeds the horizon or p_branch < epsilon (Algorithm 1, line 16).
P(tau^a <= t) = sum over branches ending at the first occurrence of a of
p_branch P(tau_branch <= t)   (5.37).

The tree grows one level at a time: the next-action probabilities of all nodes of a level
come from one batched model call (`_predict_many`), cached per context while the model is
unchanged; nodes with the same recent context and the same set of actions already seen are
merged (their futures are equal and (5.37) is linear); the merging and the convolution of
the start-time pmfs of a level with the duration pmfs are one compiled direct convolution over
each pmf's support (`_kernels.merged_end_mass`; `distributions(compiled=False)` is the numpy
reference, by FFT).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Hashable, Mapping, Sequence

import numpy as np
from scipy import fft as sp_fft

from hrc_drake.messages import shallow_copy
from hrc_drake.prediction import _kernels

from .base import SequenceModel, recent


class WaitingTimePredictor:
    """Distribution of the waiting time tau^a of every action, Algorithm 1 with eq. (5.37).

    model: a fitted or online next-action model (`SequenceModel`), shared, not copied.
    resolution: time step of the grid (s).
    epsilon: branch probability below which a node is not expanded.
    max_samples: durations remembered per action (the most recent ones).
    min_durations: optional lower bounds T^a_min per action label (s); default: the least
        recorded sample (at least one grid step).
    default_duration: duration assumed for an action without samples (point mass, s).
    max_nodes: safety cap on the tree size; expansion stops there (the CDF then undercounts).
    """

    def __init__(
        self,
        model: SequenceModel,
        resolution: float = 0.2,
        epsilon: float = 1e-3,
        max_samples: int = 50,
        min_durations: Mapping[Hashable, float] | None = None,
        default_duration: float = 1.0,
        max_nodes: int = 20000,
    ):
        if not isinstance(model, SequenceModel):
            raise ValueError(f"WaitingTimePredictor: model must be a SequenceModel: {type(model).__name__}")
        for name, value in (("resolution", resolution), ("default_duration", default_duration)):
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"WaitingTimePredictor: {name}={value} must be a positive number")
        if not 0 <= epsilon < 1:
            raise ValueError(f"WaitingTimePredictor: epsilon={epsilon} must be in [0, 1)")
        self.model = model
        self.resolution = float(resolution)
        self.epsilon = float(epsilon)
        self.max_samples = int(max_samples)
        self.min_durations = dict(min_durations or {})
        self.default_duration = float(default_duration)
        self.max_nodes = int(max_nodes)
        self._samples: dict[int, deque] = {}
        self._samples_version = 0
        self._spectra_cache: tuple = (None, None)
        self._pmfs_cache: tuple = (None, None)
        self._prob_cache_key: tuple | None = None
        self._prob_cache: dict[tuple, np.ndarray] = {}

    def clear_cache(self) -> WaitingTimePredictor:
        """Forget the cached next-action predictions and duration spectra; returns self.

        Not needed for correctness (the caches follow the model's state_id_ and the samples);
        benchmarks use it to time a cold call."""
        self._prob_cache_key, self._prob_cache = None, {}
        self._spectra_cache = self._pmfs_cache = (None, None)
        return self

    # ---------------------------------------------------------------- statistics
    def observe_duration(self, action: Hashable, duration: float) -> WaitingTimePredictor:
        """Record one measured duration T^a (s) of `action`; returns self."""
        duration = float(duration)
        if not np.isfinite(duration) or duration <= 0:
            raise ValueError(f"WaitingTimePredictor: duration of {action!r} must be finite, > 0: {duration}")
        (code,) = self.model.encode([action])
        # a new deque, not an append: clones share the others (copy-on-write)
        samples = deque(self._samples.get(code, ()), maxlen=self.max_samples)
        samples.append(duration)
        self._samples[code] = samples
        self._samples_version += 1
        return self

    def clone(self, model: SequenceModel | None = None) -> WaitingTimePredictor:
        """A copy that `observe_duration` may change without touching this one (copy-on-write),
        around `model` (default: the same model object). The memo of next-action predictions is
        shared while the model is the same object (its entries are functions of the model)."""
        new = shallow_copy(self)
        new._samples = dict(self._samples)
        if model is not None and model is not self.model:
            new.model = model
            new._prob_cache_key, new._prob_cache = None, {}
        return new

    def to_dict(self) -> dict:
        """JSON-ready parameters and duration samples (the model is saved on its own)."""
        classes = self.model.classes_
        return {
            "params": {
                "resolution": self.resolution,
                "epsilon": self.epsilon,
                "max_samples": self.max_samples,
                "min_durations": [[label, float(value)] for label, value in self.min_durations.items()],
                "default_duration": self.default_duration,
                "max_nodes": self.max_nodes,
            },
            "samples": [[classes[code], list(samples)] for code, samples in sorted(self._samples.items())],
        }

    @classmethod
    def from_dict(cls, data: dict, model: SequenceModel) -> WaitingTimePredictor:
        """Rebuild a predictor saved with `to_dict` around `model`; ValueError on bad data."""
        if not isinstance(data, dict) or "params" not in data or "samples" not in data:
            raise ValueError("WaitingTimePredictor.from_dict: expected a dict with 'params' and 'samples'")
        try:
            params = dict(data["params"])
            params["min_durations"] = {label: value for label, value in params.get("min_durations", [])}
            waiting = cls(model, **params)
            for label, samples in data["samples"]:
                for duration in samples:
                    waiting.observe_duration(label, duration)
        except (TypeError, KeyError) as err:
            raise ValueError(f"WaitingTimePredictor.from_dict: malformed data: {err!r}") from None
        return waiting

    def durations(self, action: Hashable) -> np.ndarray:
        """The remembered duration samples of `action` (s), oldest first."""
        (code,) = self.model.encode([action])
        return np.array(self._samples.get(code, ()), dtype=float)

    def _duration_samples(self, code: int) -> np.ndarray:
        samples = self._samples.get(code)
        if not samples:
            return np.array([self.default_duration])
        return np.fromiter(samples, dtype=float)

    def _min_duration(self, code: int) -> float:
        label = self.model.classes_[code]
        if label in self.min_durations:
            return max(float(self.min_durations[label]), self.resolution)
        return max(float(self._duration_samples(code).min()), self.resolution)

    def _pmf(self, samples: np.ndarray, n_bins: int, at_least_one: bool) -> np.ndarray:
        """Histogram of samples on the grid; mass past the horizon is dropped."""
        # capped before the cast: past the horizon is dropped anyway, and a sample of more than
        # 2^63 grid steps would wrap to a negative bin
        bins = np.rint(np.minimum(samples, n_bins * self.resolution) / self.resolution).astype(int)
        if at_least_one:
            bins = np.maximum(bins, 1)
        bins = bins[bins < n_bins]
        return np.bincount(bins, minlength=n_bins)[:n_bins] / samples.size

    def _duration_spectra(self, n_bins: int) -> tuple[np.ndarray, int]:
        """Spectra (m, n_fft) of the duration pmfs on the grid, cached until a new sample."""
        key = (n_bins, self._samples_version)
        if self._spectra_cache[0] != key:
            pmfs, supports = self._duration_pmfs(n_bins)
            # long enough for a linear (not circular) convolution of a start pmf with the
            # durations, and smooth: n_bins + support is often a prime (slow)
            support = max(int(supports.max()), 1)
            n_fft = sp_fft.next_fast_len(n_bins + support - 1, real=True)
            self._spectra_cache = (key, (sp_fft.rfft(pmfs, n=n_fft, axis=1), n_fft))
        return self._spectra_cache[1]

    def _duration_pmfs(self, n_bins: int) -> tuple[np.ndarray, np.ndarray]:
        """The duration pmfs (m, n_bins) on the grid and the support of each (last nonzero bin
        + 1), cached until a new sample."""
        key = (n_bins, self._samples_version)
        if self._pmfs_cache[0] != key:
            m = self.model.n_actions_
            pmfs = np.stack([self._pmf(self._duration_samples(c), n_bins, True) for c in range(m)])
            supports = np.array([np.flatnonzero(row).max(initial=-1) + 1 for row in pmfs], dtype=np.int64)
            self._pmfs_cache = (key, (pmfs, supports))
        return self._pmfs_cache[1]

    def _next_probs_function(self, width: int):
        """Next-action probabilities of context rows (P, width), -1 padded on the left.

        Rows are keyed by one integer (base m+1 digits) when it fits in int64, by tuples
        otherwise. Predictions are cached per context while the model is unchanged (its
        state_id_), so the tree levels and repeated calls between two observed actions share
        them; the contexts a level misses go to the model in one batched call.
        """
        model = self.model
        m = model.n_actions_
        if model.n_observed_ == 0:
            return lambda rows: np.full((rows.shape[0], m), 1.0 / m)
        if self._prob_cache_key != (id(model), model.state_id_, width) or len(self._prob_cache) > 100_000:
            self._prob_cache_key = (id(model), model.state_id_, width)
            self._prob_cache = {}
        cache = self._prob_cache
        digits = _row_digits(m, width)

        def next_probs(rows: np.ndarray) -> np.ndarray:
            if digits is not None:
                keys = ((rows + 1) @ digits).tolist()
            else:
                keys = [tuple(row) for row in rows.tolist()]
            missing = {key: i for i, key in enumerate(keys) if key not in cache}
            if missing:
                contexts = [tuple(c for c in rows[i].tolist() if c >= 0) for i in missing.values()]
                cache.update(zip(missing, model._predict_many(contexts), strict=True))
            return np.array([cache[key] for key in keys])

        return next_probs

    # ---------------------------------------------------------------- tree
    def distributions(
        self, history: Sequence[Hashable], elapsed: float | None, horizon: float = 60.0, targets=None,
        compiled: bool = True,
    ) -> tuple[np.ndarray, np.ndarray]:
        """CDFs P(tau^a <= t) on the grid t = 0, dt, ..., horizon for every action, eq. (5.37).

        history: past actions, oldest first; its last one is running now (or just ended).
        elapsed: time since the last action began (s); None when it has already ended.
        targets: labels whose first occurrence ends a branch (default: all actions); the tree
            stops expanding a node once every target occurred on its branch.
        Returns times (G,) and cdf (m, G) over `model.classes_`. An empty history means no
        running action: the next action starts now with the model's marginal probabilities.
        compiled: merge and convolve each level in one kernel (`_kernels.merged_end_mass`, a
            direct convolution); False: numpy's reduceat and FFT convolution (the reference;
            the two agree to FFT round-off, ~1e-16).
        """
        model = self.model
        codes = model.encode(history)
        m = model.n_actions_
        if not (np.isfinite(horizon) and horizon > 0):
            raise ValueError(f"WaitingTimePredictor: horizon={horizon} must be a positive number")
        if elapsed is not None and not (np.isfinite(elapsed) and elapsed >= 0):
            raise ValueError(f"WaitingTimePredictor: elapsed={elapsed} must be finite and >= 0 (or None)")
        n_bins = int(np.floor(horizon / self.resolution + 1e-9)) + 1
        times = np.arange(n_bins) * self.resolution
        target_mask = np.ones(m, dtype=bool)
        if targets is not None:
            target_mask[:] = False
            target_mask[list(model.encode(targets))] = True

        # residual time of the running action: samples longer than the elapsed time, shifted
        if codes and elapsed is not None:
            samples = self._duration_samples(codes[-1])
            residual = samples[samples > elapsed] - elapsed
            if residual.size == 0:  # it already ran longer than ever seen: about to end
                residual = np.zeros(1)
            root_min = float(residual.min())
        else:
            residual = np.zeros(1)
            root_min = 0.0
        root_pmf = self._pmf(residual, n_bins, at_least_one=False)

        if compiled:
            duration_pmfs, supports = self._duration_pmfs(n_bins)
        else:
            duration_spectra, n_fft = self._duration_spectra(n_bins)
        min_durations = np.array([self._min_duration(c) for c in range(m)])
        width = max(int(model.context_length_), 1)
        next_probs = self._next_probs_function(width)

        start_mass = np.zeros((m, n_bins))  # sum of p_branch * start-time pmf at first occurrence
        # level 1: the children of the running action start when it ends. A context is a row
        # of the `width` most recent codes, -1 where the history is shorter.
        root_ctx = np.full((1, width), -1, dtype=np.int64)
        tail = recent(codes, width)
        if tail:
            root_ctx[0, width - len(tail) :] = tail
        # Each tree node (a branch, after merging) carries its context row, p_branch, the mass
        # p_branch * pmf of the time its action ends (= its children start), its least end time
        # (sum of T_min) and the set of actions it has seen.
        parents_ctx = root_ctx
        parents_mass = root_pmf[None, :]
        parents_prob = np.ones(1)
        parents_min = np.array([root_min])
        parents_seen = np.zeros((1, m), dtype=bool)
        n_nodes = 0
        while parents_ctx.shape[0] and n_nodes < self.max_nodes:
            probs = next_probs(parents_ctx)  # (P, m) arc probabilities, one batched model call
            # eq. (5.37): a branch counts for action a at a's first occurrence
            start_mass += np.where(parents_seen, 0.0, probs).T @ parents_mass
            child_prob = parents_prob[:, None] * probs
            n_nodes += int(np.count_nonzero(child_prob))
            end_min = parents_min[:, None] + min_durations[None, :]
            # Algorithm 1, line 16: expand only likely branches that can start within the horizon
            expand = (child_prob >= self.epsilon) & (child_prob > 0.0) & (end_min <= horizon)
            # ... and not those that have seen every target (line 8)
            targets_left = target_mask[None, :] & ~parents_seen
            n_left = targets_left.sum(axis=1)[:, None]
            expand &= (n_left > 1) | ((n_left == 1) & ~targets_left)
            parent_idx, child_action = np.nonzero(expand)
            if parent_idx.size == 0:
                break
            child_ctx = np.concatenate([parents_ctx[parent_idx, 1:], child_action[:, None]], axis=1)
            seen = parents_seen[parent_idx]
            seen[np.arange(parent_idx.size), child_action] = True
            # Branches with the same recent context and the same actions already seen have the
            # same future: merge them (exact, as (5.37) is linear in p_branch * pmf).
            order, starts = _group_rows(child_ctx, seen, m)
            parent_idx, child_action = parent_idx[order], child_action[order]
            first = order[starts]
            # a child ends at its start + its duration (convolution, truncated at the horizon)
            if compiled:
                parents_mass = _kernels.merged_end_mass(starts, parent_idx, child_action, probs, parents_mass,
                                                       duration_pmfs, supports)
            else:
                weighted = np.add.reduceat(
                    probs[parent_idx, child_action, None] * parents_mass[parent_idx], starts, axis=0
                )
                spectra = sp_fft.rfft(weighted, n=n_fft, axis=1) * duration_spectra[child_action[starts]]
                parents_mass = sp_fft.irfft(spectra, n=n_fft, axis=1)[:, :n_bins]
                parents_mass[parents_mass < 1e-15] = 0.0  # FFT round-off, not probability mass
            parents_prob = np.add.reduceat(child_prob[parent_idx, child_action], starts)
            parents_min = np.minimum.reduceat(end_min[parent_idx, child_action], starts)
            parents_ctx = child_ctx[first]
            parents_seen = seen[first]
        cdf = np.cumsum(start_mass, axis=1)
        return times, np.clip(cdf, 0.0, 1.0)

    def distribution(
        self,
        history: Sequence[Hashable],
        elapsed: float | None,
        target: Hashable,
        horizon: float = 60.0,
    ) -> tuple[np.ndarray, np.ndarray]:
        """CDF P(tau^target <= t | history) on t = 0, dt, ..., horizon (Algorithm 1, eq. 5.37)."""
        (code,) = self.model.encode([target])
        times, cdf = self.distributions(history, elapsed, horizon, targets=[target])
        return times, cdf[code]

    def percentiles(
        self,
        history: Sequence[Hashable],
        elapsed: float | None,
        levels: Sequence[float] = (0.2, 0.5, 0.8),
        horizon: float = 60.0,
    ) -> np.ndarray:
        """Waiting-time percentiles (m, P): least grid time with CDF >= level; inf if never."""
        levels = np.asarray(levels, dtype=float)
        if np.any(~np.isfinite(levels)) or np.any((levels <= 0) | (levels >= 1)):
            raise ValueError(f"WaitingTimePredictor: percentile levels must be in (0, 1), got {levels}")
        times, cdf = self.distributions(history, elapsed, horizon)
        return percentiles_from_cdf(times, cdf, levels)


def _row_digits(n_actions: int, width: int) -> np.ndarray | None:
    """Place values that turn a row of `width` codes in -1..m-1 into one int64 (None: overflow)."""
    if width * np.log2(n_actions + 1) > 62:
        return None
    return (n_actions + 1) ** np.arange(width - 1, -1, -1, dtype=np.int64)


def _group_rows(contexts: np.ndarray, seen: np.ndarray, n_actions: int) -> tuple[np.ndarray, np.ndarray]:
    """Groups of equal (context row, seen row): the order that sorts the rows by group and the
    start of each group in it (for ufunc.reduceat). One int64 key per row when it fits."""
    width = contexts.shape[1]
    if width * np.log2(n_actions + 1) + n_actions <= 62:
        key = ((contexts + 1) @ _row_digits(n_actions, width)) << n_actions
        key |= seen.astype(np.int64) @ (np.int64(1) << np.arange(n_actions, dtype=np.int64))
    else:
        rows = np.concatenate([contexts, seen.astype(np.int64)], axis=1)
        key = np.unique(rows, axis=0, return_inverse=True)[1].reshape(-1)
    order = np.argsort(key, kind="stable")
    ordered = key[order]
    starts = np.flatnonzero(np.concatenate(([True], ordered[1:] != ordered[:-1])))
    return order, starts


def percentiles_from_cdf(times: np.ndarray, cdf: np.ndarray, levels: Sequence[float]) -> np.ndarray:
    """First grid time where each CDF row reaches each level (inf when it never does)."""
    cdf = np.atleast_2d(cdf)
    levels = np.asarray(levels, dtype=float)
    reached = cdf[:, None, :] >= levels[None, :, None] - 1e-9
    first = reached.argmax(axis=2)
    return np.where(reached.any(axis=2), times[first], np.inf)
