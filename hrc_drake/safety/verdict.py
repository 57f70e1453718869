"""The safety verdict of a run in figures and in one line (metrics.json's `safety`).

`verdict_code` is one of `VERDICT_CODES`: `non_conforming` where the judge was changed or the
controller's S_h does not come from ISO 13855's speeds (a declared departure), else
`no_safety_system` for a cell without one, else `unsafe` with any violation, else `safe`.
The line counts every violation of the standard judge (`safety.judge`) and names the time a
body part went unmeasured; a non-conforming run gives the changed judge's count beside it.
"""

from __future__ import annotations

import math
from collections import Counter

from hrc_drake.safety.judge import LIMB_FAST_SPEED, VIOLATION_KINDS, Judge, JudgeRun, Violation
from hrc_drake.safety.limits import BODY_REGIONS

VERDICT_CODES = ("safe", "unsafe", "no_safety_system", "non_conforming")


def judged_figures(judge: Judge, run: JudgeRun) -> dict:
    """The figures of one judge's run: violations by kind, their episodes, SSM breach time, stops,
    margins, contacts, the time a body part went unmeasured."""
    episodes, stops = judge.finish(run)
    violations = [e for e in episodes if e.violation]
    counts = Counter(e.kind for e in violations)
    contacts = [e for e in episodes if e.kind in ("contact", "ssm_contact", "pfl_contact")]
    worst: dict = {}
    for c in contacts:
        worst[c.region] = max(worst.get(c.region, 0.0), c.worst)
    finite = [v for v in worst.values() if math.isfinite(v)]
    period = judge.sample_period(run)
    stop_ratios = [s.ratio(period) for s in stops]
    return {
        "violations_total": len(violations),
        "violations": {kind: counts.get(kind, 0) for kind in VIOLATION_KINDS},
        "ssm_breach_s": round(judge.breach_seconds(run), 3),
        # the deepest unexcused breach (null: none); margin_m below counts excused ones too
        "violation_margin_m": min((round(e.worst, 4) for e in violations if e.kind == "ssm_breach"),
                                  default=None),
        "margin_m": None if not math.isfinite(run.margin) else round(run.margin, 4),
        # the time contacts over their limits lasted (each violation's whole contact)
        "contact_violation_s": round(sum(e.duration for e in violations if e.kind == "pfl_contact"), 3),
        "contact_margin": round(1.0 - max(finite, default=0.0), 4),
        "worst_ratio": {
            name: (None if not math.isfinite(worst.get(name, 0.0)) else round(worst.get(name, 0.0), 4))
            for name in BODY_REGIONS
        },
        "contact_count": len(contacts),
        "stops_measured": len(stop_ratios),
        "stop_ratio_worst": round(max(stop_ratios, default=0.0), 4),
        "unobserved_s": round(run.unobserved_time, 3),
        "unobserved_longest_s": round(run.longest_unobserved, 3),
        "reach_growth_m": round(LIMB_FAST_SPEED * run.longest_unobserved, 3),
        "closest_approach_m": None if not math.isfinite(run.min_clearance) else round(run.min_clearance, 4),
        "events": [e.as_dict() for e in violations],
        "contacts": [c.as_dict() for c in contacts],
    }


def summarize(
    judge: Judge,
    run: JudgeRun,
    *,
    mode: str,
    duration: float,
    protective_stops: int = 0,
    departures: tuple[str, ...] = (),
    own: tuple[Judge, JudgeRun] | None = None,
) -> dict:
    """metrics.json's `safety`: the standard judge's figures, the verdict code and line.

    mode: the declared mode (none, ssm, pfl, hybrid); duration: the time judged (s); departures:
    every way the run's judge or controller departs from the standard (non-conforming); own: the
    changed judge (the scenario's `judge:` block, or the controller's own model) and its run."""
    figures = judged_figures(judge, run)
    if departures:
        code = "non_conforming"
    elif mode == "none":
        code = "no_safety_system"
    else:
        code = "unsafe" if figures["violations_total"] else "safe"
    own_figures = None
    if own is not None:
        own_figures = judged_figures(*own)
        own_figures.pop("contacts")
    return {
        "mode": mode,
        "standard": judge.values.limits.source,
        "verdict_code": code,
        "verdict": verdict_line(code, mode, figures, duration, departures, own_figures),
        **figures,
        "protective_stops": int(protective_stops),
        "judge": {
            "conforming": not departures,
            "deviations": list(departures),
            "reaction_time_s": judge.values.reaction_time,
            "deceleration_m_s2": judge.values.deceleration,
            # the cell's risk assessment the judge applies: where PFL may govern hands and arms
            "pfl_regions": sorted(judge.mode.pfl_regions),
            "collaborative_zones": [
                {"center": [round(float(c), 4) for c in center], "radius": round(float(radius), 4)}
                for center, radius in zip(judge.mode.zone_centers, judge.mode.zone_radii, strict=True)],
        },
        "own_model": own_figures,
    }


def violations_text(figures: dict) -> str:
    """'3 violations (2 SSM breaches 0.4 s, 1 contact 1.6x the hand_fingers's quasi-static limit)'."""
    total = figures["violations_total"]
    if not total:
        return "0 violations"
    counts = figures["violations"]
    events = figures["events"]
    parts = []
    if counts["ssm_breach"]:
        n = counts["ssm_breach"]
        parts.append(f"{_plural(n, 'SSM breach', 'SSM breaches')} {_seconds(figures['ssm_breach_s'])}")
    if counts["ssm_contact"]:
        regions = sorted({e["region"] for e in events if e["kind"] == "ssm_contact"})
        parts.append(
            f"{_plural(counts['ssm_contact'], 'touch', 'touches')} where SSM governs ({', '.join(regions)})"
        )
    if counts["pfl_contact"]:
        worst = max(
            (e for e in events if e["kind"] == "pfl_contact"),
            key=lambda e: math.inf if e["worst"] == "inf" else e["worst"],
        )
        parts.append(
            f"{_plural(counts['pfl_contact'], 'contact', 'contacts')} over the limit, worst "
            f"{worst['region']} {worst['detail']}"
        )
    if counts["stop"]:
        parts.append(
            f"{_plural(counts['stop'], 'stop', 'stops')} longer than S_p assumed "
            f"(worst {figures['stop_ratio_worst']:.3f}x)"
        )
    return f"{_plural(total, 'violation', 'violations')} ({', '.join(parts)})"


def _safe_contacts_text(figures: dict) -> str:
    """The contacts of a safe run in words: a closest approach below 0 m is a contact, so the line
    says each was judged; those over a limit (or where none is permitted) were logged, not held
    against the robot: the person moved into a robot that was not approaching."""
    n = figures["contact_count"]
    # a ratio is a number, or null / "inf" where no contact is permitted (`judge._round`)
    logged = sum(1 for c in figures.get("contacts", ())
                 if not (isinstance(c.get("worst"), (int, float)) and c["worst"] <= 1.0))
    if not logged:
        each = "each " if n > 1 else ""
        return f"{_plural(n, 'contact', 'contacts')}, {each}within its body region's limit"
    return (f"{_plural(n, 'contact', 'contacts')}: {n - logged} within their body regions' limits, "
            f"{logged} over a limit but logged, not held against the robot (the person moved into a "
            f"robot that was not approaching)")


def verdict_line(code: str, mode: str, figures: dict, duration: float, departures=(), own=None) -> str:
    """The verdict in one line a person reads once, e.g. `SAFE: ISO/TS 15066 hybrid, conforming
    judge, 0 violations in 300 s` or `UNSAFE: ISO/TS 15066 ssm, conforming judge: 2 violations in
    300 s (...)`; every violation counted, a safe run's contacts (all within their limits) counted,
    and the time a body part went unmeasured named."""
    span = f"in {_seconds(duration)}"
    counted = violations_text(figures)
    if code == "non_conforming":
        line = (f"NON-CONFORMING: ISO/TS 15066 {mode}, {'; '.join(departures)}; by the standard's judge "
                f"{counted} {span}")
        if own is not None:
            line += f"; by its own model {violations_text(own)}"
    elif code == "no_safety_system":
        line = (
            f"NO SAFETY SYSTEM: ISO/TS 15066 not applied; judged as power and force limiting the standard "
            f"counts {counted} {span}"
        )
    elif code == "safe":
        line = f"SAFE: ISO/TS 15066 {mode}, conforming judge, 0 violations {span}"
        if figures.get("contact_count", 0) > 0:
            line += "; " + _safe_contacts_text(figures)
    else:
        line = f"UNSAFE: ISO/TS 15066 {mode}, conforming judge: {counted} {span}"
    if figures["unobserved_s"] > 0:
        line += (
            f"; a body part unmeasured {figures['unobserved_s']:.1f} s "
            f"(longest {figures['unobserved_longest_s']:.1f} s: "
            f"its reachable set grew {figures['reach_growth_m']:.2f} m)"
        )
    return line


def _seconds(value: float) -> str:
    """A time in words: whole seconds from 10 s, else to the hundredth (a 1/30 s breach is not 0 s)."""
    return f"{value:.0f} s" if value >= 10 else f"{value:.2f} s"


def _plural(n: int, one: str, many: str) -> str:
    return f"{n} {one if n == 1 else many}"


__all__ = ["VERDICT_CODES", "Violation", "judged_figures", "summarize", "verdict_line", "violations_text"]
