"""Event-level cell simulator (pure Python, no Drake): the pcTPN compiled from the flow is the
ground truth, with the true duration distributions. Uncontrollable transitions (the human's
intentions and starts, every action's end, the end of a wait) race as in 6.2.1; the robots'
controllable transitions fire only when the scheduler policy commands them, each time a robot
is free (7.1, receding horizon). A robot's wait lasts t_w (6.3.1) or, with the `wait_grid`
variant, ends on the next global t_w tick (`montecarlo.wait_delay`). Events due now fire before
the next decision, so an arm freed beside its holding partner joins it at once (6.3.3).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hrc_drake.distributions import sample_duration
from hrc_drake.scheduling.montecarlo import wait_delay
from hrc_drake.scheduling.petri import PcTPN


@dataclass
class CellRun:
    """Result of `simulate_cell`.

    events: (time, agent, action, kind) tuples, kind begin | end | wait_begin | wait_end.
    product_times: time of each finished product. cycle_ends: time each human pattern cycle ended.
    idle: agent -> seconds spent idle (robot waits, robots committed to a collaboration,
    human waiting for preconditions). decisions: scheduler calls.
    """

    events: list = field(default_factory=list)
    product_times: list = field(default_factory=list)
    cycle_ends: list = field(default_factory=list)
    idle: dict = field(default_factory=dict)
    end_time: float = 0.0
    decisions: int = 0

    @property
    def cycle_times(self) -> np.ndarray:
        """Durations of the human's pattern cycles (the first counted from t = 0)."""
        return np.diff(np.concatenate([[0.0], self.cycle_ends]))

    @property
    def time_per_product(self) -> float:
        """Mean time per finished product: last product time / products (inf without any)."""
        if not self.product_times:
            return float("inf")
        return self.product_times[-1] / len(self.product_times)


def simulate_cell(
    net: PcTPN,
    policy,
    rng: np.random.Generator,
    n_cycles: int | None = None,
    n_products: int | None = None,
    max_time: float = 3600.0,
    learn: bool = True,
    wait_grid: bool | None = None,
    operator=None,
) -> CellRun:
    """Run the cell until `n_cycles` human pattern cycles, `n_products` products or `max_time`.

    policy: an object with ``decide(marking, agent, now, elapsed) -> transition`` and
    ``observe(transition, delay)`` (MonteCarloPolicy or a baseline).
    wait_grid: how a robot's wait is executed: False, it lasts t_w (6.3.1); True, it ends on
    the next multiple of t_w (the grid variant, on which robots that wait meet, as actions of
    several arms need). None: the policy's own `wait_grid` (a `MonteCarloPolicy` models its
    waits so), else True (the baselines, as before).
    operator: the true durations of the human's actions, an object with
    ``duration(action, repetition, rng) -> s`` (repetition: 1 for the person's first execution of
    the action; e.g. a `volunteers.Volunteer`); None: the net's delays.
    """
    if wait_grid is None:
        wait_grid = bool(getattr(policy, "wait_grid", True))
    if not isinstance(rng, np.random.Generator):
        raise ValueError("simulate_cell: rng must be a numpy.random.Generator")
    if n_cycles is None and n_products is None and not np.isfinite(max_time):
        raise ValueError("simulate_cell: give n_cycles, n_products or a finite max_time")
    n_t = net.n_transitions
    unc = ~net.controllable
    m = net.m0.copy()
    t = 0.0
    fire_at = np.full(n_t, np.inf)
    enabled_since = np.full(n_t, np.nan)
    en_prev = np.zeros(n_t, dtype=bool)
    run = CellRun(idle={a: 0.0 for a in [*net.robot_agents, net.human_agent]})
    idle_places = [(i, net.idle_agent[i].split(",")) for i in range(net.n_places) if net.idle_agent[i]]
    avail = {r: net.place_index[f"avail:{r}"] for r in net.robot_agents}
    products = getattr(net, "product_places", np.zeros(0, dtype=int))
    cycle_place = net.place_index.get("step:0")
    human = net.human_agent
    human_waiting: set[int] = set()
    human_end = np.array([net.role[j] == "end" and _has_human(net, j) for j in range(n_t)], dtype=bool)
    repetitions: dict[str, int] = {}

    def fire(j: int):
        nonlocal m
        m = m + net.incidence[:, j]
        role, action = net.role[j], net.action[j]
        if role == "begin" or role == "end":
            with_human = (role == "begin" and not net.controllable[j]) or (
                role == "end" and _has_human(net, j)
            )
            agents = list(net.agents[j]) + ([human] if with_human else [])
            if role == "begin" and not net.controllable[j] and j in human_waiting:
                run.events.append((t, human, action, "wait_end"))
                human_waiting.discard(j)
            for a in agents:
                run.events.append((t, a, action, role))
            if with_human and hasattr(policy, "human_event"):  # a policy that forecasts the human
                policy.human_event(action, role, t)
        elif role == "join" and _starts_action(net, j):  # the partner joined: both arms begin
            for a in net.agents[j]:
                run.events.append((t, a, action, "begin"))
        elif role == "wait":
            run.events.append((t, net.agents[j][0], "", "wait_begin"))
        elif role == "wait_end":
            run.events.append((t, net.agents[j][0], "", "wait_end"))
        if products.size and net.post[products, j].any():
            run.product_times.extend([t] * int(net.post[products, j].sum()))
        if cycle_place is not None and net.post[cycle_place, j] > 0:
            run.cycle_ends.append(t)

    def update_clocks():
        nonlocal en_prev
        en = net.enabled(m)
        for j in np.flatnonzero(en & unc & ~en_prev):
            if net.role[j] == "wait_end":
                delay = float(wait_delay(t, net.wait_quantum, wait_grid))
            elif operator is not None and human_end[j]:
                action = net.action[j]
                repetitions[action] = repetitions.get(action, 0) + 1
                delay = float(operator.duration(action, repetitions[action], rng))
            else:
                delay = sample_duration(net.delays[j], rng)
            fire_at[j] = t + delay
            enabled_since[j] = t
        fire_at[~en] = np.inf
        enabled_since[~en] = np.nan
        en_prev = en & unc

    for _ in range(10_000_000):
        update_clocks()
        # decisions for every free robot (each decision uses up the robot's token), once every
        # event due now has fired, so robots freed at the same instant can act together
        if not np.any(fire_at <= t):
            for _guard in range(10 * len(avail) + 1):
                free = [r for r, i in avail.items() if m[i] > 0]
                if not free:
                    break
                agent = free[0]
                elapsed = np.where(np.isnan(enabled_since), 0.0, t - enabled_since)
                j = int(policy.decide(m, agent, now=t, elapsed=elapsed))
                run.decisions += 1
                if not (net.controllable[j] and agent in net.agents[j] and net.enabled(m)[j]):
                    raise ValueError(
                        f"simulate_cell: the policy chose {net.transitions[j]!r} for {agent!r}, "
                        "which is not an enabled controllable transition of that agent"
                    )
                fire(j)
                update_clocks()
                if np.any(fire_at <= t):  # e.g. a partner joins a held action before it decides
                    break
        j = int(np.argmin(fire_at))
        t_next = fire_at[j]
        if not np.isfinite(t_next) or t_next > max_time:
            dt = max_time - t if np.isfinite(max_time) else 0.0
            for i, agents in idle_places:
                for a in agents:
                    run.idle[a] += m[i] * dt
            t = max_time if np.isfinite(max_time) else t
            break
        dt = t_next - t
        for i, agents in idle_places:
            if m[i]:
                for a in agents:
                    run.idle[a] += m[i] * dt
        t = t_next
        if learn and net.role[j] in ("end", "intent"):
            policy.observe(j, t - enabled_since[j])
        fire_at[j] = np.inf
        en_prev[j] = False
        enabled_since[j] = np.nan
        fire(j)
        if net.role[j] == "intent":  # the start is not enabled: the human waits (6.3.2)
            starts = [
                k
                for k in range(n_t)
                if net.role[k] == "begin" and not net.controllable[k] and net.pre[:, k] @ net.post[:, j] > 0
            ]
            if starts and not net.enabled(m)[starts[0]]:
                human_waiting.add(starts[0])
                run.events.append((t, human, net.action[j], "wait_begin"))
        if n_cycles is not None and len(run.cycle_ends) >= n_cycles:
            break
        if n_products is not None and len(run.product_times) >= n_products:
            break
    run.end_time = t
    return run


def _starts_action(net: PcTPN, j: int) -> bool:
    """Whether transition j starts its action (marks a ``busy:`` place)."""
    return any(net.places[i].startswith("busy:") for i in np.flatnonzero(net.post[:, j]))


def _has_human(net: PcTPN, j: int) -> bool:
    """Whether end transition j returns the human's token (a human action)."""
    return any(net.places[i].startswith(("step:", "human:idle")) for i in np.flatnonzero(net.post[:, j]))
