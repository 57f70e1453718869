"""The safety report of a run (one PNG): the judge's clearance against S_p of the pairs SSM governs,
every violation on the time axis, and the worst ratio to the ISO/TS 15066 limit per body region."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

#: a colour per body region (matplotlib's tab10 order)
REGION_COLOURS = {
    "hand_fingers": "tab:red",
    "lower_arm_wrist": "tab:orange",
    "upper_arm_elbow": "tab:olive",
    "chest": "tab:purple",
    "abdomen": "tab:pink",
    "neck": "tab:brown",
    "face": "black",
    "skull_forehead": "black",
    "back_shoulders": "tab:cyan",
    "pelvis": "tab:gray",
}
#: a colour per kind of violation (`safety.judge.VIOLATION_KINDS`)
KIND_COLOURS = {
    "ssm_breach": "tab:orange",
    "ssm_contact": "tab:red",
    "pfl_contact": "tab:purple",
    "stop": "tab:brown",
}


def plot_safety(path: str | Path, trace, episodes, summary: dict, title: str = "") -> Path:
    """Write the report: `trace` [(t, min clearance, clearance and S_p of the SSM pair nearest its
    S_p, in breach)] of the judge, `episodes` (its `Violation`s and logged contacts), `summary`
    (metrics.json's `safety`)."""
    from hrc_drake.untrusted import headless_pyplot

    plt = headless_pyplot()

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(11, 7), gridspec_kw={"height_ratios": [2, 1]})
    if trace:
        rows = np.array([row[:4] for row in trace], dtype=float)
        t = rows[:, 0]
        top.plot(
            t,
            np.where(np.isfinite(rows[:, 1]), rows[:, 1], np.nan),
            color="tab:blue",
            lw=0.8,
            label="min clearance robot - body (truth)",
        )
        top.plot(t, rows[:, 2], color="tab:cyan", lw=0.6, label="clearance of the SSM pair nearest its S_p")
        top.plot(
            t,
            rows[:, 3],
            color="tab:green",
            lw=0.8,
            label="its S_p (ISO 13855 speeds, the robot's real stop)",
        )
    top.axhline(0.0, color="black", lw=0.6)
    violations = [e for e in episodes if e.violation]
    for kind, colour in KIND_COLOURS.items():
        chosen = [e for e in violations if e.kind == kind]
        for e in chosen:
            top.axvspan(e.onset, e.onset + max(e.duration, 0.05), color=colour, alpha=0.25, lw=0)
        if chosen:
            top.plot([], [], color=colour, lw=6, alpha=0.4, label=f"violation: {kind} ({len(chosen)})")
    touched = [e for e in episodes if e.kind in ("contact", "ssm_contact", "pfl_contact")]
    for region in sorted({c.region for c in touched}):
        chosen = [c for c in touched if c.region == region]
        top.scatter(
            [c.onset for c in chosen],
            [0.0] * len(chosen),
            s=[40 if c.violation else 14 for c in chosen],
            marker="x",
            color=REGION_COLOURS.get(region, "tab:gray"),
            label=f"contact: {region} ({len(chosen)})",
            zorder=3,
        )
    top.set_xlabel("time (s)")
    top.set_ylabel("m")
    top.set_ylim(bottom=-0.05)
    top.legend(loc="upper right", fontsize=7, ncol=2)
    top.set_title(f"{title}\n{_wrapped(summary.get('verdict', ''))}", fontsize=8)
    worst = summary.get("worst_ratio", {})
    names = sorted({c.region for c in touched})
    values = [worst.get(n, 0.0) if worst.get(n, 0.0) is not None else math.inf for n in names]
    shown = [v if math.isfinite(v) else 0.0 for v in values]
    bars = bottom.bar(names, shown, color=[REGION_COLOURS.get(n, "tab:gray") for n in names])
    for bar, value in zip(bars, values, strict=True):
        label = "no contact permitted" if not math.isfinite(value) else f"{value:.2f}"
        bottom.annotate(
            label, (bar.get_x() + bar.get_width() / 2, bar.get_height()), ha="center", va="bottom", fontsize=8
        )
    bottom.axhline(1.0, color="tab:red", ls="--", lw=1.0, label="the region's limit (ratio 1)")
    bottom.set_ylabel("worst ratio to the limit")
    bottom.set_ylim(0.0, max([1.2, *(v * 1.15 for v in shown)]))
    if not names:
        bottom.text(0.5, 0.5, "no contact", ha="center", va="center", transform=bottom.transAxes)
    bottom.legend(loc="upper right", fontsize=7)
    bottom.tick_params(axis="x", labelsize=8)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _wrapped(text: str, width: int = 140) -> str:
    import textwrap

    return "\n".join(textwrap.wrap(str(text), width)) or ""
