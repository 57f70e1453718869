"""The safety report of a run: separation against S_p over time, contacts by body region, and the
worst ratio to the ISO/TS 15066 limit per region (one PNG)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

#: a colour per body region (matplotlib's tab10 order)
REGION_COLOURS = {"hand_fingers": "tab:red", "lower_arm_wrist": "tab:orange", "upper_arm_elbow": "tab:olive",
                  "chest": "tab:purple", "abdomen": "tab:pink", "neck": "tab:brown", "face": "black",
                  "skull_forehead": "black", "back_shoulders": "tab:cyan", "pelvis": "tab:gray"}


def plot_safety(path: str | Path, trace, contacts, summary: dict, title: str = "") -> Path:
    """Write the report: `trace` [(t, min clearance, S_p of that pair, rule)], `contacts` (the
    monitor's `Contact`s), `summary` (metrics.json's `safety`)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(11, 7), gridspec_kw={"height_ratios": [2, 1]})
    if trace:
        t = np.array([row[0] for row in trace], dtype=float)
        distance = np.array([row[1] for row in trace], dtype=float)
        separation = np.array([row[2] for row in trace], dtype=float)
        ssm = np.array([row[3] == "ssm" for row in trace])
        top.plot(t, np.where(np.isfinite(distance), distance, np.nan), color="tab:blue", lw=0.8,
                 label="min clearance robot - body (truth)")
        top.plot(t, np.where(ssm, separation, np.nan), color="tab:green", lw=0.8,
                 label="S_p of that pair (SSM, robot's true approach speed)")
        top.plot(t, np.where(~ssm, separation, np.nan), color="tab:green", lw=0.8, ls=":",
                 label="S_p of that pair (PFL: contact allowed within its speed)")
    top.axhline(0.0, color="black", lw=0.6)
    for region in sorted({c.region for c in contacts}):
        chosen = [c for c in contacts if c.region == region]
        top.scatter([c.time for c in chosen], [-c.penetration for c in chosen], s=[40 if c.violation else 14
                    for c in chosen], marker="x", color=REGION_COLOURS.get(region, "tab:gray"),
                    label=f"contact: {region} ({len(chosen)})", zorder=3)
    top.set_xlabel("time (s)")
    top.set_ylabel("m")
    top.set_ylim(bottom=min(-0.05, *(-c.penetration for c in contacts)) if contacts else -0.05)
    top.legend(loc="upper right", fontsize=7, ncol=2)
    top.set_title(f"{title}\n{summary.get('verdict', '')}", fontsize=9)
    worst = summary.get("worst_ratio", {})
    names = sorted({c.region for c in contacts})  # the regions touched
    values = [worst.get(n, 0.0) if worst.get(n, 0.0) is not None else math.inf for n in names]
    shown = [v if math.isfinite(v) else 0.0 for v in values]
    bars = bottom.bar(names, shown, color=[REGION_COLOURS.get(n, "tab:gray") for n in names])
    for bar, value in zip(bars, values, strict=True):
        label = "no contact permitted" if not math.isfinite(value) else f"{value:.2f}"
        bottom.annotate(label, (bar.get_x() + bar.get_width() / 2, bar.get_height()), ha="center",
                        va="bottom", fontsize=8)
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
