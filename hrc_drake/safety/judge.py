"""The ISO/TS 15066 judge: a run's safety verdict, decided on the truth with the standard's values.

The judge is not the controller it judges. It reads the true body and robot capsules, the
declared mode (which rule governs a pair: the cell's risk assessment), the timing of the cell's
sensing and control chain (T_r) and the robot's stopping deceleration from its model; never the
controller's tuning (`safety:`). A scenario may change it only through its `judge:` block, and
then the verdict is NON-CONFORMING (`deviations`).

Its values (docs/safety.md, "The judge"):
- S_p of ISO/TS 15066 eq. (1)-(2) on the truth, C = Z_d = Z_r = 0 (the true body is known
  whole), with the stop the controller really makes: it brakes the whole path at the robot's
  deceleration a on its fastest point (speed V), so T_s = V / a, and a point approaching at v
  travels S_s = v V / (2a) while the robot stops:
      S_p = S_h(T_r + T_s) + v T_r + v V / (2a)
- S_h: ISO 13855's speeds, no cap: hands and arms 2.0 m/s while S_h <= 0.5 m, else 1.6 m/s and
  at least 0.5 m (ISO 13855 eq. 1); head and torso 1.6 m/s (the whole body's approach, the
  speed ISO/TS 15066 5.5.4.2.3 takes for an operator whose speed is not monitored).
- Annex A, Tables A.2 and A.3 as shipped (`limits.load_limits()`); pressures over 1 cm^2;
  transient limits for the first 0.5 s of a free contact, quasi-static once the part is clamped
  or the contact lasts longer; m_R = max(plant's effective mass, M/2) + m_L (eq. A.5).
- a robot point "approaches" when it moves toward the body faster than 1 mm/s (a numerical
  tolerance, not a tunable speed).

Violations, each an episode with onset, duration, pair and worst figure (`Violation`):
- `ssm_breach`: a pair SSM governs whose separation is < S_p while its robot point approaches,
  unless the robot is in a protective stop begun within T_r of the breach's onset and not yet
  longer than S_p assumed;
- `ssm_contact`: the robot, approaching, touches a region SSM governs (at any speed);
- `pfl_contact`: a contact PFL governs over its limit at a sample while it lasts: the peak force
  v_rel sqrt(mu k) (v_rel: the robot's and the person's approach) while the robot approaches,
  or, once the part is held (clamped against any rigid body behind it along the push: the
  table, occluders, another robot or the robot's own other links), the spring force k x the
  depth the robot pressed since, while it lasts;
- `stop`: a protective stop that took longer, or travelled further, than S_p assumed
  (T_r + V/a, V T_r + V^2 / (2a)).
A person who walks into a robot that is not approaching is logged, not held against it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

import numpy as np

from hrc_drake.kernels import capsule_clearances
from hrc_drake.messages import Immutable
from hrc_drake.safety import _kernels
from hrc_drake.safety.config import LIMB_REGIONS, NO_CONTACT_REGIONS, Hybrid, NoSafety, PowerForceLimiting
from hrc_drake.safety.limits import BODY_REGIONS, LimitsTable, load_limits
from hrc_drake.safety.regions import CLAMP_MARGIN, FixedBox
from hrc_drake.traces import AppendOnly, DecimatedTrace

#: ISO 13855:2010 eq. (1): the upper limbs' approach speed K while S <= 0.5 m ...
LIMB_FAST_SPEED = 2.0
#: ... and beyond, with S >= 0.5 m; also the whole body's (walking) approach speed.
WALKING_SPEED = 1.6
LIMB_SWITCH_DISTANCE = 0.5
#: m/s: a robot point slower than this toward the body is not approaching (numerical tolerance).
APPROACH_TOLERANCE = 1e-3
#: s: a free contact is transient for this long, quasi-static afterwards (ISO/TS 15066 Annex A).
TRANSIENT_DURATION = 0.5
#: m^2: the area the pressures of Table A.2 are taken over (1 cm^2).
CONTACT_AREA = 1e-4
#: m: a stop may travel this much beyond what S_p assumed before it counts (the samples' rounding).
STOP_DISTANCE_TOLERANCE = 5e-4
#: m/s: a stopping robot may be this much faster than braking at a from its command allows.
STOP_SPEED_TOLERANCE = 0.01
#: the kinds of violation, in the order the verdict lists them
VIOLATION_KINDS = ("ssm_breach", "ssm_contact", "pfl_contact", "stop")


@dataclass(frozen=True)
class JudgeValues:
    """The values the judge decides with (SI units); `standard_values` gives the conforming ones.

    reaction_time: T_r of the cell's sensing and control chain; deceleration: a of the robot's
    stop; actuation_period: the part of T_r after a stop command (the path follower's period);
    limb_speed / body_speed: v_h of hands and arms (0: ISO 13855's rule) and of head and torso;
    covered_time: H of a motion model whose swept volumes hold the person's next H s (0 for the
    standard: S_h = v_h max(T_r + T_s - H, 0)); the rest as the module's constants.
    """

    reaction_time: float
    deceleration: float
    limits: LimitsTable
    limb_speed: float = 0.0
    body_speed: float = WALKING_SPEED
    covered_time: float = 0.0
    approach_tolerance: float = APPROACH_TOLERANCE
    transient_duration: float = TRANSIENT_DURATION
    contact_area: float = CONTACT_AREA
    clamp_margin: float = CLAMP_MARGIN
    actuation_period: float = 1.0 / 30.0

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name != "limits" and not (math.isfinite(value) and value >= 0):
                raise ValueError(f"JudgeValues.{f.name} must be a finite number >= 0, got {value!r}")
        if self.deceleration <= 0:
            raise ValueError(f"JudgeValues.deceleration must be > 0, got {self.deceleration!r}")


def standard_values(
    reaction_time: float, deceleration: float, actuation_period: float = 1.0 / 30.0
) -> JudgeValues:
    """The conforming judge of a cell whose chain reacts in `reaction_time` s (its last part, the
    path follower's period after a command, `actuation_period`) and whose robot stops at
    `deceleration` m/s^2: ISO 13855's speeds, Annex A's packaged tables."""
    return JudgeValues(
        reaction_time=reaction_time,
        deceleration=deceleration,
        limits=load_limits(),
        actuation_period=actuation_period,
    )


def deviations(values: JudgeValues, standard: JudgeValues) -> tuple[str, ...]:
    """Every way `values` departs from the `standard` judge, in words ("" for none)."""
    out = []
    for f in fields(JudgeValues):
        mine, theirs = getattr(values, f.name), getattr(standard, f.name)
        if f.name == "limits":
            if mine.source != theirs.source or mine.regions != theirs.regions:
                out.append(f"limits table {mine.source!r}, not {theirs.source!r}")
        elif not math.isclose(mine, theirs, rel_tol=1e-9, abs_tol=1e-12):
            out.append(f"{f.name} {mine:g}, not the standard's {theirs:g}")
    return tuple(out)


def human_travel(time, body_region, values: JudgeValues):
    """S_h (m) over `time` (s) per pair: hands and arms at ISO 13855's rule (2.0 m/s while <= 0.5 m,
    else 1.6 m/s and at least 0.5 m) or `limb_speed`; head and torso (`body_region`) at
    `body_speed`; with a covered time H only the time beyond H counts. Broadcasts."""
    time = np.maximum(np.asarray(time, dtype=float) - values.covered_time, 0.0)
    if values.limb_speed > 0:
        limbs = values.limb_speed * time
    else:
        fast = LIMB_FAST_SPEED * time
        limbs = np.where(
            fast <= LIMB_SWITCH_DISTANCE, fast, np.maximum(WALKING_SPEED * time, LIMB_SWITCH_DISTANCE)
        )
        if values.covered_time > 0:  # a time shifted by H is no longer an approach from rest
            limbs = np.where(time > 0, limbs, 0.0)
    return np.where(body_region, values.body_speed * time, limbs)


def protective_separation(approach, fastest, body_region, values: JudgeValues):
    """S_p (m) of eq. (1)-(2) on the truth per pair: S_h(T_r + V/a) + v T_r + v V / (2a), v the
    pair's approach speed, V >= v the robot's fastest point's speed (the stop brakes the path)."""
    v = np.maximum(np.asarray(approach, dtype=float), 0.0)
    fastest = np.maximum(np.asarray(fastest, dtype=float), v)
    a, t_r = values.deceleration, values.reaction_time
    return human_travel(t_r + fastest / a, body_region, values) + v * t_r + v * fastest / (2.0 * a)


@dataclass(frozen=True)
class DeclaredMode:
    """Which rule governs a pair, by the cell's declared mode: `name` (ssm, pfl, hybrid; a cell
    without a safety system is judged as pfl, the standard's most permissive mode), the regions
    PFL may govern and, for hybrid, the collaborative zones (centres (Z, 3), radii (Z,)) where it
    does."""

    name: str
    pfl_regions: frozenset
    zone_centers: np.ndarray
    zone_radii: np.ndarray

    def eligible(self, regions) -> np.ndarray:
        """(R,) whether PFL may govern each region (a `BODY_REGIONS` name each) somewhere."""
        return np.array([name in self.pfl_regions for name in regions], dtype=bool)

    def governed_by_pfl(self, eligible, contact_points) -> np.ndarray:
        """(N,) whether PFL governs each pair: its region may take contact (`eligible`, (N,)) and, in
        a hybrid mode, the pair's contact point (N, 3) lies in a collaborative zone."""
        pfl = np.array(eligible, dtype=bool)
        if self.name == "hybrid" and pfl.any():
            points = np.asarray(contact_points, dtype=float).reshape(-1, 3)
            gaps = np.linalg.norm(points[:, None, :] - self.zone_centers[None], axis=2)
            pfl &= np.any(gaps <= self.zone_radii[None], axis=1)
        return pfl


def declared_mode(config, zones=None) -> DeclaredMode:
    """The `DeclaredMode` of a safety config (`safety.config`) and the layout's zones."""
    centers, radii = zones if zones is not None else (np.zeros((0, 3)), np.zeros(0))
    centers = np.asarray(centers, dtype=float).reshape(-1, 3)
    radii = np.asarray(radii, dtype=float).reshape(-1)
    contact_regions = frozenset(r for r in BODY_REGIONS if r not in NO_CONTACT_REGIONS)
    if isinstance(config, Hybrid):
        # hybrid: hands and arms may take contact in the zones, head and torso never (SSM)
        return DeclaredMode("hybrid", frozenset(config.pfl_regions) & set(LIMB_REGIONS), centers, radii)
    if isinstance(config, PowerForceLimiting) or isinstance(config, NoSafety):
        return DeclaredMode("pfl", contact_regions, centers, radii)
    return DeclaredMode("ssm", frozenset(), centers, radii)


@dataclass(frozen=True)
class Violation(Immutable):
    """One episode the judge holds against the robot (or logs): its kind (`VIOLATION_KINDS`, or
    "contact" for a logged contact within its limits), onset and duration (s), the pair, and its
    worst figure: for a breach the most negative clearance - S_p (m), for a contact the largest
    ratio to its limit, for a stop measured / assumed."""

    kind: str
    onset: float
    duration: float
    link: str
    body_part: str
    region: str
    worst: float
    violation: bool = True
    #: words for the verdict and the plots ("quasi-static limit", "clamped against cart1/rail")
    detail: str = ""

    def as_dict(self) -> dict:
        """JSON-ready fields, rounded."""
        return {f.name: (_round(getattr(self, f.name))) for f in fields(self)}


@dataclass(frozen=True)
class JudgedContact(Immutable):
    """A contact as the judge follows it, sample by sample (SI units)."""

    onset: float
    link: str
    body_part: str
    region: str
    rule: str
    duration: float = 0.0
    #: relative and robot approach speeds at the onset
    relative_speed: float = 0.0
    robot_speed: float = 0.0
    robot_mass: float = 0.0
    #: the worst sample: ratio to its limit, its peak force, which limit
    ratio: float = 0.0
    force: float = 0.0
    limit: str = "transient"
    violation: bool = False
    clamped_against: str = ""
    #: time it became quasi-static (clamped or past the transient duration); nan while transient
    quasi_since: float = math.nan
    #: depth the robot pressed since the onset, at most the overlap (m)
    compression: float = 0.0
    #: time over its limit (s): the samples over it, each for its interval
    over_limit: float = 0.0
    penetration: float = 0.0

    def as_dict(self) -> dict:
        return {f.name: _round(getattr(self, f.name)) for f in fields(self)}


@dataclass(frozen=True)
class Stop(Immutable):
    """A protective stop as measured: commanded at `onset` with the fastest point at `speed`;
    `distance` and `time` the fastest point travelled and moved since; `assumed_*` what S_p took
    after the command (the follower's period P, then the brake: P + V/a and V P + V^2/(2a); the
    rest of T_r came before the command); `speed_ratio` the largest of the fastest point's speed
    over what braking at a from the command allows (V - a (t - P), with a 1 cm/s tolerance);
    `ended`: the command was released."""

    onset: float
    speed: float
    assumed_time: float
    assumed_distance: float
    distance: float = 0.0
    time: float = 0.0
    speed_ratio: float = 0.0
    ended: bool = False

    def ratio(self, period: float) -> float:
        """Measured / assumed, the largest of distance, time and speed, each assumed with its rounding
        tolerance (0.5 mm; one sample `period`; 1 cm/s): above 1 exactly when the stop overran."""
        return max(
            self.distance / (self.assumed_distance + STOP_DISTANCE_TOLERANCE),
            self.time / (self.assumed_time + period + 1e-9),
            self.speed_ratio,
        )

    def overran(self, period: float) -> bool:
        """Longer than S_p assumed: further, later or faster than braking at a allows."""
        return self.ratio(period) > 1.0


@dataclass(frozen=True)
class JudgeRun(Immutable):
    """What the judge has seen so far (replaced by each `Judge.step`, never changed in place)."""

    samples: int = 0
    last_time: float = -math.inf
    last_robot: tuple | None = None
    last_regions: tuple | None = None
    #: closed violations and logged contacts
    episodes: AppendOnly = field(default_factory=AppendOnly)
    #: ((k, r), when the pair's robot point came inside its S_p approaching), for the pairs inside now
    inside: tuple = ()
    #: the SSM breach under way: a `Violation` growing while some pair is in unexcused breach
    breach: Violation | None = None
    #: a breach younger than T_r with no protective stop yet: excused if one begins in time
    pending: Violation | None = None
    contacts: tuple = ()  # ((k, r), JudgedContact)
    stop: Stop | None = None
    stops: AppendOnly = field(default_factory=AppendOnly)
    #: the time of the closed SSM breaches (s; `Judge.breach_seconds` adds the open ones)
    breach_time: float = 0.0
    margin: float = math.inf
    #: whether the controller commanded a protective stop at the last sample
    commanded: bool = False
    #: the robot's fastest end point's speed at the last sample (m/s)
    last_fastest: float = 0.0
    #: when each skeleton point was last measured (the run's start before it ever was)
    last_measured: tuple = (0.0,) * 8
    unobserved_time: float = 0.0
    longest_unobserved: float = 0.0
    min_clearance: float = math.inf
    #: (time, min clearance, clearance and S_p of the SSM pair nearest its S_p, in breach)
    trace: DecimatedTrace = field(default_factory=lambda: DecimatedTrace(8192))


class Judge:
    """Steps a `JudgeRun` with each true sample (pure: `step` returns a new run).

    values: `JudgeValues`; mode: `DeclaredMode`; link_names (K), region_names (R: the region
    capsules' names) and regions (R: their `BODY_REGIONS` names); arm_masses (K): M of each robot
    capsule's moving chain; payloads (K): m_L carried by each capsule's arm; fixed_boxes: rigid
    surfaces of the cell (table, occluders, fixtures) a part can be clamped against.
    """

    def __init__(
        self,
        values: JudgeValues,
        mode: DeclaredMode,
        link_names,
        region_names,
        regions,
        arm_masses,
        payloads=None,
        fixed_boxes: tuple[FixedBox, ...] = (),
    ):
        self.values = values
        self.mode = mode
        self.link_names = tuple(link_names)
        self.region_names = tuple(region_names)
        self.regions = tuple(regions)
        self.body_region = np.array([name not in LIMB_REGIONS for name in self.regions])
        self.pfl_region = mode.eligible(self.regions)
        self.arm_masses = np.asarray(arm_masses, dtype=float)
        self.payloads = np.zeros(len(self.link_names)) if payloads is None else np.asarray(payloads, float)
        self.fixed_boxes = tuple(fixed_boxes)
        halves = [np.multiply(b.size, 0.5) for b in self.fixed_boxes]
        self._boxes = (
            np.array([np.subtract(b.center, h) for b, h in zip(self.fixed_boxes, halves, strict=True)]),
            np.array([np.add(b.center, h) for b, h in zip(self.fixed_boxes, halves, strict=True)]),
        )

    # -- one sample ---------------------------------------------------------------------------

    def step(
        self, run: JudgeRun, time: float, robot, regions, effective_mass, stop_commanded=None, measured=None
    ) -> JudgeRun:
        """The run after a true sample at `time`: robot capsules (start, end, radius) (K) and region
        capsules (R); their velocities are their motion since the last sample. effective_mass(k,
        points, u): the plant's m_R (vectorised); stop_commanded: whether the controller commands
        a protective stop (None: no controller); measured: (8,) which skeleton points the cell
        measured at this sample (None: not known)."""
        dt = time - run.last_time if math.isfinite(run.last_time) else 0.0
        robot = tuple(np.asarray(x, dtype=float) for x in robot)
        regions = tuple(np.asarray(x, dtype=float) for x in regions)
        if not all(np.all(np.isfinite(x)) for x in robot):
            # fail closed: a NaN speed or distance would make every comparison below false
            raise ValueError(f"the judge got a robot capsule that is not finite at t = {time:.3f} s: the "
                             "robot's description or its motion is broken; nothing is judged from it")
        robot_velocity = _velocity(run.last_robot, robot, dt)
        body_velocity = _velocity(run.last_regions, regions, dt)
        end_speeds = np.maximum(
            np.linalg.norm(robot_velocity[0], axis=1), np.linalg.norm(robot_velocity[1], axis=1)
        )
        fastest = float(end_speeds.max(initial=0.0))
        distance = capsule_clearances(*robot, *regions)
        # the tick's largest end displacements, from the speeds already measured
        body_fastest = max(float(np.linalg.norm(v, axis=1).max(initial=0.0)) for v in body_velocity)
        missed = _contact_between_samples(run.last_robot, run.last_regions, robot, regions, distance,
                                          (fastest + body_fastest) * dt)
        # the pairs are judged where they came closest: a contact the sample missed (the robot passed
        # through a body part between two samples) is judged at that instant, with the tick's motion
        seen_robot, seen_regions, distance = missed if missed is not None else (robot, regions, distance)
        stop = self._stop_step(run, time, dt, fastest, stop_commanded)
        k, r = self._candidates(distance, end_speeds, fastest, run)
        inside, contacts, breach, pending = {}, dict(run.contacts), run.breach, run.pending
        episodes = []
        margin = run.margin
        nearest = (math.nan, math.nan)
        worst = waiting = None
        if len(k):
            geometry = _kernels.pair_geometry(
                seen_robot, robot_velocity, seen_regions, np.ascontiguousarray(k), np.ascontiguousarray(r)
            )
            t, surface, on_body, direction, velocity, approach = geometry
            pfl = self.mode.governed_by_pfl(self.pfl_region[r], 0.5 * (surface + on_body))
            gap = distance[k, r]
            sp = protective_separation(approach, fastest, self.body_region[r], self.values)
            counted = ~pfl & (approach > self.values.approach_tolerance)
            if counted.any():
                margins = np.where(counted, gap - sp, np.inf)
                n = int(np.argmin(margins))
                margin = min(margin, float(margins[n]))
                nearest = (float(gap[n]), float(sp[n]))
            inside, worst, waiting = self._inside_step(run, time, k, r, counted & (gap < sp), gap - sp, stop)
            if worst is not None:
                breach = self._breach_sample(
                    breach, time, dt, int(k[worst]), int(r[worst]), float(gap[worst] - sp[worst])
                )
            elif waiting is not None:
                pending = self._breach_sample(
                    pending, time, dt, int(k[waiting]), int(r[waiting]), float(gap[waiting] - sp[waiting])
                )
            touching = (gap < 0.0, pfl, gap, geometry, body_velocity)
            contacts, closed = self._contact_step(
                time, dt, k, r, touching, seen_robot, seen_regions, effective_mass, contacts
            )
            episodes += closed
        breach, pending, ended = self._settle_breaches(
            breach, pending, worst is not None, waiting is not None, stop
        )
        episodes += ended
        last_measured, unobserved, longest = self._unobserved_step(run, time, dt, measured)
        stops = run.stops
        if stop is not None and stop.ended:
            stops, stop = stops.append(stop), None
        min_clearance = float(distance.min(initial=math.inf))
        trace = run.trace.offer((time, min_clearance, *nearest, worst is not None))
        return JudgeRun(
            run.samples + 1,
            time,
            robot,
            regions,
            run.episodes.extend(episodes),
            tuple(sorted(inside.items())),
            breach,
            pending,
            tuple(sorted(contacts.items())),
            stop,
            stops,
            run.breach_time + sum(e.duration for e in episodes if e.kind == "ssm_breach"),
            margin,
            bool(stop_commanded),
            fastest,
            last_measured,
            unobserved,
            longest,
            min(run.min_clearance, min_clearance),
            trace,
        )

    def _candidates(self, distance, end_speeds, fastest, run: JudgeRun):
        """Pairs that may be inside their S_p, may set a new margin, or are in an open breach or
        contact: S_p of a pair is at most S_h(T_r + V/a) + V_k T_r + V_k V / (2a), V_k its
        capsule's fastest end point (a point of a rigid segment is no faster than its ends)."""
        a, t_r = self.values.deceleration, self.values.reaction_time
        human = float(np.max(human_travel(t_r + fastest / a, np.array([False, True]), self.values)))
        reach = human + end_speeds * t_r + end_speeds * fastest / (2.0 * a)
        bound = distance - reach[:, None]
        near = (bound < 0.0) | (bound < run.margin)
        for (k, r), _ in (*run.inside, *run.contacts):
            near[k, r] = True
        k, r = np.nonzero(near)
        return k.astype(np.int64), r.astype(np.int64)

    # -- SSM ------------------------------------------------------------------------------------

    def _inside_step(self, run: JudgeRun, time, k, r, inside_now, margins, stop):
        """(the pairs inside their S_p with the robot point approaching, by when each came inside;
        the index of the pair deepest in unexcused breach, or None; of the pair deepest in a breach
        younger than T_r with no stop begun yet, or None)."""
        since = dict(run.inside)
        inside, worst, waiting = {}, None, None
        stopping = stop is not None and not stop.ended
        for n in np.nonzero(inside_now)[0].tolist():
            key = (int(k[n]), int(r[n]))
            onset = since.get(key, time)
            inside[key] = onset
            if self._excused(stop, onset):
                continue
            if not stopping and time - onset <= self.values.reaction_time + 1e-9:
                if waiting is None or margins[n] < margins[waiting]:
                    waiting = n
            elif worst is None or margins[n] < margins[worst]:
                worst = n
        return inside, worst, waiting

    def _settle_breaches(self, breach, pending, breaching: bool, waiting: bool, stop):
        """(breach under way, pending breach, closed breaches) after a sample: a pending breach whose
        T_r is over, or that is over, counts unless a protective stop began within T_r of it; a
        breach with no unexcused sample now ends."""
        closed = []
        if pending is not None and (breaching or not waiting):
            stopped = (
                stop is not None
                and not stop.ended
                and stop.onset <= pending.onset + self.values.reaction_time
            )
            if not stopped:
                breach = _merged(pending, breach)
            pending = None
        if not breaching and breach is not None:
            closed.append(breach)
            breach = None
        return breach, pending, closed

    def _excused(self, stop: Stop | None, onset: float) -> bool:
        """A breach is excused while a protective stop is under way that began within T_r of the
        breach's onset and is not yet longer than S_p assumed."""
        if stop is None or stop.ended:
            return False
        if stop.onset > onset + self.values.reaction_time + 1e-9:
            return False
        return not stop.overran(0.0)

    def _breach_sample(self, breach: Violation | None, time, dt, k, r, margin) -> Violation:
        """The SSM breach under way after a sample in unexcused breach, deepest at pair (k, r)."""
        if breach is None:
            return Violation(
                "ssm_breach",
                time,
                dt,
                self.link_names[k],
                self.region_names[r],
                self.regions[r],
                margin,
                True,
                f"{-margin:.3f} m inside S_p",
            )
        if margin < breach.worst:
            return replace(
                breach,
                duration=breach.duration + dt,
                link=self.link_names[k],
                body_part=self.region_names[r],
                region=self.regions[r],
                worst=margin,
                detail=f"{-margin:.3f} m inside S_p",
            )
        return replace(breach, duration=breach.duration + dt)

    # -- contacts -------------------------------------------------------------------------------

    def _contact_step(self, time, dt, k, r, pairs, robot, regions, effective_mass, contacts):
        """Follow every contact a sample: open, judge, close; (open contacts, closed episodes).
        pairs: (touching, governed by PFL, clearance, geometry, the body's velocity) of the pairs,
        geometry their (t, robot surface point, body point, direction, velocity, approach)."""
        touching, pfl, gap, geometry, body_velocity = pairs
        t, surface, on_body, direction, velocity, approach = geometry
        out, closed = {}, []
        now = set()
        for n in np.nonzero(touching)[0].tolist():
            key = (int(k[n]), int(r[n]))
            now.add(key)
            human_approach = 0.0
            if body_velocity is not None:
                j = key[1]
                v_body = body_velocity[0][j] + t[n] * (body_velocity[1][j] - body_velocity[0][j])
                human_approach = -float(v_body @ direction[n])  # toward the robot
            robot_mass = self.robot_mass(key[0], surface[n], direction[n], effective_mass)
            against = self.clamped_against(key[0], float(regions[2][key[1]]), on_body[n], direction[n], robot)
            out[key] = self.judge_contact(
                contacts.get(key),
                time,
                dt,
                key,
                bool(pfl[n]),
                float(approach[n]),
                human_approach,
                -float(gap[n]),
                robot_mass,
                against,
                float(np.linalg.norm(velocity[n])),
            )
        for key, contact in contacts.items():
            if key not in now:
                closed.append(self._contact_episode(contact))
        return out, closed

    def robot_mass(self, k: int, point, direction, effective_mass) -> float:
        """m_R at a contact: max(the plant's along u, the standard's M/2) plus the payload m_L."""
        plant = float(
            np.asarray(
                effective_mass(np.array([k]), np.reshape(point, (1, 3)), np.reshape(direction, (1, 3))),
                dtype=float,
            )[0]
        )
        return max(plant, 0.5 * float(self.arm_masses[k])) + float(self.payloads[k])

    def clamped_against(self, k: int, radius: float, body_point, direction, robot) -> str:
        """What clamps a body part (a ball of `radius` at its axis point) pushed by robot capsule k
        along `direction` (unit, robot -> body): a rigid body the ball, pushed `clamp_margin` on,
        would reach and come nearer to; a fixed box (table, occluder), or another robot capsule
        (another robot, a cart, the robot's own other links); "" if none."""
        point = np.reshape(np.asarray(body_point, dtype=float), (1, 3))
        moved = point + self.values.clamp_margin * np.reshape(np.asarray(direction, dtype=float), (1, 3))
        if self.fixed_boxes:
            lower, upper = self._boxes
            now, then = (
                np.linalg.norm(np.maximum(lower - p, 0.0) + np.maximum(p - upper, 0.0), axis=1)
                for p in (point, moved)
            )
            if np.any((then < radius) & (then < now - 1e-9)):
                return "a fixed surface"
        start, end, radii = robot
        ball = np.array([radius])
        now, then = (capsule_clearances(p, p, ball, start, end, radii)[0] for p in (point, moved))
        behind = (then < 0.0) & (then < now - 1e-9)
        behind[k] = False
        return self.link_names[int(np.argmax(behind))] if behind.any() else ""

    def judge_contact(
        self,
        contact: JudgedContact | None,
        time,
        dt,
        key,
        pfl: bool,
        robot_approach: float,
        human_approach: float,
        depth: float,
        robot_mass: float,
        against: str,
        robot_speed: float | None = None,
    ) -> JudgedContact:
        """The contact after one sample. Its limit: transient for the first `transient_duration` of a
        free contact, quasi-static once clamped or later. Its forces: the peak force v_rel sqrt(mu k)
        (eq. A.3) while the robot moves, and, once quasi-static, the spring force k x the depth the
        robot pressed since the onset (its approach over each interval, at most the overlap); the
        ratio to the limit (force, and pressure over 1 cm^2). robot_speed: the robot point's speed
        (None: its approach): a robot at rest is not held to a contact the person made."""
        k, r = key
        values = self.values
        region = values.limits[self.regions[r]]
        speed = robot_approach if robot_speed is None else robot_speed
        moving = speed > values.approach_tolerance
        relative = max(robot_approach + human_approach, 0.0)
        if contact is None:
            contact = JudgedContact(
                time,
                self.link_names[k],
                self.region_names[r],
                self.regions[r],
                "pfl" if pfl else "ssm",
                relative_speed=relative,
                robot_speed=robot_approach,
                robot_mass=robot_mass,
            )
        elapsed = dt if time > contact.onset else 0.0
        rule = "pfl" if contact.rule == "pfl" and pfl else "ssm"  # SSM at any sample: an SSM contact
        against = against or contact.clamped_against
        quasi_since = contact.quasi_since
        if math.isnan(quasi_since) and (against or time - contact.onset > values.transient_duration):
            quasi_since = time
        quasi = not math.isnan(quasi_since)
        # the depth the robot pressed (its approach over each interval), no more than the overlap: the
        # person's own pressing on is not the robot's doing
        compression = min(contact.compression + max(robot_approach, 0.0) * dt, depth)
        mu = 1.0 / (1.0 / region.effective_mass + 1.0 / robot_mass)
        peak = relative * math.sqrt(mu * region.spring_constant) if moving else 0.0  # eq. (A.3)
        spring = region.spring_constant * compression if quasi else 0.0
        force = max(peak, spring)
        ratio = _limit_ratio(region, force, quasi, values.contact_area)
        over = rule == "pfl" and ratio > 1.0
        violation = contact.violation or over or (rule == "ssm" and moving)
        worse = ratio > contact.ratio
        return replace(
            contact,
            rule=rule,
            duration=contact.duration + elapsed,
            ratio=max(ratio, contact.ratio),
            force=force if worse else contact.force,
            limit=("quasi-static" if quasi else "transient") if worse else contact.limit,
            violation=violation,
            clamped_against=against,
            quasi_since=quasi_since,
            compression=compression,
            penetration=max(contact.penetration, depth),
            over_limit=contact.over_limit + (max(elapsed, dt) if over else 0.0),
        )

    def _contact_episode(self, contact: JudgedContact) -> Violation:
        """A closed contact as an episode: an ssm_contact or pfl_contact violation, or a logged one."""
        kind = "contact" if not contact.violation else f"{contact.rule}_contact"
        if not contact.violation:
            detail = (
                f"{contact.ratio:.2f}x the {contact.limit} limit, logged"
                if contact.rule == "pfl"
                else "logged: touched by a robot that was not approaching"
            )
        elif contact.rule == "ssm":
            detail = "touched where SSM governs (no contact permitted)"
        else:
            detail = f"{contact.ratio:.2f}x the {contact.limit} limit"
        if contact.clamped_against:
            detail += f", clamped against {contact.clamped_against}"
        return Violation(
            kind,
            contact.onset,
            contact.duration,
            contact.link,
            contact.body_part,
            contact.region,
            contact.ratio,
            contact.violation,
            detail,
        )

    # -- stops and lost people ------------------------------------------------------------------

    def _stop_step(self, run: JudgeRun, time, dt, fastest, commanded) -> Stop | None:
        """The protective stop under way after this sample, measured on the truth. The judge samples
        before the systems' updates at its time: the command it reads and the motion it sees since
        the last sample were both decided at the last sample. So a stop begins at the first sample
        its command is read, from the speed seen at the sample before, and counts the motion seen
        from that sample on, every sample while the command lasts (a robot that moves again under
        it overruns); it ends at the sample the command is read released (that motion is the
        released command's)."""
        stop = run.stop
        values = self.values
        if stop is None:
            if not commanded or run.commanded:
                return None
            a, period, speed = values.deceleration, values.actuation_period, run.last_fastest
            stop = Stop(time, speed, period + speed / a, speed * period + speed * speed / (2.0 * a))
        elif not commanded:
            return replace(stop, ended=True)
        elapsed = time - stop.onset + dt  # the motion seen now ends `elapsed` after the command
        allowed = max(stop.speed - values.deceleration * (elapsed - values.actuation_period), 0.0)
        moving = fastest > values.approach_tolerance
        return replace(
            stop,
            distance=stop.distance + fastest * dt,
            time=elapsed if moving else stop.time,
            speed_ratio=max(stop.speed_ratio, fastest / (allowed + STOP_SPEED_TOLERANCE)),
        )

    def _unobserved_step(self, run: JudgeRun, time, dt, measured):
        """(when each skeleton point was last measured, the time some point was not, the longest time
        a point went unmeasured)."""
        if measured is None:
            return run.last_measured, run.unobserved_time, run.longest_unobserved
        measured = np.asarray(measured, dtype=bool).reshape(-1)
        last = np.where(measured, time, np.array(run.last_measured, dtype=float))
        unobserved = run.unobserved_time + (0.0 if measured.all() else dt)
        longest = max(run.longest_unobserved, float((time - last).max(initial=0.0)))
        return tuple(last.tolist()), unobserved, longest

    # -- the end --------------------------------------------------------------------------------

    def finish(self, run: JudgeRun) -> tuple[list[Violation], list[Stop]]:
        """Every episode of the run (open ones closed as they are) and every stop, by onset."""
        episodes = list(run.episodes)
        # open at the end: a breach under way, and one still waiting for a stop that never came
        episodes += [e for e in (run.breach, run.pending) if e is not None]
        episodes += [self._contact_episode(c) for _, c in run.contacts]
        stops = list(run.stops) + ([run.stop] if run.stop is not None else [])
        period = self.sample_period(run)
        episodes += [
            Violation("stop", s.onset, s.time, "robot", "", "", s.ratio(period), True, _stop_words(s))
            for s in stops
            if s.overran(period)
        ]
        episodes.sort(key=lambda e: (e.onset, e.kind))
        return episodes, stops

    @staticmethod
    def breach_seconds(run: JudgeRun) -> float:
        """The time in unexcused SSM breach (s), open breaches included."""
        return run.breach_time + sum(e.duration for e in (run.breach, run.pending) if e is not None)

    @staticmethod
    def sample_period(run: JudgeRun) -> float:
        """The mean time between the run's samples (0 before two)."""
        return 0.0 if run.samples < 2 else run.last_time / max(run.samples - 1, 1)


def _stop_words(stop: Stop) -> str:
    """How a stop overran, in words."""
    words = (
        f"{stop.distance * 1000:.1f} mm in {stop.time:.2f} s where S_p assumed "
        f"{stop.assumed_distance * 1000:.1f} mm in {stop.assumed_time:.2f} s"
    )
    if stop.speed_ratio > 1.0:
        words += f"; {stop.speed_ratio:.2f}x the speed braking at a allows"
    return words


def _merged(first: Violation, then: Violation | None) -> Violation:
    """A breach that began as `first` (pending) and went on as `then` (or ended there)."""
    if then is None:
        return first
    deeper = then if then.worst < first.worst else first
    return replace(deeper, onset=min(first.onset, then.onset), duration=first.duration + then.duration)


def _limit_ratio(region, force: float, quasi_static: bool, area: float) -> float:
    """The larger of F / F_max and (F / A) / p_max, quasi-static or transient limits of Table A.2;
    inf for a force on a region where that contact is not permitted at all."""
    force_limit = region.force_limit(quasi_static)
    if force_limit <= 0.0:
        return math.inf if force > 0.0 else 0.0
    return max(force / force_limit, force / area / region.pressure_limit(quasi_static))


#: the finest motion (m) of a capsule's end between two samples the judge looks at: faster, it
#: looks between the samples too (a robot at 1.5 m/s moves 5 cm per 1/30 s tick)
SWEEP_STEP = 0.01
#: the most instants looked at between two samples
MAX_SWEEP = 200


def _contact_between_samples(last_robot, last_regions, robot, regions, distance, move: float):
    """(robot, regions, clearances) at the instant between the last sample and this one (capsule
    ends moving linearly) where a robot-body pair's clearance is least, when that instant holds a
    contact the samples do not show (a link passed through a body part between them); else None.
    Looked at only where the tick's motion could have closed a clearance: a clearance changes by
    at most the sum of the two capsules' largest end displacements (`move`, m: the robot's and the
    body's largest over the tick)."""
    if last_robot is None or last_regions is None or not distance.size or distance.min() <= 0.0:
        return None
    if move <= SWEEP_STEP or distance.min() > move:
        return None
    steps = min(math.ceil(move / SWEEP_STEP), MAX_SWEEP)
    worst = None
    for s in range(1, steps):
        a = s / steps
        at_robot = (last_robot[0] + a * (robot[0] - last_robot[0]),
                    last_robot[1] + a * (robot[1] - last_robot[1]), robot[2])
        at_regions = (last_regions[0] + a * (regions[0] - last_regions[0]),
                      last_regions[1] + a * (regions[1] - last_regions[1]), regions[2])
        clearances = capsule_clearances(*at_robot, *at_regions)
        if clearances.min() < 0.0 and (worst is None or clearances.min() < worst[2].min()):
            worst = (at_robot, at_regions, clearances)
    return worst


def _velocity(last, capsules, dt: float):
    """(v_start, v_end) of capsules' end points by finite difference since `last` (zeros without)."""
    if last is None or dt <= 0:
        return np.zeros_like(capsules[0]), np.zeros_like(capsules[1])
    return (capsules[0] - last[0]) / dt, (capsules[1] - last[1]) / dt


def _round(value):
    if isinstance(value, float):
        return round(value, 4) if math.isfinite(value) else (None if math.isnan(value) else "inf")
    return value
