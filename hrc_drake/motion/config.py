"""Typed configs of reactive safety (thesis 8.1): the human motion model, one dataclass per
kind, and the speed scaling that reads its swept volumes (a separate config).

A scenario's `motion_model` field is `NoMotionModel`, `GPMotionModel` or
`WorstCaseMotionModel`, and `speed_scaling` a `SeparationSpeedScaling`;
`motion.systems.apply_motion_config` builds both systems. The defaults are those of
`ReactiveMotionPredictor` and `SeparationRule` (thesis 8.1.3).
No pydrake here, and real annotations (pydrake's typed YAML loader reads them).
"""

import math
from dataclasses import dataclass

from hrc_drake.errors import check

#: The GP models of thesis 8.1.2: A (one GP per joint), B (one GP of all joints), C (base, arms).
VARIANTS = ("A", "B", "C")
#: Highest update rate of a Python system (DESIGN.md, performance rules).
MAX_RATE = 50.0


def _finite(value, path, name, low=None, high=None, low_open=False):
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if ok and low is not None:
        ok = value > low if low_open else value >= low
    if ok and high is not None:
        ok = value <= high
    if not ok:
        lo = "-inf" if low is None else f"{low:g}"
        hi = "inf" if high is None else f"{high:g}"
        check(False, f"{path}.{name}", f"must be a finite number in {'(' if low_open else '['}{lo}, {hi}], "
              f"got {value!r}")


def _integer(value, low, high, path, name):
    check(isinstance(value, int) and not isinstance(value, bool) and low <= value <= high,
          f"{path}.{name}", f"must be an integer in [{low}, {high}], got {value!r}")


@dataclass
class NoMotionModel:
    """No human motion model: no swept volumes, no speed scaling."""

    def validate(self, path: str) -> None:
        """Nothing to check."""


@dataclass
class WorstCaseMotionModel:
    """Swept volumes from the worst-case reachable excursions of [107]: bounded joint velocity
    and acceleration, eq. (8.1), from the Kalman-filtered joint state (8.3)."""

    #: Update rate of the predictor (Hz), at most 50.
    rate: float = 20.0
    #: Prediction time covered by the swept volumes (s); rounded to whole periods.
    horizon: float = 0.5
    #: Jerk density sigma of the arm joints in the KF of eq. (8.3) (rad/s^3).
    process_std: float = 3.0
    #: Jerk density of base yaw and torso flexion (rad/s^3).
    torso_process_std: float = 1.0
    #: Jerk density of the base translation (m/s^3).
    base_process_std: float = 0.5
    #: Noise of the skeletal points (m), turned into per-joint IK noise through the Jacobian.
    point_std: float = 0.01
    #: Joint noise assumed when none is given (rad or m).
    measurement_std: float = 0.05
    #: Joint speed limit of [107] (rad/s).
    joint_speed: float = 3.0
    #: Joint acceleration limit of [107] (rad/s^2).
    joint_accel: float = 15.0
    #: Base translation speed limit (m/s).
    base_speed: float = 1.6
    #: Base translation acceleration limit (m/s^2).
    base_accel: float = 3.0
    #: Grid values per rotation when sampling the joint box of a swept volume (>= 2).
    levels: int = 3
    #: Extra radius added to every swept-volume capsule (m).
    margin: float = 0.0

    def validate(self, path: str) -> None:
        """Raise `ConfigError` naming `path.field` for a value the predictor cannot use."""
        _finite(self.rate, path, "rate", 0.0, MAX_RATE, low_open=True)
        _finite(self.horizon, path, "horizon", 0.0, 10.0, low_open=True)
        # Plausibility ranges: a human's joints, base and noise, loose by ten or more around the
        # defaults (thesis 8.1.3 measures joint speeds of ~3 rad/s and a walking base of ~1.6 m/s).
        for name, high in (("process_std", 100.0), ("torso_process_std", 100.0), ("base_process_std", 100.0),
                           ("point_std", 1.0), ("measurement_std", 1.0), ("joint_speed", 30.0),
                           ("joint_accel", 300.0), ("base_speed", 10.0), ("base_accel", 50.0)):
            _finite(getattr(self, name), path, name, 0.0, high, low_open=True)
        _integer(self.levels, 2, 10, path, "levels")
        _finite(self.margin, path, "margin", 0.0, 1.0)


@dataclass
class GPMotionModel(WorstCaseMotionModel):
    """Swept volumes from Monte Carlo rollouts of a Gaussian-process motion model h_GP
    (thesis 8.1.2, eq. 8.4-8.18), capped by the worst-case bounds of [107] (also the fallback
    until the GP holds `min_samples` samples)."""

    #: The model of 8.1.2: "A" (one GP per joint, eq. 8.11-8.13), "B" (one GP of all joints,
    #: eq. 8.14) or "C" (base, left arm, right arm, eq. 8.15-8.18).
    variant: str = "C"
    #: P, past states a GP prediction looks at (eq. 8.4).
    order: int = 4
    #: T, Monte Carlo trials of eq. (8.8).
    n_trials: int = 50
    #: Percentile (0-100) of the excursions over the trials (Fig. 8.3); negative: their mean,
    #: eq. (8.9)-(8.10).
    percentile: float = -1.0
    #: Period of the GP model refresh (s, 0.5 in 8.1.3).
    refresh_period: float = 0.5
    #: Size of the GP training set (100 in 8.1.3).
    max_samples: int = 100
    #: Length of the RTS-smoothed window, eq. (8.6) (steps).
    smoothing_window: int = 20
    #: Training samples the GP needs before it replaces the worst-case bounds.
    min_samples: int = 30
    #: L-BFGS iterations per hyperparameter refit of the kernel (8.7).
    max_iter: int = 15

    def validate(self, path: str) -> None:
        """Raise `ConfigError` naming `path.field` for a value the predictor cannot use."""
        super().validate(path)
        check(self.variant in VARIANTS, f"{path}.variant", f"must be one of {VARIANTS}, got {self.variant!r}")
        _integer(self.order, 1, 10, path, "order")
        _integer(self.n_trials, 1, 10000, path, "n_trials")
        _finite(self.percentile, path, "percentile", None, 100.0)
        _finite(self.refresh_period, path, "refresh_period", 0.0, 60.0, low_open=True)
        _integer(self.max_samples, 2, 2000, path, "max_samples")
        _integer(self.smoothing_window, 2, 10000, path, "smoothing_window")
        _integer(self.min_samples, 2, self.max_samples, path, "min_samples")
        _integer(self.max_iter, 0, 1000, path, "max_iter")


@dataclass
class SeparationSpeedScaling:
    """Speed override of the robot from its clearance to the human swept volumes: the speed and
    separation rule S_p(s) of thesis 8.1.3 (ISO/TS 15066), see `motion.speed`."""

    #: C, minimum clearance kept between robot and swept volumes (m).
    clearance: float = 0.1
    #: T_r, reaction time: sensing + one controller period (s).
    reaction_time: float = 0.1
    #: T_s, stopping time of the robot (s).
    stopping_time: float = 0.3
    #: v_r, robot speed toward the operator at override 1 (m/s).
    robot_speed: float = 1.0
    #: v_h, human speed not already covered by the swept volumes (m/s).
    human_speed: float = 0.0
    #: Update rate of the speed scaler (Hz), at most 50.
    rate: float = 20.0
    #: How far ahead along the path (s at full speed) the robot capsules give the approach speed.
    lookahead: float = 0.1

    def validate(self, path: str) -> None:
        """Raise `ConfigError` naming `path.field` for a value the rule cannot use."""
        for name in ("clearance", "reaction_time", "stopping_time", "human_speed"):
            _finite(getattr(self, name), path, name, 0.0, 100.0)
        _finite(self.robot_speed, path, "robot_speed", 0.0, 100.0, low_open=True)
        check(self.reaction_time + self.stopping_time > 0, f"{path}.stopping_time",
              "reaction_time + stopping_time must be > 0")
        _finite(self.rate, path, "rate", 0.0, MAX_RATE, low_open=True)
        _finite(self.lookahead, path, "lookahead", 0.0, 10.0, low_open=True)


#: Every motion-model kind a scenario can choose.
MotionModelConfig = NoMotionModel | GPMotionModel | WorstCaseMotionModel
