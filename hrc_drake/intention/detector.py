"""Actions recognised from the hands entering and leaving goal regions (thesis Ch. 2 preamble).

Every human action a has a goal region G_a, a sphere of centre C_a and radius r_a: "when an
operator's hand enters this area the beginning of the corresponding action can be detected".
`GoalRegionDetector` turns a stream of wrist estimates into begin/end `HumanEvent`s, robust to
what a tracker gives:

- hysteresis: a wrist enters G_a when |w - C_a| <= entry_scale * r_a and leaves it only when
  |w - C_a| > exit_scale * r_a, so jitter at the border starts and ends nothing;
- minimum dwell: an entry (within entry_scale * r_a) counts once the wrist has stayed min_dwell
  s without leaving the exit band (exit_scale * r_a): the dwell runs in the whole band, so a
  hand that crosses a region on its way elsewhere starts no action only when its chord through
  the exit sphere takes less than min_dwell: through the centre, a crossing faster than about
  2 exit_scale r_a / min_dwell (0.9 m/s for r_a = 0.07 m, exit_scale 1.3 and 0.2 s); slower
  crossings are actions (box_usb's g1_home, crossed on the way to other goals, is perceived
  as tape there: tests/cell/test_perceived_events.py). Counting the dwell inside the entry
  radius only filters more crossings but loses actions whose hand stops in the band: box_usb's
  bring at g4_station, recall 0.89 -> 0.44 in its 60 s test run (issue 38). The begin is
  dated at the entry;
- lost points: a wrist whose estimate is not finite, or whose spread exceeds max_spread, is
  unknown: it changes nothing, and a wrist unknown for longer than lost_timeout s leaves its
  region, the action ending when it was last seen inside;
- two hands: each hand has its own machine, so two hands work in two regions at once; two hands
  in one region are one action, begun by the first and ended by the last to leave.

The detector is an immutable value: `update` returns a new detector (itself when nothing
changed) and the events of that update.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from hrc_drake.intention.config import END_RULES
from hrc_drake.messages import HANDS, L_WRIST, R_WRIST, HumanEvent, Immutable

#: the skeleton point of each hand, in `HANDS` order
WRIST_POINTS = (L_WRIST, R_WRIST)

OUTSIDE, ENTERING, INSIDE = "outside", "entering", "inside"


@dataclass(frozen=True)
class HandTrack(Immutable):
    """One hand's machine: its phase, the goal (index) it is entering or inside, the time it
    entered, and since when its estimate is lost (NaN while known). It changes only at a
    transition, so a detector whose hands do nothing new stays the same value."""

    phase: str = OUTSIDE
    goal: int = -1
    entered: float = math.nan
    lost_since: float = math.nan


@dataclass(frozen=True)
class GoalRegionDetector(Immutable):
    """Begin/end events of the actions whose goal regions the hands enter (thesis Ch. 2).

    goals: goal names (G,); centers (G, 3) C_a (m); radii (G,) r_a (m); actions: the action of
    each goal (G,), named in the events (default: the goal's name). entry_scale, exit_scale:
    the hysteresis band, entry at entry_scale * r_a, exit beyond exit_scale * r_a
    (0 < entry_scale <= exit_scale). min_dwell (s >= 0), max_spread (m > 0: the largest
    estimate spread still used), lost_timeout (s > 0): see the module docstring. agent: the
    events' agent. end_rule: "exit" (an action ends when the last hand leaves its region) or
    "next" (an action lasts until the next begins: for actions that go on beyond their region,
    e.g. take a part there and work elsewhere; the thesis dates only the begin, by the entry).
    Under "next" every entry into a region that no hand was in begins an instance, so two
    consecutive instances of one action are two actions (thesis Ch. 2: a hand entering G_a is
    the beginning of a). "next_merging_reentries" is our earlier variant: a region left and
    entered again continues its action, which never perceives two consecutive instances of one
    action (pcb_ic's pattern 2 of Fig. 5.17, two IC insertions in a row, lost every second one).
    """

    goals: tuple[str, ...]
    centers: np.ndarray
    radii: np.ndarray
    actions: tuple[str, ...] = ()
    entry_scale: float = 1.0
    exit_scale: float = 1.3
    min_dwell: float = 0.2
    max_spread: float = 0.1
    lost_timeout: float = 2.0
    agent: str = "human"
    end_rule: str = "exit"
    hands: tuple[HandTrack, ...] = (HandTrack(), HandTrack())
    seq: int = 0
    #: with end_rule "next" (or its variant): the action begun last and not yet ended (-1: none)
    current: int = -1
    #: with end_rule "next": when the last hand left the current action's region (NaN: a hand is
    #: in it); only an entry after that begins a new instance of the same action
    current_left: float = math.nan
    #: time of the last transition: an earlier (or not finite) frame time is ignored
    last_transition: float = -math.inf

    def __post_init__(self):
        goals = tuple(str(g) for g in self.goals)
        centers = np.asarray(self.centers, dtype=float).reshape(-1, 3)
        radii = np.asarray(self.radii, dtype=float).reshape(-1)
        actions = tuple(str(a) for a in self.actions) if self.actions else goals
        if not goals or centers.shape != (len(goals), 3) or radii.shape != (len(goals),):
            raise ValueError(
                f"GoalRegionDetector: need G >= 1 goals with centers (G, 3) and radii (G,), got "
                f"{len(goals)} goals, centers {centers.shape}, radii {radii.shape}")
        if len(actions) != len(goals):
            raise ValueError(f"GoalRegionDetector: {len(actions)} actions for {len(goals)} goals")
        if not np.all(np.isfinite(centers)) or not np.all(np.isfinite(radii) & (radii > 0)):
            raise ValueError("GoalRegionDetector: centers must be finite and radii finite and > 0")
        if not (0.0 < self.entry_scale <= self.exit_scale < math.inf):
            raise ValueError(f"GoalRegionDetector: need 0 < entry_scale <= exit_scale < inf, got "
                             f"{self.entry_scale!r}, {self.exit_scale!r}")
        if self.end_rule not in END_RULES:
            raise ValueError(f"GoalRegionDetector: end_rule must be one of {END_RULES}, "
                             f"got {self.end_rule!r}")
        if not 0.0 <= self.min_dwell < math.inf:
            raise ValueError(f"GoalRegionDetector: min_dwell must be >= 0, got {self.min_dwell!r}")
        for name in ("max_spread", "lost_timeout"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"GoalRegionDetector: {name} must be > 0, got {getattr(self, name)!r}")
        object.__setattr__(self, "goals", goals)
        object.__setattr__(self, "centers", centers)
        object.__setattr__(self, "radii", radii)
        object.__setattr__(self, "actions", actions)

    # ------------------------------------------------------------------ reading
    def active(self) -> dict[str, tuple[str, ...]]:
        """{action: hands inside its region} of the actions begun and not ended."""
        out: dict[str, list[str]] = {}
        for hand, track in zip(HANDS, self.hands, strict=True):
            if track.phase == INSIDE:
                out.setdefault(self.actions[track.goal], []).append(hand)
        return {action: tuple(hands) for action, hands in out.items()}

    # ------------------------------------------------------------------ update
    def update(self, time: float, wrists, known) -> tuple[GoalRegionDetector, list[HumanEvent]]:
        """Advance both hands to `time` with wrists (2, 3) (left, right) and known (2,) bool
        (False: the estimate is lost); returns (the next detector, its events, oldest first).

        A wrist that is not finite counts as lost. A frame whose time is not finite or earlier
        than the last transition changes nothing (a stream may repeat or reorder frames). Call
        `known_wrists` to apply max_spread to a `SkeletonEstimate`."""
        time = float(time)
        if not time >= self.last_transition or math.isinf(time):
            return self, []
        wrists = np.asarray(wrists, dtype=float).reshape(2, 3)
        known = np.asarray(known, dtype=bool).reshape(2) & np.all(np.isfinite(wrists), axis=1)
        distance = np.sqrt(np.sum((wrists[:, None, :] - self.centers[None, :, :]) ** 2, axis=-1))  # (2, G)
        hand_events: list[tuple[float, int, str, int]] = []  # (time, hand, kind, goal)
        tracks = tuple(self._step_hand(self.hands[h], h, time, distance[h], bool(known[h]), hand_events)
                       for h in range(2))
        if all(new is old for new, old in zip(tracks, self.hands, strict=True)):
            return self, []  # a hand's track is replaced only at a transition
        events, seq, current, current_left = self._merge(hand_events)
        return replace(self, hands=tracks, seq=seq, current=current, current_left=current_left,
                       last_transition=time), events

    def known_wrists(self, points, spread):
        """(wrists (2, 3), known (2,)) of a skeleton estimate: points (8, 3), spread (8,) (m);
        a wrist is known when finite and its spread is at most max_spread (not when the camera
        saw it: a tracker's estimate of an occluded point is usable while its spread is small)."""
        points = np.asarray(points, dtype=float).reshape(8, 3)
        spread = np.asarray(spread, dtype=float).reshape(8)
        wrists = points[list(WRIST_POINTS)]
        known = np.all(np.isfinite(wrists), axis=1) & (spread[list(WRIST_POINTS)] <= self.max_spread)
        return wrists, known

    def _step_hand(self, track: HandTrack, h: int, time: float, distance: np.ndarray, known: bool,
                   out: list) -> HandTrack:
        """One hand's transition (module docstring); appends its (time, hand, kind, goal)."""
        if not known:
            if track.phase == OUTSIDE:
                return track
            if math.isnan(track.lost_since):
                return replace(track, lost_since=time)
            if time - track.lost_since > self.lost_timeout:
                if track.phase == INSIDE:
                    out.append((track.lost_since, h, "end", track.goal))
                return HandTrack()
            return track
        if not math.isnan(track.lost_since):
            track = replace(track, lost_since=math.nan)
        if track.phase == OUTSIDE:
            return self._maybe_enter(track, h, time, distance, out)
        inside = distance[track.goal] <= self.exit_scale * self.radii[track.goal]
        if track.phase == ENTERING:
            if not inside:  # passed through, or jitter before the dwell: no action
                return self._maybe_enter(HandTrack(), h, time, distance, out)
            if time - track.entered >= self.min_dwell:
                out.append((track.entered, h, "begin", track.goal))
                return replace(track, phase=INSIDE)
            return track
        if inside:  # INSIDE
            return track
        out.append((time, h, "end", track.goal))
        return self._maybe_enter(HandTrack(), h, time, distance, out)

    def _maybe_enter(self, track: HandTrack, h: int, time: float, distance: np.ndarray,
                     out: list) -> HandTrack:
        """Outside: enter the nearest region within entry_scale * r_a, if any."""
        margin = distance - self.entry_scale * self.radii
        goal = int(np.argmin(margin))
        if margin[goal] > 0.0:
            return track
        if self.min_dwell <= 0.0:
            out.append((time, h, "begin", goal))
            return HandTrack(INSIDE, goal, time)
        return HandTrack(ENTERING, goal, time)

    def _merge(self, hand_events: list) -> tuple[list[HumanEvent], int, int, float]:
        """Hand-level transitions to action events: an action begins with the first hand inside
        its region and ends when the last one leaves ("exit"), or when the next begins ("next": a
        new entry into an empty region, the same action's included; the variant skips those)."""
        inside = [0] * len(self.goals)
        for track in self.hands:
            if track.phase == INSIDE:
                inside[track.goal] += 1
        events: list[HumanEvent] = []
        seq, current, current_left = self.seq, self.current, self.current_left

        def emit(time, h, kind, goal):
            nonlocal seq
            seq += 1
            events.append(HumanEvent(time=time, action=self.actions[goal], kind=kind, seq=seq,
                                     agent=self.agent, hand=HANDS[h], goal=self.goals[goal]))

        for time, h, kind, goal in sorted(hand_events, key=lambda e: (e[0], e[2] != "end")):
            inside[goal] += 1 if kind == "begin" else -1
            if inside[goal] != (1 if kind == "begin" else 0):
                continue  # the other hand began this action already, or is still inside
            if self.end_rule == "exit":
                emit(time, h, kind, goal)
            elif kind == "end":
                if goal == current:
                    current_left = time
            else:
                # a hand whose dwell ends after the other hand left entered while it was inside:
                # the same instance
                repeat = self.end_rule == "next" and goal == current and time >= current_left
                if goal != current or repeat:
                    if current >= 0:
                        emit(time, h, "end", current)
                    emit(time, h, "begin", goal)
                    current = goal
                current_left = math.nan
        return events, seq, current, current_left


def _instances(events) -> list[tuple[str, float, float]]:
    """(action, begin, end) of every action begun in `events` (end inf while it goes on)."""
    open_: dict[str, list[float]] = {}
    out = []
    for e in sorted(events, key=lambda e: (e.time, e.kind != "end")):
        if e.kind == "begin":
            open_.setdefault(e.action, []).append(e.time)
        elif e.kind == "end" and open_.get(e.action):
            out.append((e.action, open_[e.action].pop(0), e.time))
    out += [(a, t, math.inf) for a, times in open_.items() for t in times]
    return sorted(out, key=lambda x: x[1])


def detection_quality(truth, perceived, slack: float = 1.0) -> dict:
    """How well perceived actions match the true ones: each perceived begin is matched, in time
    order, to the earliest unmatched true instance of the same action whose [begin, end + slack]
    holds it. Returns precision (matched / perceived), recall (matched / true), the median and
    p90 latency of the matched begins (perceived - true, s), spurious and missed counts.

    truth, perceived: events with time, action and kind ("begin"/"end"; others are ignored).
    """
    true_instances = _instances(truth)
    seen = _instances(perceived)
    used = [False] * len(true_instances)
    latencies = []
    for action, begin, _ in seen:
        for k, (true_action, true_begin, true_end) in enumerate(true_instances):
            if not used[k] and true_action == action and true_begin - slack <= begin <= true_end + slack:
                used[k] = True
                latencies.append(begin - true_begin)
                break
    matched = len(latencies)
    return {
        "event_precision": matched / len(seen) if seen else math.nan,
        "event_recall": matched / len(true_instances) if true_instances else math.nan,
        "event_latency_median_s": float(np.median(latencies)) if latencies else math.nan,
        "event_latency_p90_s": float(np.percentile(latencies, 90)) if latencies else math.nan,
        "spurious_actions": len(seen) - matched,
        "missed_actions": len(true_instances) - matched,
    }
