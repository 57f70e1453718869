"""Plots of a search: the optimisation history (objective against runs, the optimiser beside
random search), Optuna's parameter importances, and the parameter values of the best and worst
candidates."""

from __future__ import annotations

import math
from pathlib import Path


def _pyplot():
    from hrc_drake.untrusted import headless_pyplot

    plt = headless_pyplot()

    return plt


def plot_history(results, search, path: Path) -> Path:
    """Each candidate's objective against the runs spent so far, and the best so far, per search."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    minimize = search.objective.direction == "minimize"
    for label, color in (("optimizer", "tab:blue"), ("random", "tab:orange")):
        part = results[results["search"] == label].sort_values("number")
        if part.empty:
            continue
        name = type(search.optimizer).__name__ if label == "optimizer" else "random"
        ok = part[part["objective"].map(lambda v: math.isfinite(v))]
        ax.scatter(
            ok["runs"], ok["objective"], s=14, color=color, alpha=0.5, marker="o", label=f"{name}: candidates"
        )
        best, xs, ys = None, [], []
        for runs, value, feasible in zip(part["runs"], part["objective"], part["feasible"], strict=True):
            if (
                feasible
                and math.isfinite(value)
                and (best is None or (value < best if minimize else value > best))
            ):
                best = value
            if best is not None:
                xs.append(runs)
                ys.append(best)
        ax.step(xs, ys, where="post", color=color, label=f"{name}: best feasible so far")
    ax.set_xlabel("runs")
    ax.set_ylabel(f"{search.objective.metric} ({search.objective.over_seeds} over seeds)")
    ax.set_title(f"{search.name}: {search.objective.direction} {search.objective.metric}", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_importances(importances: dict, search, path: Path) -> Path | None:
    """Optuna's parameter importances (fANOVA by default) as horizontal bars."""
    if not importances:
        return None
    plt = _pyplot()
    names = list(importances)[::-1]
    fig, ax = plt.subplots(figsize=(7, 0.5 + 0.35 * len(names)))
    ax.barh(names, [importances[n] for n in names], color="tab:blue")
    ax.set_xlabel("importance (Optuna, normalised)")
    ax.set_title(f"{search.name}: parameter importances for {search.objective.metric}", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_parameters(best, worst, search, path: Path) -> Path | None:
    """The numeric parameter values of the best and the worst candidates, each within its range."""
    numeric = [p for p in search.parameters if p.kind in ("float", "int")]
    if not numeric or best.empty:
        return None
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 0.6 + 0.4 * len(numeric)))
    for i, p in enumerate(numeric):
        span = (p.high - p.low) or 1.0
        for frame, color, label in ((best, "tab:green", "best"), (worst, "tab:red", "worst")):
            xs = [(float(v) - p.low) / span for v in frame[f"param.{p.name}"]]
            ax.scatter(xs, [i] * len(xs), color=color, alpha=0.6, s=24, label=label if i == 0 else None)
    ax.set_yticks(range(len(numeric)), [f"{p.name} [{p.low:g}, {p.high:g}]" for p in numeric], fontsize=8)
    ax.set_xlim(-0.05, 1.05)
    ax.set_xlabel("position in the range (0: low, 1: high)")
    ax.set_title(f"{search.name}: parameters of the best and worst candidates", fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
