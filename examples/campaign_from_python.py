"""A campaign from Python: the torch and clock cell (thesis 7.5.3) with and without its safety
system, 2 seeds x 150 s each, run in this process (`workers=0`; give `workers=2` for a local Dask
cluster), then read back as a table.

    python3 examples/campaign_from_python.py [--out DIR]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from hrc_drake.campaign.engine import run_campaign  # noqa: E402
from hrc_drake.campaign.spec import make_campaign  # noqa: E402
from hrc_drake.cell.scenario import Tagged  # noqa: E402


def main(out: Path | None = None, duration: float = 150.0, seeds: int = 2):
    out = Path(out) if out else Path(tempfile.mkdtemp(prefix="hrc-campaign-"))
    document = {
        "name": "torch_clock_safety",
        "description": "torch_clock as shipped (ISO/TS 15066 PFL) against no safety system",
        "duration": duration,
        "seeds": {"count": seeds, "first": 0},
        "scenarios": [str(REPO / "diagrams" / "torch_clock.yaml")],
        "variants": {"shipped": {}, "no_safety": {"safety": Tagged("NoSafety", {})}},
        "metrics": ["products_finished", "min_human_robot_distance", "safety.violations_total"],
    }
    campaign = make_campaign(document, out / "campaign.yaml")
    outcome = run_campaign(campaign, out, workers=0, progress=None)
    table = outcome.rows[["variant", "seed", "products_finished", "min_human_robot_distance",
                          "safety.violations_total"]]
    print(table.sort_values(["variant", "seed"]).to_string(index=False))
    mean = table.groupby("variant")[["products_finished", "safety.violations_total"]].mean()
    shipped, unguarded = mean.loc["shipped"], mean.loc["no_safety"]
    print(f"Per {duration:g} s run, mean of {seeds} seed(s): as shipped "
          f"{shipped['products_finished']:.1f} products and {shipped['safety.violations_total']:.1f} "
          f"violations of ISO/TS 15066; without a safety system {unguarded['products_finished']:.1f} "
          f"products and {unguarded['safety.violations_total']:.1f} violations.")
    print(f"{outcome.ran} runs in {outcome.wall_time:.0f} s; tables and plots in {out}")
    return table


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=None, help="campaign folder (default: a temporary one)")
    main(parser.parse_args().out)
