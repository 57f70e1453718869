"""Typed configs of the skeleton tracker, one dataclass per kind (thesis 9.1).

A scenario's `tracker` field is one of `NoTracker`, `HoldLastSeenTracker`, `ParticleFilterTracker`,
`KalmanTracker`;
`perception.systems.apply_tracker_config` builds the system. The defaults reproduce the
tracker of `diagrams/pcb_occlusion.yaml` (the thesis' settings of 9.1.3).
No pydrake here, and real annotations (pydrake's typed YAML loader reads them).
"""

import math
from dataclasses import dataclass

from hrc_drake.errors import check


def _positive(value, path: str, name: str) -> None:
    check(math.isfinite(value) and value > 0, f"{path}.{name}", f"must be a finite number > 0, got {value!r}")


def _non_negative(value, path: str, name: str) -> None:
    check(math.isfinite(value) and value >= 0, f"{path}.{name}",
          f"must be a finite number >= 0, got {value!r}")


def _int_in(value, low: int, high: int, path: str, name: str) -> None:
    check(isinstance(value, int) and not isinstance(value, bool) and low <= value <= high,
          f"{path}.{name}", f"must be an integer in [{low}, {high}], got {value!r}")


def _slow_down(config, path: str) -> None:
    check(math.isfinite(config.slow_down_threshold) and 0.0 < config.slow_down_threshold <= 1.0,
          f"{path}.slow_down_threshold", f"must be in (0, 1], got {config.slow_down_threshold!r}")
    check(math.isfinite(config.slow_factor) and 0.0 <= config.slow_factor <= 1.0,
          f"{path}.slow_factor", f"must be in [0, 1], got {config.slow_factor!r}")


def _chain(config, path: str) -> None:
    _int_in(config.order, 1, 4, path, "order")
    for name in ("sigma_position", "sigma_velocity", "sigma_acceleration", "sigma_jerk",
                 "initial_velocity_std", "initial_acceleration_std", "initial_jerk_std"):
        _non_negative(getattr(config, name), path, name)
    _positive(config.measurement_std, path, "measurement_std")
    check(config.measurement_std < 1.0, f"{path}.measurement_std",
          f"must be below 1 m (a camera's noise), got {config.measurement_std!r}")
    _int_in(config.display_particles, 1, 10000, path, "display_particles")


@dataclass
class NoTracker:
    """No tracker: the estimate is the last measurement; a lost point keeps its last seen
    position (DESIGN.md "a missing one has a plain default")."""

    def validate(self, path: str) -> None:
        """Nothing to check."""


@dataclass
class HoldLastSeenTracker:
    """The hold-last-seen baseline of the tracker comparison (thesis 9.1.3, Fig. 9.7): a lost
    point stays where it was last seen, as with `NoTracker`, but the estimate also drives the
    slow-down rule of 9.1.3 (a held point inside the robot workspace box counts as belief 1
    there, outside as 0), so its cycle times compare with the filters' on equal terms.
    `NoTracker` drives no slow-down rule at all."""

    #: Slow-down rule of 9.1.3: the robot slows when some point has at least this fraction of
    #: its belief (0 or 1 for a held point) inside the robot workspace box.
    slow_down_threshold: float = 0.1
    #: Speed override while the slow-down rule holds (fraction of the nominal speed).
    slow_factor: float = 0.3

    def validate(self, path: str) -> None:
        """Raise `ConfigError` naming `path.field` for a value the rule cannot use."""
        _slow_down(self, path)


@dataclass
class ParticleFilterTracker:
    """The occlusion-aware particle filter of thesis 9.1.2 (`SkeletonParticleFilter`), one
    particle set per skeletal point, and the slow-down rule of 9.1.3."""

    #: N, particles per skeletal point (thesis 9.1.3: 500).
    particles: int = 500
    #: Blocks of the chain of integrators, eq. (9.2): 4 = position .. jerk.
    order: int = 4
    #: Process standard deviation of the position block, eq. (9.3) (m).
    sigma_position: float = 0.1
    #: Process standard deviation of the velocity block, eq. (9.3) (m/s).
    sigma_velocity: float = 0.2
    #: Process standard deviation of the acceleration block, eq. (9.3) (m/s^2).
    sigma_acceleration: float = 1.0
    #: Process standard deviation of the jerk block, eq. (9.3) (m/s^3).
    sigma_jerk: float = 5.0
    #: Standard deviation of the measured positions, R = measurement_std^2 I of eq. (9.8) (m).
    measurement_std: float = 0.01
    #: Half amplitude theta of the spherical crowns of the admissible regions, eq. (9.13) (m).
    crown: float = 0.05
    #: Systematic resampling instead of the thesis' bootstrap (multinomial) resampling.
    systematic: bool = False
    #: The literal thesis: seen points by the bootstrap PF, weights eq. (9.8); False samples
    #: seen points from their exact Kalman posterior (our default, see particle_filter.py).
    bootstrap_tracked: bool = False
    #: A variant (not the thesis): a newly hidden point's particles keep only their positions,
    #: with velocity .. jerk 0, instead of the full posterior (particle_filter.py, issue 37).
    hidden_at_rest: bool = False
    #: Frames with both ends seen used to calibrate each segment length.
    calibration_frames: int = 10
    #: Re-acquisition gate: a seen point farther than gate * measurement_std from its whole
    #: cloud is re-seeded around the measurement (measurement std units).
    gate: float = 6.0
    #: Standard deviation of the velocity of a new track (m/s).
    initial_velocity_std: float = 0.2
    #: Standard deviation of the acceleration of a new track (m/s^2).
    initial_acceleration_std: float = 1.0
    #: Standard deviation of the jerk of a new track (m/s^3).
    initial_jerk_std: float = 5.0
    #: Particles per point copied into the estimate (for display).
    display_particles: int = 50
    #: Slow-down rule of 9.1.3: the robot slows when some point has at least this fraction of
    #: its belief (particles) inside the robot workspace box.
    slow_down_threshold: float = 0.1
    #: Speed override while the slow-down rule holds (fraction of the nominal speed).
    slow_factor: float = 0.3

    def validate(self, path: str) -> None:
        """Raise `ConfigError` naming `path.field` for a value the filter cannot use."""
        _int_in(self.particles, 2, 100000, path, "particles")
        _chain(self, path)
        _non_negative(self.crown, path, "crown")
        _int_in(self.calibration_frames, 1, 10000, path, "calibration_frames")
        _positive(self.gate, path, "gate")
        _slow_down(self, path)


@dataclass
class KalmanTracker:
    """The per-point Kalman baseline of thesis 9.1.3 (open loop under occlusion), its 90 %
    confidence ellipsoid as the belief volume of the slow-down rule."""

    #: Blocks of the chain of integrators, eq. (9.2): 4 = position .. jerk.
    order: int = 4
    #: Process standard deviation of the position block, eq. (9.3) (m).
    sigma_position: float = 0.1
    #: Process standard deviation of the velocity block, eq. (9.3) (m/s).
    sigma_velocity: float = 0.2
    #: Process standard deviation of the acceleration block, eq. (9.3) (m/s^2).
    sigma_acceleration: float = 1.0
    #: Process standard deviation of the jerk block, eq. (9.3) (m/s^3).
    sigma_jerk: float = 5.0
    #: Standard deviation of the measured positions, E = measurement_std^2 I of eq. (9.4) (m).
    measurement_std: float = 0.01
    #: Standard deviation of the velocity of a new track (m/s).
    initial_velocity_std: float = 0.2
    #: Standard deviation of the acceleration of a new track (m/s^2).
    initial_acceleration_std: float = 1.0
    #: Standard deviation of the jerk of a new track (m/s^3).
    initial_jerk_std: float = 5.0
    #: Confidence of the ellipsoid of each point (9.1.3: 0.9), in (0, 1).
    confidence: float = 0.9
    #: Fixed samples of each point's confidence ellipsoid copied into the estimate (display).
    display_particles: int = 50
    #: Slow-down rule of 9.1.3: the robot slows when some point has at least this fraction of
    #: its confidence ellipsoid inside the robot workspace box (or the box inside it).
    slow_down_threshold: float = 0.1
    #: Speed override while the slow-down rule holds (fraction of the nominal speed).
    slow_factor: float = 0.3

    def validate(self, path: str) -> None:
        """Raise `ConfigError` naming `path.field` for a value the filter cannot use."""
        _chain(self, path)
        check(math.isfinite(self.confidence) and 0.0 < self.confidence < 1.0, f"{path}.confidence",
              f"must be in (0, 1), got {self.confidence!r}")
        _slow_down(self, path)


#: Every tracker kind a scenario can choose.
TrackerConfig = NoTracker | HoldLastSeenTracker | ParticleFilterTracker | KalmanTracker
