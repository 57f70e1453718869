"""The between-subjects study of thesis 7.5.2-7.5.3 with simulated volunteers, at event level
(`hrc_drake.scheduling.cellsim` on the use case's pcTPN): shared by `bench_use_case_b.py` and
`bench_use_case_c.py`.

Each arm (scheduler) gets its own pool of simulated people (`scheduling.volunteers`: a learning
curve, skewed durations, each person their own speed and learning rate), drawn from one
population, so the groups hold different people as the thesis's did. Every person runs once, to
the experiment's number of products. Reported per experiment:

- `between_subjects.p_less`: the thesis's test (one-sided Mann-Whitney, first arm below the
  second, samples pooled over the people of each group) on the first 5 people of each pool, the
  thesis's group size; `p_less_people`: the same people, one median per person (the design's
  unit: pooling a person's successive samples treats them as independent);
- `power.groups_of_5`: the share of 1000 such experiments, 5 people per group drawn again from the
  pools, with p < 0.05 (the thesis's test), `groups_of_5_people` with per-person medians, and the
  power at larger groups;
- `people_needed_p05`: the smallest group size of 5, 10, 15, 20, 30 (at most half a pool) whose
  power reaches 0.8 with the thesis's test (`people_needed_p05_people`: per-person medians);
  None: none does.

Not modelled at event level: the robots' slow-down near the operator (use case c), the cell's
motions; the robots' actions take their flow durations.
"""

from __future__ import annotations

import time

import numpy as np

from hrc_drake.scheduling.cellsim import simulate_cell
from hrc_drake.scheduling.volunteers import (
    VolunteerPopulation,
    action_moments,
    between_subjects_p,
    cycle_times,
    draw_volunteer,
    human_wait_per_product,
    people_needed,
    power_by_resampling,
)

#: the thesis's group size (5 volunteers per scheduler and pattern, 7.5.2 and 7.5.3)
GROUP_SIZE = 5
POWER_DRAWS = 1000
SIZES = (5, 10, 15, 20, 30)


def run_pool(net, make_policy, human_durations: dict, people: int, n_products: int, seed: int,
             population: VolunteerPopulation, max_time: float, label: str) -> list[dict]:
    """`people` simulated persons, each one run of `n_products` products under the policy
    `make_policy(net, person_seed)`; person k's parameters and durations come from seed + k."""
    means, cvs = action_moments(human_durations)
    rows, t0 = [], time.perf_counter()
    for k in range(people):
        rng = np.random.default_rng([seed, k])
        person = draw_volunteer(population, means, cvs, rng)
        run = simulate_cell(net, make_policy(net, seed * 1000 + k), rng, n_products=n_products,
                            max_time=max_time, operator=person)
        rows.append({"speed": person.speed, "learning_rate": person.learning_rate,
                     "products": len(run.product_times), "cycles": cycle_times(run).tolist(),
                     "human_wait": human_wait_per_product(run, net.human_agent).tolist()})
        print(f"    {label} person {k:2d}: speed {person.speed:.2f} rate {person.learning_rate:.2f} "
              f"{rows[-1]['products']} products, cycle median "
              f"{np.median(rows[-1]['cycles']) if rows[-1]['cycles'] else float('nan'):6.1f} s "
              f"({time.perf_counter() - t0:.0f} s)", flush=True)
    return rows


def compare(pools: dict, first: str, second: str, metric: str, seed: int, draws: int = POWER_DRAWS) -> dict:
    """The thesis's test, the power and the people needed for `first` below `second` on `metric`
    ("cycles" or "human_wait"), from the arms' pools (`run_pool`)."""
    pool_a = [row[metric] for row in pools[first] if row[metric]]
    pool_b = [row[metric] for row in pools[second] if row[metric]]
    n = min(GROUP_SIZE, len(pool_a), len(pool_b))
    out = {"metric": metric, "arms": [first, second], "people_per_pool": [len(pool_a), len(pool_b)]}
    if n == 0:
        return {**out, "between_subjects": {"p_less": None}, "power": {}, "people_needed_p05": None}
    rng = np.random.default_rng(seed)
    out["between_subjects"] = {
        "p_less": round(between_subjects_p(pool_a[:n], pool_b[:n]), 5),
        "p_less_people": round(between_subjects_p(pool_a[:n], pool_b[:n], unit="people"), 5),
        "people": n,
        "median_first": round(float(np.median(np.concatenate(pool_a[:n]))), 3),
        "median_second": round(float(np.median(np.concatenate(pool_b[:n]))), 3),
    }
    out["power"] = {"draws": draws}
    for unit, suffix in (("samples", ""), ("people", "_people")):
        if n == GROUP_SIZE:
            power = power_by_resampling(pool_a, pool_b, n, rng, draws, unit=unit)
            out["power"][f"groups_of_5{suffix}"] = power
        needed, by_size = people_needed(pool_a, pool_b, rng, SIZES, draws=max(draws // 2, 1), unit=unit)
        out["power"][f"by_group_size{suffix}"] = {str(k): round(v, 3) for k, v in by_size.items()}
        out[f"people_needed_p05{suffix}"] = needed
    for name, pool in (("first", pool_a), ("second", pool_b)):  # every person of the pool, pooled
        samples = np.concatenate(pool)
        out[f"median_all_{name}"] = round(float(np.median(samples)), 3)
        out[f"quartiles_all_{name}"] = [round(float(q), 3) for q in np.percentile(samples, [25, 50, 75])]
        out[f"mean_all_{name}"] = round(float(samples.mean()), 3)
    return out


def summary_line(label: str, result: dict, thesis: str) -> str:
    """One line a person reads once."""
    bs, power = result["between_subjects"], result["power"]
    if bs["p_less"] is None:
        return f"  {label}: no samples"

    def needed(suffix):
        n = result[f"people_needed_p05{suffix}"]
        tried = [int(k) for k in power.get("by_group_size" + suffix, {})]
        return f"{n}" if n else f"more than {max(tried, default=0)}"

    return (f"  {label}: 5 vs 5 people, p = {bs['p_less']} pooled as the thesis (thesis {thesis}), "
            f"{bs['p_less_people']} per person; power at 5 per group {power.get('groups_of_5')} "
            f"(per person {power.get('groups_of_5_people')}); power 0.8 at p < 0.05 takes {needed('')} "
            f"people per group ({needed('_people')} per person)")
