"""Contact accounting on the truth: every contact between a robot link and a body region, judged
by the ISO/TS 15066 rule that governs it, and the time spent below the protective separation.

A contact is a pair (robot capsule, region capsule) whose true clearance is < 0. At its onset the
model of Annex A gives, for the relative speed v_rel along the contact normal (the robot point's
speed toward the body minus the body point's toward the robot), the robot's effective mass m_R,
the region's m_H and k (Table A.3): mu (eq. A.4), the transferred energy E = mu v_rel^2 / 2, the
peak force F = v_rel sqrt(mu k) (eq. A.3) and pressure F / A, and their ratio to the region's
limits (transient, or quasi-static where a fixed surface clamps the part: then also the spring
force k x depth while the robot keeps pressing). While the contact lasts its penetration depth
grows until the robot stops approaching (its protective stop, `stop_delay`).

Violations by rule, each the robot's doing (it was approaching the body at the onset, or pressed
a clamped part): `ssm`, the robot touched a region that SSM governs; `pfl`, a contact over its
region's limit; with no safety system (`none`) every such contact over the ISO limits (head and
face: any) counts, so an unprotected cell's verdict says what the standard would. A clamped
part's spring force k x depth counts the depth the robot made (its approach speed integrated
over the contact), not the simulated operator's own pressing on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from hrc_drake.messages import Immutable
from hrc_drake.safety import _kernels
from hrc_drake.safety.limits import BODY_REGIONS, contact_peak, limit_ratio
from hrc_drake.safety.rules import SafetyRules, pair_geometry, subset_pairs
from hrc_drake.safety.ssm import protective_separation
from hrc_drake.traces import AppendOnly, DecimatedTrace


@dataclass(frozen=True)
class Contact(Immutable):
    """One contact between a robot link and a body region (SI units)."""

    time: float
    link: str
    body_part: str
    region: str
    #: the rule that governed the pair: ssm, pfl or none (no safety system)
    rule: str
    relative_speed: float
    robot_speed: float
    robot_mass: float
    human_mass: float
    reduced_mass: float
    energy: float
    force: float
    pressure: float
    clamped: bool
    #: the force limit it was judged by (N): transient, or quasi-static when clamped
    force_limit: float
    ratio: float
    violation: bool
    penetration: float = 0.0
    #: the part of the penetration the robot made: its approach speed integrated over the contact
    #: (the simulated operator does not yield, so the rest is the operator pressing on)
    robot_penetration: float = 0.0
    duration: float = 0.0
    #: s from the onset until the robot stopped approaching the body (nan: it never did)
    stop_delay: float = math.nan

    def as_dict(self) -> dict:
        """JSON-ready fields, rounded."""
        out = {}
        for name in self.__dataclass_fields__:
            value = getattr(self, name)
            if isinstance(value, float):
                value = round(value, 4) if math.isfinite(value) else (None if math.isnan(value) else "inf")
            out[name] = value
        return out


@dataclass(frozen=True)
class MonitorRun(Immutable):
    """What the monitor has seen so far: closed contacts, open ones by pair, time figures."""

    contacts: AppendOnly = field(default_factory=AppendOnly)
    open: tuple = ()
    #: (time, min clearance to any region, S_p of that pair, rule of that pair) at every sample
    trace: DecimatedTrace = field(default_factory=lambda: DecimatedTrace(8192))
    samples: int = 0
    time_below_sp_moving: float = 0.0
    last_time: float = -math.inf
    #: region capsules (start, end) at the last sample, for the body's velocities
    last_regions: tuple | None = None
    #: robot capsules (start, end) at the last sample, for the robot's velocities
    last_robot: tuple | None = None
    #: the smallest clearance - S_p so far over the pairs SSM governs with the robot point
    #: approaching (`ssm_margin`); inf before any
    min_ssm_margin: float = math.inf


class ContactAccountant:
    """Steps a `MonitorRun` with each true sample (pure: `step` returns a new run).

    rules: the cell's `SafetyRules` (what governs each pair; `none` rules mark every contact
    "none"); region_names / link_names: names of the region and robot capsules.
    """

    def __init__(self, rules: SafetyRules, limits, link_names, region_names, moving_speed: float = 0.01):
        self.rules = rules
        self.limits = limits
        self.link_names = tuple(link_names)
        self.region_names = tuple(region_names)
        self.moving_speed = float(moving_speed)

    def step(self, run: MonitorRun, time: float, robot, robot_velocity, regions,
             effective_mass) -> MonitorRun:
        """The run after a sample at `time`: robot capsules and their end points' true velocities
        (v_start, v_end; None: by finite differences since the last sample, as the body's), the
        true region capsules; effective_mass(k, points, u) gives m_R (vectorised)."""
        dt = time - run.last_time if math.isfinite(run.last_time) else 0.0
        body_velocity = _body_velocity(run.last_regions, regions, dt)
        if robot_velocity is None:  # the robot's true motion since the last sample
            robot_velocity = _body_velocity(run.last_robot, robot, dt)
            if robot_velocity is None:
                robot_velocity = (np.zeros_like(robot[0]), np.zeros_like(robot[1]))
        rules = self.rules
        distance, k, r = rules.screen(robot, robot_velocity, regions, np.zeros(len(regions[2])))
        nearest = np.unravel_index(np.argmin(distance), distance.shape) if distance.size else None
        open_pairs = dict(run.open)
        below = False
        sp_nearest = math.nan
        rule_nearest = ""
        if len(k) or open_pairs:
            if open_pairs:
                keys = sorted(set(zip(k.tolist(), r.tolist(), strict=True)) | set(open_pairs))
                k = np.array([a for a, _ in keys], dtype=int)
                r = np.array([b for _, b in keys], dtype=int)
            pairs = pair_geometry(robot, robot_velocity, regions, k, r, distance[k, r], rules.compiled)
            pfl = rules.governed_by_pfl(pairs, regions[2])
            sp = rules.separations(pairs, pairs.approach)
            moving = pairs.approach > self.moving_speed
            below = bool(np.any(~pfl & moving & (pairs.distance < sp))) and rules.mode != "none"
            if nearest is not None:
                at = np.nonzero((pairs.k == nearest[0]) & (pairs.r == nearest[1]))[0]
                if len(at):
                    sp_nearest, rule_nearest = float(sp[at[0]]), _rule(rules, bool(pfl[at[0]]))
            touching = np.nonzero(pairs.distance < 0.0)[0]
            if len(touching) or open_pairs:
                open_pairs = self._contacts(time, dt, subset_pairs(pairs, touching), pfl[touching],
                                            body_velocity, regions, open_pairs, effective_mass)
        margin = run.min_ssm_margin
        if rules.mode != "none" and distance.size:
            margin = min(margin, self.ssm_margin(robot, robot_velocity, regions, distance, margin))
        closed = [c for key, c in run.open if key not in open_pairs]
        contacts = run.contacts.extend(replace(c, duration=time - c.time) for c in closed)
        min_distance = float(distance[nearest]) if nearest is not None else math.inf
        trace = run.trace.offer((time, min_distance, sp_nearest, rule_nearest))
        return MonitorRun(contacts, tuple(sorted(open_pairs.items())), trace, run.samples + 1,
                          run.time_below_sp_moving + (dt if below else 0.0), time,
                          (np.array(regions[0]), np.array(regions[1])),
                          (np.array(robot[0]), np.array(robot[1])), margin)

    def ssm_margin(self, robot, robot_velocity, regions, distance, below: float = math.inf) -> float:
        """min over the pairs SSM governs whose robot point approaches the body faster than
        `moving_speed` of (true clearance - S_p at that approach speed), inf when there is none;
        only what lies below `below` counts (the run's margin so far).

        Exact over every pair (not only the screened ones): a pair's approach speed is at most its
        capsule's fastest end point's v_max and S_p grows with the speed, so clearance - S_p(v_max)
        bounds its margin from below, and only the pairs whose bound lies under `below` are
        computed. Its sign agrees with `time_below_sp_moving`: negative exactly at the samples a
        moving robot point was inside the S_p of a region SSM governs."""
        rules = self.rules
        if rules.compiled:
            k, r = _kernels._margin_candidates(distance, *_kernels._arrays(*robot_velocity), *rules._params,
                                               float(below))
        else:
            v_max = np.maximum(np.linalg.norm(robot_velocity[0], axis=1),
                               np.linalg.norm(robot_velocity[1], axis=1))
            reach = np.maximum(protective_separation(v_max, rules.separation),
                               protective_separation(v_max, rules.body_separation))
            k, r = np.nonzero(distance - reach[:, None] < below)
        if not len(k):
            return math.inf
        pairs = pair_geometry(robot, robot_velocity, regions, k, r, distance[k, r], rules.compiled)
        counted = ~rules.governed_by_pfl(pairs, regions[2]) & (pairs.approach > self.moving_speed)
        if not counted.any():
            return math.inf
        return float(np.min((pairs.distance - rules.separations(pairs, pairs.approach))[counted]))

    def _contacts(self, time, dt, pairs, pfl, body_velocity, regions, open_pairs, effective_mass) -> dict:
        """The open contacts after this sample: new ones judged at their onset, old ones deepened."""
        out = {}
        for n, (k, r) in enumerate(zip(pairs.k.tolist(), pairs.r.tolist(), strict=True)):
            depth = -float(pairs.distance[n])
            if depth <= 0.0:
                continue
            approach = float(pairs.approach[n])
            contact = open_pairs.get((k, r))
            pushed = 0.0
            if contact is None:
                contact = self._onset(time, pairs, n, bool(pfl[n]), body_velocity, regions, effective_mass)
            else:
                pushed = max(approach, 0.0) * dt
            region = self.limits[contact.region]
            robot_depth = contact.robot_penetration + pushed
            ratio = contact.ratio
            violation = contact.violation
            if contact.clamped and region.force > 0:
                # clamped: the body's spring compressed by the robot, F = k x depth (quasi-static),
                # over its limit a violation under any rule
                pressed = region.spring_constant * robot_depth / region.force
                ratio = max(ratio, pressed)
                violation = violation or pressed > 1.0
            stop_delay = contact.stop_delay
            if math.isnan(stop_delay) and approach <= self.moving_speed:
                stop_delay = time - contact.time
            out[(k, r)] = replace(contact, penetration=max(contact.penetration, depth), ratio=ratio,
                                  robot_penetration=robot_depth, stop_delay=stop_delay, violation=violation)
        return out

    def _onset(self, time, pairs, n, pfl, body_velocity, regions, effective_mass) -> Contact:
        k, r = int(pairs.k[n]), int(pairs.r[n])
        rules = self.rules
        robot_speed = float(pairs.approach[n])
        human_speed = 0.0
        if body_velocity is not None:
            t = float(pairs.t[n])
            v_body = body_velocity[0][r] + t * (body_velocity[1][r] - body_velocity[0][r])
            human_speed = -float(v_body @ pairs.direction[n])  # toward the robot
        relative = max(robot_speed + human_speed, 0.0)
        rule = _rule(rules, pfl)
        region_name = rules.regions[r]
        region = self.limits[region_name]
        picked = _one(pairs, n)
        robot_mass = float(rules.robot_masses(picked, effective_mass)[0]) if rules.pfl else \
            float(effective_mass(picked.k, picked.robot_point, picked.direction)[0])
        clamped = bool(rules.clamped(picked, regions[2])[0])
        mu, energy, force, pressure = contact_peak(region, robot_mass, relative, rules.contact_area or 1e-4)
        ratio = limit_ratio(region, force, pressure, clamped)
        # a violation is the robot's doing: it was moving toward the body (a person who walks into a
        # stopped robot is logged, not held against the mode); SSM forbids that contact at all
        robot_moving = robot_speed > self.moving_speed
        violation = robot_moving and (rule == "ssm" or ratio > 1.0)
        return Contact(time, self.link_names[k], self.region_names[r], region_name, rule, relative,
                       robot_speed, robot_mass, region.effective_mass, mu, energy, force, pressure, clamped,
                       region.force_limit(clamped), ratio, violation)


def _rule(rules: SafetyRules, pfl: bool) -> str:
    if rules.mode == "none":
        return "none"
    return "pfl" if pfl else "ssm"


def _one(pairs, n):
    return subset_pairs(pairs, np.array([n]))


def _body_velocity(last, regions, dt: float):
    """(v_start, v_end) of capsules by finite difference since their `last` (start, end), or None."""
    if last is None or dt <= 0:
        return None
    return (np.asarray(regions[0]) - last[0]) / dt, (np.asarray(regions[1]) - last[1]) / dt


#: the rules each mode has: the keys of its `violations`
MODE_RULES = {"none": ("none",), "ssm": ("ssm",), "pfl": ("ssm", "pfl"), "hybrid": ("ssm", "pfl")}


def summarize_safety(run: MonitorRun, mode: str, protective_stops: int, limits, standard: str) -> dict:
    """The `safety` figures of metrics.json from a monitor run (open contacts counted as they are).

    Every run of a mode has the same keys (campaign columns): `violations` per rule of the mode,
    `worst_ratio` per body region (0: no contact; null: a contact where none is permitted)."""
    contacts = list(run.contacts) + [c for _, c in run.open]
    contacts.sort(key=lambda c: c.time)
    violations = dict.fromkeys(MODE_RULES[mode], 0)
    worst: dict = {}
    for c in contacts:
        if c.violation:
            violations[c.rule] = violations.get(c.rule, 0) + 1
        if not math.isnan(c.ratio):
            worst[c.region] = max(worst.get(c.region, 0.0), c.ratio)
    total = sum(violations.values())
    ratios = {name: worst.get(name, 0.0) for name in BODY_REGIONS}
    finite = [v for v in worst.values() if math.isfinite(v)]
    return {
        "mode": mode,
        "standard": standard,
        "violations_total": total,
        "violations": violations,
        "worst_ratio": {name: (round(v, 4) if math.isfinite(v) else None) for name, v in ratios.items()},
        "time_below_sp_moving_s": round(run.time_below_sp_moving, 3),
        "margin_m": None if mode == "none" or not math.isfinite(run.min_ssm_margin) else run.min_ssm_margin,
        "contact_margin": 1.0 - max(finite, default=0.0),
        "protective_stops": int(protective_stops),
        "contact_count": len(contacts),
        "contacts": [c.as_dict() for c in contacts],
        "verdict": verdict_line(mode, total, violations, worst, len(contacts), contacts),
    }


def verdict_line(mode: str, total: int, violations: dict, worst: dict, n_contacts: int, contacts) -> str:
    """One line for the CLI: the mode, its violations and the worst contact against its limit."""
    by_rule = ", ".join(f"{n} {rule}" for rule, n in sorted(violations.items()) if n)
    if worst:
        region, ratio = max(worst.items(), key=lambda item: item[1])
        worst_contact = max((c for c in contacts if c.region == region), key=lambda c: c.ratio)
        kind = "quasi-static" if worst_contact.clamped else "transient"
        ratio_text = ("no contact permitted" if not math.isfinite(ratio)
                      else f"{ratio:.2f} of the {kind} limit")
        worst_text = f"; worst {region} contact {ratio_text}"
    else:
        worst_text = "; no contact"
    if mode == "none":
        head = "NO SAFETY SYSTEM: ISO/TS 15066 not applied"
        status = (f"{_count(n_contacts, 'contact')}, {total} over the standard's limits" if n_contacts
                  else "no contact")
        return f"{head}; {status}{worst_text if worst else ''}"
    status = "0 violations" if not total else f"{total} VIOLATIONS ({by_rule})"
    return f"ISO/TS 15066 {mode}: {status}; {_count(n_contacts, 'contact')}{worst_text}"


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"
