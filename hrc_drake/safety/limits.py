"""ISO/TS 15066 body regions and power-and-force-limiting speeds (Annex A).

The limits table is one cited data file, `iso_ts_15066.yaml` beside this module: per body region
the quasi-static force F and pressures p_s of Table A.2 (transient contact: `transient_factor`
times both, 0 where transient contact is not applicable), the spring constant k and effective
mass m_H of Table A.3.

Annex A.3 models a contact as the robot's and the body's effective masses meeting through the
body region's spring: the reduced mass mu = (1/m_H + 1/m_R)^-1 (eq. A.4) carries the kinetic
energy E = mu v_rel^2 / 2 into the spring, E = F^2 / (2k) (eq. A.3), so the peak force is
F = v_rel sqrt(mu k) and the permissible relative speed

    v_rel,max = F_max / sqrt(mu k)              (eq. A.6, force form)
    v_rel,max = p_max A / sqrt(mu k)            (eq. A.6, pressure form over a contact area A)

with the transient limits for a free contact and the quasi-static ones for a clamped body part.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np
import yaml

from hrc_drake.errors import ConfigError, yaml_error_reason

#: The table shipped with the package (ISO/TS 15066:2016 Tables A.2 and A.3).
LIMITS_FILE = "iso_ts_15066.yaml"
#: Fields every region of the table must give, with their plausibility ranges (units of the file).
_REGION_FIELDS = {"force": (1.0, 1000.0), "transient_factor": (0.0, 10.0), "spring_constant": (1.0, 1000.0),
                  "effective_mass": (0.01, 200.0)}
#: Body regions the simulated operator has (the body model has no legs).
BODY_REGIONS = ("skull_forehead", "face", "neck", "back_shoulders", "chest", "abdomen", "pelvis",
                "upper_arm_elbow", "lower_arm_wrist", "hand_fingers")


@dataclass(frozen=True)
class BodyRegion:
    """One body region of ISO/TS 15066 Annex A, in SI units.

    force: F, quasi-static maximum permissible force (N, Table A.2); pressure: the smallest
    maximum permissible pressure p_s of its specific areas (Pa = N/m^2, Table A.2);
    transient_factor: multiplier of both for transient contact (0: transient contact not
    permitted); spring_constant: k (N/m, Table A.3); effective_mass: m_H (kg, Table A.3).
    """

    name: str
    label: str
    force: float
    pressure: float
    transient_factor: float
    spring_constant: float
    effective_mass: float

    def force_limit(self, clamped: bool) -> float:
        """F_max (N): quasi-static when clamped, transient otherwise (0: no contact permitted)."""
        return self.force if clamped else self.transient_factor * self.force

    def pressure_limit(self, clamped: bool) -> float:
        """p_max (Pa): quasi-static when clamped, transient otherwise (0: no contact permitted)."""
        return self.pressure if clamped else self.transient_factor * self.pressure


@dataclass(frozen=True)
class LimitsTable:
    """Every body region of a limits file, by name, and where it came from."""

    regions: dict
    source: str

    def __getitem__(self, name: str) -> BodyRegion:
        try:
            return self.regions[name]
        except KeyError:
            known = sorted(self.regions)
            raise KeyError(f"unknown ISO/TS 15066 body region {name!r} (known: {known})") from None


def _number(value, where: str, low: float, high: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or not low <= value <= high:
        raise ConfigError(where, f"must be a number in [{low:g}, {high:g}], got {value!r}")
    return float(value)


def parse_limits(document, source: str = LIMITS_FILE) -> LimitsTable:
    """A `LimitsTable` from a parsed limits document; `ConfigError` naming the entry at fault."""
    if not isinstance(document, dict) or not isinstance(document.get("regions"), dict):
        raise ConfigError(source, "must be a mapping with a 'regions' mapping")
    regions = {}
    for name, entry in document["regions"].items():
        where = f"{source}: regions.{name}"
        if not isinstance(entry, dict):
            raise ConfigError(where, "must be a mapping")
        unknown = set(entry) - {*_REGION_FIELDS, "label", "areas"}
        if unknown:
            raise ConfigError(where, f"unknown keys {sorted(unknown)}")
        values = {}
        for key, (low, high) in _REGION_FIELDS.items():
            if key not in entry:
                raise ConfigError(f"{where}.{key}", "is missing")
            values[key] = _number(entry[key], f"{where}.{key}", low, high)
        areas = entry.get("areas")
        if not isinstance(areas, dict) or not areas:
            raise ConfigError(f"{where}.areas", "must map at least one specific body area to its pressure "
                                                "(N/cm^2)")
        pressures = [_number(p, f"{where}.areas.{area}", 1.0, 2000.0) for area, p in areas.items()]
        regions[name] = BodyRegion(
            name=str(name), label=str(entry.get("label", name)), force=values["force"],
            pressure=min(pressures) * 1e4, transient_factor=values["transient_factor"],
            spring_constant=values["spring_constant"] * 1e3, effective_mass=values["effective_mass"])
    missing = [r for r in BODY_REGIONS if r not in regions]
    if missing:
        raise ConfigError(f"{source}: regions", f"lacks the body regions {missing}")
    return LimitsTable(regions, str(document.get("standard", source)))


def load_limits(path: str | Path | None = None) -> LimitsTable:
    """The limits table of `path` (None: the packaged ISO/TS 15066 table), safely parsed and checked."""
    if path is None:
        text = resources.files("hrc_drake.safety").joinpath(LIMITS_FILE).read_text(encoding="utf-8")
        source = LIMITS_FILE
    else:
        path = Path(path)
        if not path.is_file():
            raise ConfigError(str(path), "no such limits file")
        try:
            text, source = path.read_text(encoding="utf-8"), str(path)
        except UnicodeDecodeError as err:
            raise ConfigError(str(path), f"not UTF-8 text (byte {err.start}): not a limits table") from None
    try:
        document = yaml.safe_load(text)
    except yaml.YAMLError as err:
        raise ConfigError(source, f"not valid YAML: {yaml_error_reason(err)}") from None
    return parse_limits(document, source)


def reduced_mass(human_mass, robot_mass):
    """mu = (1/m_H + 1/m_R)^-1 (ISO/TS 15066 eq. A.4), kg; broadcasts."""
    return 1.0 / (1.0 / human_mass + 1.0 / robot_mass)


def iso_robot_mass(moving_mass: float, payload: float = 0.0) -> float:
    """m_R = M/2 + m_L: the standard's effective robot mass from the moving parts' total mass M
    and the payload m_L (eq. A.5)."""
    return 0.5 * moving_mass + payload


def permissible_speed(region: BodyRegion, robot_mass, clamped: bool = False,
                      contact_area: float | None = None):
    """v_rel,max (m/s) of eq. (A.6): the smaller of the force form F_max / sqrt(mu k) and, with a
    contact area A (m^2), the pressure form p_max A / sqrt(mu k). 0 where no contact is permitted.
    robot_mass: m_R (kg), a number or an array."""
    stiffness = np.sqrt(reduced_mass(region.effective_mass, np.asarray(robot_mass, dtype=float))
                        * region.spring_constant)
    speed = region.force_limit(clamped) / stiffness
    if contact_area is not None:
        speed = np.minimum(speed, region.pressure_limit(clamped) * contact_area / stiffness)
    return float(speed) if np.ndim(speed) == 0 else speed


def contact_peak(region: BodyRegion, robot_mass: float, relative_speed: float,
                 contact_area: float | None = None) -> tuple[float, float, float, float]:
    """(mu, E, F, p) of a contact at `relative_speed` (m/s): reduced mass (kg), transferred energy
    E = mu v^2 / 2 (J), peak force F = v sqrt(mu k) (N, eq. A.3) and pressure F / A (Pa; nan
    without an area)."""
    mu = float(reduced_mass(region.effective_mass, robot_mass))
    v = max(float(relative_speed), 0.0)
    force = v * math.sqrt(mu * region.spring_constant)
    pressure = force / contact_area if contact_area else float("nan")
    return mu, 0.5 * mu * v * v, force, pressure


def limit_ratio(region: BodyRegion, force: float, pressure: float, clamped: bool) -> float:
    """The larger of F / F_max and p / p_max (nan pressures ignored); inf for a contact with a region
    where the contact type is not permitted at all."""
    force_limit = region.force_limit(clamped)
    if force_limit <= 0.0:
        return math.inf
    ratio = force / force_limit
    if math.isfinite(pressure):
        ratio = max(ratio, pressure / region.pressure_limit(clamped))
    return ratio
