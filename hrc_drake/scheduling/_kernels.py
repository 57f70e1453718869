"""Compiled kernel (numba) of the Monte Carlo scheduler (Algorithm 4, `scheduling.montecarlo`):
one lockstep step of all its trials, on the net's arcs by transition (`petri_arcs`). The numpy
form `simulate_trials(compiled=False)` is the reference the tests compare against
(tests/scheduling/test_scheduler.py). Compiled when first called, cached on disk
(`hrc_drake.kernels`, group "scheduling").
"""

from __future__ import annotations

import numpy as np
from numba import njit

from hrc_drake import kernels


@njit(cache=True)
def _trial_step(m, arcs, fired, unc, controllable, is_wait_end, pools, count, fire_at, en_prev, t,
                alive, keys, group, key_bonus, horizon, now, quantum, dt, chosen, column, activity_place,
                activity_of_place, pair_of, pair_pools):
    """One lockstep step of `scheduling.montecarlo.simulate_trials` (the trials of Algorithm 4)
    for every trial n, in place: fire fired[n] (when >= 0) chosen by the previous step, enable
    (eq. 6.1), clock the newly enabled uncontrollable transitions from the delay pools (a robot's
    wait ends on the next t_w tick), then choose the next firing (the enabled controllable one
    with the largest key, unless an uncontrollable clock is due now; else the earliest clock) and
    advance the time to it, at most to the horizon. Writes dt, chosen and column (chosen, or -1
    once the trial has reached the horizon); returns whether any trial is still running.
    arcs: the net's arcs by transition (`petri_arcs`): only the places a transition touches are read.
    activity_place, activity_of_place, pair_of, pair_pools: the operator's activity of a trial is
    that of its first marked place of activity_place (else the last column of pair_of); a newly
    enabled transition j with pair_of[j, activity] = l >= 0 takes its delay from pair_pools[n, l]
    instead of pools[n, j] (`scheduling.slowdown`; all -1: no change)."""
    pre_start, pre_place, pre_weight, inc_start, inc_place, inc_delta = arcs
    n_trials = m.shape[0]
    n_tr = pre_start.shape[0] - 1
    depth = pools.shape[2]
    no_activity = pair_of.shape[1] - 1
    any_alive = False
    for n in range(n_trials):
        j = fired[n]
        if j >= 0:  # finished trials fire too: what happens to them is never read
            for a in range(inc_start[j], inc_start[j + 1]):
                m[n, inc_place[a]] += inc_delta[a]
            fire_at[n, j] = np.inf
            en_prev[n, j] = False
        activity = no_activity
        for k in range(activity_place.shape[0]):
            if m[n, activity_place[k]] > 0:
                activity = activity_of_place[k]
                break
        j_unc, t_unc = 0, np.inf
        j_ctrl, best_key, any_ctrl = 0, -np.inf, False
        for j in range(n_tr):
            enabled = True
            for a in range(pre_start[j], pre_start[j + 1]):
                if pre_weight[a] > m[n, pre_place[a]]:
                    enabled = False
                    break
            if enabled and unc[j] and not en_prev[n, j]:
                pair = pair_of[j, activity]
                if pair >= 0:
                    delay = pair_pools[n, pair, count[n, j] % depth]
                else:
                    delay = pools[n, j, count[n, j] % depth]
                if quantum > 0 and is_wait_end[j]:
                    delay = quantum - (now + t[n]) % quantum
                    if delay < 1e-9 * quantum:
                        delay = quantum
                fire_at[n, j] = t[n] + delay
                count[n, j] += 1
            if not enabled:
                fire_at[n, j] = np.inf
            en_prev[n, j] = enabled and unc[j]
            if fire_at[n, j] < t_unc:  # the first earliest clock, as np.argmin
                j_unc, t_unc = j, fire_at[n, j]
            key = -1.0
            if enabled and controllable[j]:
                any_ctrl = True
                key = keys[group[n], j] + key_bonus[j]
            if key > best_key:  # the first largest key, as np.argmax
                j_ctrl, best_key = j, key
        # events due now fire first, so robots freed at the same instant decide together
        has_ctrl = any_ctrl and alive[n] and t_unc > t[n]
        advance = alive[n] and not has_ctrl
        t_next = min(t_unc, horizon) if advance else t[n]
        dt[n] = t_next - t[n]
        t[n] = t_next
        alive[n] = alive[n] and not (advance and t_unc > horizon)
        any_alive = any_alive or alive[n]
        chosen[n] = j_ctrl if has_ctrl else j_unc
        column[n] = chosen[n] if alive[n] else -1
    return any_alive


def petri_arcs(pre, incidence) -> tuple[np.ndarray, ...]:
    """The arcs of a net with pre (P, T) and incidence (P, T), by transition, for `trial_step`:
    (pre_start (T+1,), pre_place, pre_weight) of the input arcs Pre^ij > 0 and (inc_start,
    inc_place, inc_delta) of the nonzero incidence entries, as int64 arrays in CSR form."""
    out = []
    for matrix in (np.asarray(pre), np.asarray(incidence)):
        transition, place = np.nonzero(matrix.T)
        start = np.searchsorted(transition, np.arange(matrix.shape[1] + 1)).astype(np.int64)
        out += [start, place.astype(np.int64), matrix.T[transition, place].astype(np.int64)]
    return tuple(out)


def trial_step(m, arcs, fired, unc, controllable, is_wait_end, pools, count, fire_at, en_prev, t, alive,
               keys, group, key_bonus, horizon: float, now: float, quantum: float, dt, chosen,
               column, activity_place, activity_of_place, pair_of, pair_pools) -> bool:
    """`_trial_step` on the caller's arrays, changed in place (no copies: the caller passes C-ordered
    int64 m (N, P), fired, count, group, chosen, column; bool unc, controllable, is_wait_end,
    en_prev, alive; float64 pools, fire_at, t, keys, key_bonus, dt, pair_pools (N, L, depth); int64
    activity_place, activity_of_place (K,), pair_of (T, C + 1); arcs from `petri_arcs`)."""
    return _trial_step(m, arcs, fired, unc, controllable, is_wait_end, pools, count, fire_at, en_prev, t,
                       alive, keys, group, key_bonus, horizon, now, quantum, dt, chosen, column,
                       activity_place, activity_of_place, pair_of, pair_pools)


def _warm_up_steps() -> list:
    """The calls that compile (or load) the kernels here on tiny inputs (`kernels.warm_up`): the
    trial step needs the arcs' compiled form, so one step."""

    def step():
        ints, flags, reals = np.zeros(1, dtype=np.int64), np.ones(1, dtype=bool), np.zeros(1)
        marking, arcs = np.ones((1, 1), dtype=np.int64), petri_arcs(np.ones((1, 1)), np.zeros((1, 1)))
        trial_step(marking, arcs, ints - 1, flags, ~flags, ~flags, np.ones((1, 1, 1)), marking - 1,
                   np.full((1, 1), np.inf), np.zeros((1, 1), dtype=bool), reals.copy(), flags.copy(),
                   np.zeros((1, 1)), ints, reals, 1.0, 0.0, 0.0, reals.copy(), ints.copy(), ints.copy(),
                   ints[:0], ints[:0], np.full((1, 1), -1, dtype=np.int64), np.zeros((1, 0, 1)))

    return [step]


kernels.register_group(globals())
