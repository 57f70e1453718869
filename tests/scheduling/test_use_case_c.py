"""Use case c (thesis 7.5.3) as shipped: the torch_clock net without a resource for the robots'
shared area (the thesis's footnote 7), and the campaign that measures what the thesis measures."""

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pydrake")

from hrc_drake.campaign.spec import load_campaign  # noqa: E402
from hrc_drake.cell.scenario import load_scenario  # noqa: E402
from hrc_drake.scheduling.compiler import net_from_scenario  # noqa: E402
from hrc_drake.scheduling.config import FuzzyScheduler  # noqa: E402

from .test_fuzzy_scheduler import _torch_clock_net  # noqa: E402

DIAGRAMS = Path(__file__).resolve().parents[2] / "diagrams"


def test_torch_clock_models_no_resource_for_the_shared_area():
    scenario = load_scenario(DIAGRAMS / "torch_clock.yaml")
    assert scenario.flow.resources == {} and all(not a.resources for a in scenario.flow.actions)
    net = net_from_scenario(scenario, FuzzyScheduler(wait_quantum=5.0))
    # R2 and L3 may run at once in the net (no place holds them apart)
    m = net.m0.copy()
    for name in ("batteries", "station_A", "glass_frame", "dial_hands"):
        m[net.place_index[f"buf:{name}"]] += 1
        m[net.place_index[f"space:{name}"]] -= 1
    m = net.fire(m, "R2:begin")
    assert net.enabled(m)[net.transition_index["L3:begin"]]
    # the fuzzy tests' Drake-free copy of the flow is the shipped one
    core = _torch_clock_net()
    assert core.transitions == net.transitions and core.places == net.places
    assert np.array_equal(core.pre, net.pre) and np.array_equal(core.post, net.post)


def test_the_shipped_campaign_runs_experiment_b_with_per_product_samples():
    """The bench (tools/bench_use_case_c.py) runs this file: 10 products need 900 s, and the
    thesis's samples are per product (Fig. 7.27)."""
    campaign = load_campaign(DIAGRAMS / "campaigns" / "use_case_c_schedulers.yaml")
    assert campaign.duration >= 900 and "per_product" in campaign.extra_metrics
    assert {"fuzzy", "uniform"} <= set(campaign.variants)
    for arm in ("fuzzy", "uniform"):
        assert campaign.variants[arm]["scheduler"]["horizon"] == 50.0
        assert campaign.variants[arm]["scheduler"]["wait_quantum"] == 5.0
