"""Compiled kernel (numba) of the waiting-time predictor (Algorithm 1, `prediction.waiting`):
one level of the waiting-time tree, its children merged and each group's start-time pmf
convolved with its action's duration pmf (a direct convolution). `distributions(compiled=False)`
is the numpy reference the tests compare against (tests/prediction/test_waiting.py). Compiled
when first called, cached on disk (`hrc_drake.kernels`, group "prediction").
"""

from __future__ import annotations

import numpy as np
from numba import njit

from hrc_drake import kernels
from hrc_drake.kernels import _arrays


@njit(cache=True)
def _merged_end_mass(starts, parent_idx, child_action, probs, parents_mass, duration_pmfs, supports):
    """One level of Algorithm 1's tree (`prediction.waiting`): the children, sorted by group and
    starting at `starts`, merged (sum of p_arc * parent's end-time pmf per group), then each
    group's start-time pmf convolved with its action's duration pmf (direct sum over the pmf's
    support, truncated at the grid's end). Returns (groups, G)."""
    n_groups, n_rows = starts.shape[0], parent_idx.shape[0]
    n_bins = parents_mass.shape[1]
    out = np.zeros((n_groups, n_bins))
    weighted = np.empty(n_bins)
    for g in range(n_groups):
        stop = starts[g + 1] if g + 1 < n_groups else n_rows
        for t in range(n_bins):
            weighted[t] = 0.0
        for r in range(starts[g], stop):
            parent = parent_idx[r]
            arc = probs[parent, child_action[r]]
            for t in range(n_bins):
                weighted[t] += arc * parents_mass[parent, t]
        action = child_action[starts[g]]
        support = supports[action]
        for t in range(n_bins):
            total = 0.0
            for k in range(min(support, t + 1)):
                total += weighted[t - k] * duration_pmfs[action, k]
            out[g, t] = total
    return out


def merged_end_mass(starts, parent_idx, child_action, probs, parents_mass, duration_pmfs,
                    supports) -> np.ndarray:
    """`_merged_end_mass`: int arrays starts, parent_idx, child_action, supports; float probs (P, m),
    parents_mass (P, G), duration_pmfs (m, G)."""
    ints = (np.ascontiguousarray(a, dtype=np.int64) for a in (starts, parent_idx, child_action))
    return _merged_end_mass(*ints, *_arrays(probs, parents_mass, duration_pmfs),
                            np.ascontiguousarray(supports, dtype=np.int64))


def _warm_up_steps() -> list:
    """The call that compiles (or loads) the kernel here on tiny inputs (`kernels.warm_up`)."""
    return [lambda: merged_end_mass(np.zeros(1), np.zeros(1), np.zeros(1), np.ones((1, 1)), np.ones((1, 2)),
                                    np.ones((1, 2)), np.ones(1))]


kernels.register_group(globals())
