"""The ISO/TS 15066 table and the PFL speeds of eq. (A.6), against hand computation."""

from __future__ import annotations

import math

import pytest
import yaml

from hrc_drake.errors import ConfigError
from hrc_drake.safety.limits import (
    BODY_REGIONS,
    contact_peak,
    iso_robot_mass,
    limit_ratio,
    load_limits,
    parse_limits,
    permissible_speed,
    reduced_mass,
)


@pytest.fixture(scope="module")
def table():
    return load_limits()


def test_the_packaged_table_holds_the_published_values(table):
    # ISO/TS 15066:2016 Table A.2 (F quasi-static, smallest p_s) and Table A.3 (k, m_H)
    expected = {"hand_fingers": (140, 190, 75, 0.6), "lower_arm_wrist": (160, 180, 40, 2.0),
                "upper_arm_elbow": (150, 190, 30, 3.0), "chest": (140, 120, 25, 40.0),
                "abdomen": (110, 140, 10, 40.0), "face": (65, 110, 75, 4.4), "neck": (150, 140, 50, 1.2),
                "skull_forehead": (130, 110, 150, 4.4), "back_shoulders": (210, 160, 35, 40.0),
                "pelvis": (180, 210, 25, 40.0)}
    for name, (force, pressure, k, mass) in expected.items():
        region = table[name]
        assert region.force == force
        assert region.pressure == pytest.approx(pressure * 1e4)
        assert region.spring_constant == pytest.approx(k * 1e3)
        assert region.effective_mass == mass
    assert table["face"].transient_factor == 0 and table["skull_forehead"].transient_factor == 0
    assert table["hand_fingers"].transient_factor == 2


@pytest.mark.parametrize("name, m_h, k, force", [
    ("hand_fingers", 0.6, 75e3, 140.0), ("lower_arm_wrist", 2.0, 40e3, 160.0), ("chest", 40.0, 25e3, 140.0)])
def test_pfl_speeds_for_a_3_kg_robot_match_hand_computation(table, name, m_h, k, force):
    mu = 1.0 / (1.0 / m_h + 1.0 / 3.0)
    assert permissible_speed(table[name], 3.0) == pytest.approx(2 * force / math.sqrt(mu * k))
    assert permissible_speed(table[name], 3.0, clamped=True) == pytest.approx(force / math.sqrt(mu * k))


def test_worked_numbers(table):
    # hand: mu = (1/0.6 + 1/3)^-1 = 0.5 kg; sqrt(0.5 * 75000) = 193.65; 280 N / 193.65 = 1.446 m/s
    assert reduced_mass(0.6, 3.0) == pytest.approx(0.5)
    assert permissible_speed(table["hand_fingers"], 3.0) == pytest.approx(1.4459, abs=1e-4)
    assert permissible_speed(table["hand_fingers"], 3.0, clamped=True) == pytest.approx(0.7230, abs=1e-4)
    # chest with a 1 cm^2 contact: the sternum's 2 x 120 N/cm^2 = 240 N binds before 280 N
    assert permissible_speed(table["chest"], 3.0, contact_area=1e-4) == pytest.approx(
        240.0 / math.sqrt(reduced_mass(40.0, 3.0) * 25e3))
    # the face takes no transient contact
    assert permissible_speed(table["face"], 3.0) == 0.0
    assert iso_robot_mass(10.0, 1.0) == 6.0


def test_contact_peak_and_ratio(table):
    hand = table["hand_fingers"]
    mu, energy, force, pressure = contact_peak(hand, 3.0, 1.0, contact_area=2e-4)
    assert mu == pytest.approx(0.5)
    assert energy == pytest.approx(0.25)
    assert force == pytest.approx(math.sqrt(0.5 * 75e3))
    assert pressure == pytest.approx(force / 2e-4)
    # F = E form: E = F^2 / (2k)
    assert energy == pytest.approx(force**2 / (2 * hand.spring_constant))
    assert limit_ratio(hand, force, math.nan, clamped=False) == pytest.approx(force / 280.0)
    assert limit_ratio(hand, force, math.nan, clamped=True) == pytest.approx(force / 140.0)
    assert limit_ratio(table["face"], 1.0, math.nan, clamped=False) == math.inf


def _document():
    from importlib import resources

    return yaml.safe_load(resources.files("hrc_drake.safety").joinpath("iso_ts_15066.yaml").read_text())


@pytest.mark.parametrize("edit, field", [
    (lambda d: d["regions"]["hand_fingers"].pop("force"), "regions.hand_fingers.force"),
    (lambda d: d["regions"]["chest"].__setitem__("effective_mass", -3), "regions.chest.effective_mass"),
    (lambda d: d["regions"]["neck"]["areas"].__setitem__("neck_muscle", "soft"),
     "regions.neck.areas.neck_muscle"),
    (lambda d: d["regions"].pop("face"), "regions"),
    (lambda d: d["regions"]["face"].__setitem__("colour", 1), "regions.face"),
])
def test_a_bad_table_is_refused_naming_the_entry(edit, field):
    document = _document()
    edit(document)
    with pytest.raises(ConfigError) as err:
        parse_limits(document, "limits.yaml")
    assert field in str(err.value)


def test_every_body_region_is_in_the_table(table):
    assert set(BODY_REGIONS) <= set(table.regions)
