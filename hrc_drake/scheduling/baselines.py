"""Baseline robot schedulers on the same pcTPN (thesis 7.3.2 and 7.5.1).

Named for what they do: 7.3.2 compares the Monte Carlo scheduler with the centralized
deterministic planner of [93] and the multi-agent stochastic one of [76], and the text does not
say enough to reconstruct either, so neither is claimed here. `BestOfRolloutsPlanPolicy` keeps
what the text gives of [93] (a long-horizon plan on mean durations, suspended on a deadlock for
a random enabled robot action); `RandomEnabledPolicy` has only that random repair.

All share the policy interface of `MonteCarloPolicy`:
``decide(marking, agent, now=0.0, elapsed=None) -> transition index`` and ``observe(j, delay)``.
Collaborations with the human are joined reactively by all baselines: a robot commits to a
human-robot action only when the human already waits for it (as the round robin of 7.5.1).
"""

from __future__ import annotations

import numpy as np

from hrc_drake.messages import shallow_copy
from hrc_drake.scheduling.learning import DurationModel
from hrc_drake.scheduling.montecarlo import copy_generator, simulate_trials
from hrc_drake.scheduling.petri import PcTPN

_PROGRESS = ("end", "intent", "begin", "giveup")


def is_deadlocked(net: PcTPN, marking) -> bool:
    """True when no action is in progress and the human cannot start: only robots can move."""
    en = net.enabled(marking)
    return not any(
        en[j] and not net.controllable[j] and net.role[j] in _PROGRESS for j in range(net.n_transitions)
    )


def _wait_of(net: PcTPN, agent: str) -> int:
    return net.transition_index[f"{agent}:wait"]


def fire_joins(net: PcTPN, marking) -> np.ndarray:
    """`marking` after every join that is enabled has fired (a free partner joins a held action at
    once, 6.3.3; zero delay)."""
    m = np.array(marking, copy=True)
    for _ in range(net.n_transitions + 1):
        en = net.enabled(m)
        joins = [k for k in range(net.n_transitions) if en[k] and net.role[k] == "join"]
        if not joins:
            break
        m = m + net.incidence[:, joins[0]]
    return m


def _human_waits_for(net: PcTPN, marking, action: str) -> bool:
    """Whether the human intends `action` and waits for its preconditions (a marked ``hwait``
    place before one of its starts)."""
    for k in range(net.n_transitions):
        if net.role[k] == "begin" and not net.controllable[k] and net.action[k] == action:
            pre = np.flatnonzero(net.pre[:, k])
            if any(net.places[i].startswith("hwait:") and marking[i] > 0 for i in pre):
                return True
    return False


def _reactive_commit(net: PcTPN, marking, agent: str, en) -> int | None:
    """The agent's commitment to a collaboration the human waits for: one that can start at once
    after the commitment (its parts are there and its partners join), or, for an arm that holds
    for a partner still busy (hold model, 6.3.3), one the human already waits for."""
    for j in net.agent_transitions(agent):
        if net.role[j] != "commit" or not en[j]:
            continue
        after = fire_joins(net, marking + net.incidence[:, j])
        en_after = net.enabled(after)
        for k in range(net.n_transitions):
            if (
                net.role[k] == "begin"
                and not net.controllable[k]
                and net.action[k] == net.action[j]
                and en_after[k]
            ):
                return int(j)
        if len(net.agents[j]) == 1 and _human_waits_for(net, after, net.action[j]):
            return int(j)
    return None


#: roles of the transitions by which a robot starts work of its own (an action, or its hold on an
#: action of two robots)
_WORK = ("begin", "hold")


def _work_choices(net: PcTPN, en, agent: str) -> np.ndarray:
    js = net.agent_transitions(agent)
    return np.array([j for j in js if en[j] and net.role[j] in _WORK], dtype=int)


def _start_of(net: PcTPN, action: str, agent: str) -> int | None:
    """The transition by which `agent` starts robot action `action`: its begin, or its hold on an
    action of two robots (hold model); None when `action` is not a robot action of `agent`."""
    for key in (f"{action}:begin", f"{action}:hold:{agent}"):
        j = net.transition_index.get(key)
        if j is not None and net.controllable[j] and agent in net.agents[j]:
            return j
    return None


class _Policy:
    def __init__(self, net: PcTPN, random_state=None):
        self.net = net
        self.rng = np.random.default_rng(random_state)

    def observe(self, transition, delay: float) -> None:
        """Baselines do not learn."""

    def clone(self):
        """A copy that `decide` may change without touching this one: its own random generator
        (same state) and program pointers; the net, programs and plan are shared (read only)."""
        new = shallow_copy(self)
        new.rng = copy_generator(self.rng)
        if hasattr(self, "pointer"):
            new.pointer = dict(self.pointer)
        return new

    def _repair(self, marking, agent: str, en) -> int:
        """A random enabled robot action other than the wait (the wait when there is none): the
        deadlock repair the thesis gives for [93] (7.3.2)."""
        choices = _work_choices(self.net, en, agent)
        if choices.size:
            return int(self.rng.choice(choices))
        return _wait_of(self.net, agent)


class RandomEnabledPolicy(_Policy):
    """Start whatever is enabled: a random enabled action of the agent, else its wait; joins a
    collaboration as soon as the human waits for it.

    No plan: every decision is the random repair the thesis gives for [93] (7.3.2). It is
    neither [93] (no long-horizon plan) nor [76] (whose repair rules the text does not give).
    """

    def decide(self, marking, agent: str, now: float = 0.0, elapsed=None) -> int:
        en = self.net.enabled(marking)
        commit = _reactive_commit(self.net, marking, agent, en)
        if commit is not None:
            return commit
        return self._repair(marking, agent, en)


class RoundRobinPolicy(_Policy):
    """Fixed cyclic program per robot agent (7.5.1): the next action of the program when it is
    enabled, else the wait quantum; joins a collaboration as soon as the human waits for it.
    On a deadlock the program skips to its next enabled action.

    programs: agent -> list of action names; default: the agent's robot-only actions in flow order.
    """

    def __init__(self, net: PcTPN, programs: dict[str, list[str]] | None = None, random_state=None):
        super().__init__(net, random_state)
        programs = dict(programs or {})
        self.programs: dict[str, list[int]] = {}
        for agent in net.robot_agents:
            names = programs.get(agent)
            if names is None:
                js = [j for j in net.agent_transitions(agent) if net.role[j] in _WORK]
            else:
                js = []
                for name in names:
                    j = _start_of(net, name, agent)
                    if j is None:
                        raise ValueError(f"RoundRobinPolicy: {name!r} is not a robot action of {agent!r}")
                    js.append(j)
            self.programs[agent] = js
        self.pointer = {agent: 0 for agent in net.robot_agents}

    def decide(self, marking, agent: str, now: float = 0.0, elapsed=None) -> int:
        en = self.net.enabled(marking)
        commit = _reactive_commit(self.net, marking, agent, en)
        if commit is not None:
            return commit
        program = self.programs[agent]
        if not program:
            return _wait_of(self.net, agent)
        k = self.pointer[agent]
        if en[program[k]]:
            self.pointer[agent] = (k + 1) % len(program)
            return program[k]
        if is_deadlocked(self.net, marking):
            for step in range(1, len(program)):
                k2 = (k + step) % len(program)
                if en[program[k2]]:
                    self.pointer[agent] = (k2 + 1) % len(program)
                    return program[k2]
            return self._repair(marking, agent, en)
        return _wait_of(self.net, agent)


class _MeanDurations(DurationModel):
    def sample_pools(self, rng, n_trials, depth):
        pools = np.zeros((n_trials, self.net.n_transitions, depth))
        for j in np.flatnonzero(~self.net.controllable):
            pools[:, j, :] = self.mean(j)
        return pools


class BestOfRolloutsPlanPolicy(_Policy):
    """Long-horizon plan, the best of `n_candidates` mean-duration rollouts, with random repair
    on deadlock.

    Offline, `n_candidates` rollouts of the net with every delay at its mean and random robot
    choices are run over `plan_horizon` s, the human following its known pattern; the one with
    the most products, then the lowest idle cost, gives each robot its sequence of actions.
    Online each robot starts its next planned action when enabled, else waits; on a deadlock
    (or past the plan's end) a random enabled robot action other than the wait is executed
    while the plan is suspended. Collaborations are joined reactively (module docstring).

    How it departs from [93] as 7.3.2 describes it: the plan is the best of random rollouts,
    not the output of [93]'s planner, and it follows the human's known pattern instead of
    treating the human as a controllable agent (the thesis blames the deadlocks of [93] and
    [76] on that assumption). Mean durations and the random repair are what the text gives
    of [93].
    """

    def __init__(self, net: PcTPN, plan_horizon: float = 600.0, n_candidates: int = 64, random_state=None):
        super().__init__(net, random_state)
        durations = _MeanDurations(net)
        roots = np.flatnonzero(net.controllable & net.enabled(net.m0))
        # the rollouts as they were before the trials of Algorithm 4 became literal (issue 38):
        # stratified roots, shared keys, and waits on the t_w grid, as this policy's cell waits
        batch = simulate_trials(
            net, net.m0, durations, self.rng, n_candidates, plan_horizon, roots, max_steps=100000,
            stratified_roots=True, common_random_numbers=True, wait_grid=True,
        )
        products = np.zeros(n_candidates)
        for n in range(n_candidates):
            path = batch.paths[n][batch.paths[n] >= 0]
            products[n] = net.post[net.product_places][:, path].sum() if net.product_places.size else 0
        # most products first, then least idle cost
        best = int(np.lexsort((batch.costs, -products))[0])
        path = batch.paths[best][batch.paths[best] >= 0]
        self.plan: dict[str, list[int]] = {a: [] for a in net.robot_agents}
        for j in path:  # a held action's partner joins by itself, so it is in the holder's plan only
            if net.controllable[j] and net.role[j] in _WORK:
                for agent in net.agents[j]:
                    self.plan[agent].append(int(j))
        self.pointer = {a: 0 for a in net.robot_agents}

    def decide(self, marking, agent: str, now: float = 0.0, elapsed=None) -> int:
        en = self.net.enabled(marking)
        commit = _reactive_commit(self.net, marking, agent, en)
        if commit is not None:
            return commit
        plan, k = self.plan[agent], self.pointer[agent]
        if k < len(plan) and en[plan[k]]:
            j = plan[k]
            for other in self.net.agents[j]:
                self.pointer[other] += 1
            return j
        if k >= len(plan) or is_deadlocked(self.net, marking):
            return self._repair(marking, agent, en)
        return _wait_of(self.net, agent)
