"""Typed configs of reactive safety (thesis 8.1): the human motion model, one dataclass per
kind, and the speed scaling that reads its swept volumes (a separate config).

A scenario's `motion_model` field is `NoMotionModel`, `GPMotionModel` or
`WorstCaseMotionModel`, and `speed_scaling` a `SeparationSpeedScaling`;
`motion.systems.apply_motion_config` builds both systems. The defaults are those of
`ReactiveMotionPredictor` and `SeparationRule` (thesis 8.1.3).
No pydrake here, and real annotations (pydrake's typed YAML loader reads them).
"""

from dataclasses import dataclass, field

from hrc_drake.config_common import check_number as _finite
from hrc_drake.errors import check

#: The GP models of thesis 8.1.2: A (one GP per joint), B (one GP of all joints), C (base, arms).
VARIANTS = ("A", "B", "C")
#: Angular joint groups of the body model that carry their own limits (`<group>_speed`, `<group>_accel`).
HUMAN_JOINT_GROUPS = ("shoulder", "shoulder_rotation", "elbow", "torso", "yaw")
#: Highest update rate of a Python system (DESIGN.md, performance rules).
MAX_RATE = 50.0


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
    # Human kinematic limits of [107] (8.1.1), per joint group of the body model. Speeds follow
    # ISO 13855 (scope text at standards.globalspec.com/std/1116909: upper limbs approach at
    # 2000 mm/s, a walking person at 1600 mm/s), the approach speeds ISO/TS 15066 refers to.
    # An angular limit is that 2.0 m/s at the end of the longest lever the joint moves, with
    # the default segments (upper arm 0.30 m, forearm + hand 0.37 m, torso 0.50 m, half
    # shoulder width 0.20 m). The accelerations are assumptions: no source found bounds them.
    #: Shoulder flexion and abduction speed (rad/s): 2.0 m/s over the whole arm, 0.67 m.
    shoulder_speed: float = 3.0
    #: Shoulder (humeral) rotation speed (rad/s): 2.0 m/s over the bent forearm, 0.37 m.
    shoulder_rotation_speed: float = 5.4
    #: Elbow flexion speed (rad/s): 2.0 m/s over forearm + hand, 0.37 m.
    elbow_speed: float = 5.4
    #: Torso flexion speed (rad/s): 2.0 m/s at the fingertip of a raised arm, 1.17 m from the hip.
    torso_speed: float = 1.7
    #: Base yaw speed (rad/s): 2.0 m/s at the fingertip of an outstretched arm, 0.87 m from the axis.
    yaw_speed: float = 2.3
    #: Base translation speed (m/s): ISO 13855's walking speed K = 1.6 m/s.
    base_speed: float = 1.6
    #: Shoulder flexion and abduction acceleration (rad/s^2, assumption).
    shoulder_accel: float = 15.0
    #: Shoulder rotation acceleration (rad/s^2, assumption).
    shoulder_rotation_accel: float = 15.0
    #: Elbow flexion acceleration (rad/s^2, assumption).
    elbow_accel: float = 15.0
    #: Torso flexion acceleration (rad/s^2, assumption).
    torso_accel: float = 15.0
    #: Base yaw acceleration (rad/s^2, assumption).
    yaw_accel: float = 15.0
    #: Base translation acceleration (m/s^2, assumption).
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
        # defaults.
        for name, high in (("process_std", 100.0), ("torso_process_std", 100.0), ("base_process_std", 100.0),
                           ("point_std", 1.0), ("measurement_std", 1.0), ("base_speed", 10.0),
                           ("base_accel", 50.0)):
            _finite(getattr(self, name), path, name, 0.0, high, low_open=True)
        for group in HUMAN_JOINT_GROUPS:
            _finite(getattr(self, f"{group}_speed"), path, f"{group}_speed", 0.0, 50.0, low_open=True)
            _finite(getattr(self, f"{group}_accel"), path, f"{group}_accel", 0.0, 500.0, low_open=True)
        _integer(self.levels, 2, 10, path, "levels")
        _finite(self.margin, path, "margin", 0.0, 1.0)


@dataclass
class GPMotionModel(WorstCaseMotionModel):
    """Swept volumes from Monte Carlo rollouts of a Gaussian-process motion model h_GP
    (thesis 8.1.2, eq. 8.4-8.18); the worst-case bounds of [107] are the fallback until the GP
    holds `min_samples` samples."""

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
    #: Re-optimise the kernel's hyperparameters at every k-th model refresh only, reusing them
    #: with the new training set in between: a variant (8.1.3 recomputes them at every refresh,
    #: k = 1); the sweep of `tools/bench_motion.py --sweep-hyperparameters` is in the README.
    hyperparameter_every: int = 1
    #: Clip the GP excursions to the worst-case ones of [107]: a safety option the thesis does
    #: not use (with it the GP can never be less conservative than [107] where [107] is tight).
    cap_by_worst_case: bool = False
    #: States h_GP learns and rolls out: "smoothed" (eq. 8.13, RTS-smoothed) or "filtered" (a
    #: variant, the Kalman-filtered phi_k|k; smoothed states follow the filter's integrator chain
    #: so closely that the GP's rollouts come out too narrow, see the README).
    training_states: str = "smoothed"

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
        _integer(self.hyperparameter_every, 1, 1000, path, "hyperparameter_every")
        check(self.training_states in ("smoothed", "filtered"), f"{path}.training_states",
              f"must be 'smoothed' or 'filtered', got {self.training_states!r}")
        check(isinstance(self.cap_by_worst_case, bool), f"{path}.cap_by_worst_case",
              f"must be true or false, got {self.cap_by_worst_case!r}")


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


@dataclass
class NoProactivePlanner:
    """No proactive paths: the robot keeps its nominal paths."""

    def validate(self, path: str) -> None:
        """Nothing to check."""


@dataclass
class ProactivePlanner:
    """Proactive paths of thesis 8.2 for one robot action r crossing the shared area: GPDM
    clouds of the human actions A_S weighted by P_RH, and STOMP on the cost (8.32)
    (`motion.proactive`). Defaults: 8.2.4 where it gives them."""

    #: r, a robot action of the scenario; its path is replanned (its last pose is q_N).
    robot_action: str = ""
    #: The named pose r starts from (q_0 of Q_r, eq. 8.19): the last pose of the action before it.
    start_pose: str = ""
    #: A_S, the operator's actions that cross the shared area (each moves one arm, 8.2.2).
    human_actions: list[str] = field(default_factory=list)
    #: Waypoints of the nominal and proactive paths (43 in 8.2.4).
    waypoints: int = 43
    #: T, window of P_RH, eq. (8.22) (s).
    window: float = 120.0
    #: Period of the proactive loop (s, 20 in 8.2.4).
    replan_period: float = 20.0
    #: Realisations kept per human action, FIFO (3 in 8.2.4).
    capacity: int = 3
    #: G, grid splits per side of the cloud's box (25 in 8.2.4).
    grid: int = 25
    #: Radius of the sphere of the arm's swept volumes (m, "the typical anatomical size").
    arm_radius: float = 0.06
    #: Latent dimension of the GPDMs.
    latent_dim: int = 3
    #: L-BFGS iterations of each GPDM fit.
    gpdm_iterations: int = 100
    #: lambda_1 (repulsion) and lambda_2 (deformation) of eq. (8.32); the thesis gives no values
    #: ("problem-specific"). 0.5 / 1 is the smallest ratio at which STOMP bends r_1 of
    #: box_usb_proactive.yaml at alpha = 10 (`tools/bench_proactive_sweep.py`: ratios 0.02-2).
    lambda1: float = 0.5
    lambda2: float = 1.0
    #: alpha, decay of the repulsive field of eq. (8.32) (1/m).
    alpha: float = 10.0
    #: STOMP: noisy rollouts per iteration, iterations, exploration noise (rad).
    n_rollouts: int = 8
    iterations: int = 30
    noise_std: float = 0.4
    #: Rate at which the arm points of the skeleton estimate are recorded (Hz), at most 50.
    rate: float = 10.0
    #: Cloud points with an occupancy gamma at or below this are dropped (8.2.2).
    cloud_threshold: float = 0.0
    #: Floating-point precision of the J_Rep sums, "float32" or "float64": float32 halves
    #: STOMP's time (0.8 -> 0.4 s on a replanning of box_usb_proactive.yaml) at ~1e-6 relative
    #: error of the potential; the paths of three STOMP seeds came out with the same cost to 1e-3.
    potential_precision: str = "float32"

    def validate(self, path: str) -> None:
        """Raise `ConfigError` naming `path.field` for a value the planner cannot use."""
        check(self.potential_precision in ("float32", "float64"), f"{path}.potential_precision",
              f"must be 'float32' or 'float64', got {self.potential_precision!r}")
        check(bool(self.robot_action), f"{path}.robot_action", "must name a robot action")
        check(bool(self.start_pose), f"{path}.start_pose", "must name a robot pose")
        check(len(self.human_actions) > 0 and all(isinstance(a, str) and a for a in self.human_actions),
              f"{path}.human_actions", "must list at least one operator action")
        check(len(set(self.human_actions)) == len(self.human_actions), f"{path}.human_actions",
              "lists an action twice")
        _integer(self.waypoints, 3, 1000, path, "waypoints")
        _finite(self.window, path, "window", 0.0, 1e6, low_open=True)
        _finite(self.replan_period, path, "replan_period", 0.0, 1e6, low_open=True)
        _integer(self.capacity, 1, 100, path, "capacity")
        _integer(self.grid, 2, 100, path, "grid")
        _finite(self.arm_radius, path, "arm_radius", 0.0, 0.5, low_open=True)
        _integer(self.latent_dim, 1, 9, path, "latent_dim")
        _integer(self.gpdm_iterations, 1, 10000, path, "gpdm_iterations")
        for name in ("lambda1", "lambda2"):
            _finite(getattr(self, name), path, name, 0.0, 1e6)
        _finite(self.alpha, path, "alpha", 0.0, 1e4, low_open=True)
        _integer(self.n_rollouts, 1, 1000, path, "n_rollouts")
        _integer(self.iterations, 1, 10000, path, "iterations")
        _finite(self.noise_std, path, "noise_std", 0.0, 10.0, low_open=True)
        _finite(self.rate, path, "rate", 0.0, MAX_RATE, low_open=True)
        _finite(self.cloud_threshold, path, "cloud_threshold", 0.0, 1.0)


#: Every proactive-planner kind a scenario can choose.
ProactivePlannerConfig = NoProactivePlanner | ProactivePlanner

#: Every motion-model kind a scenario can choose.
MotionModelConfig = NoMotionModel | GPMotionModel | WorstCaseMotionModel
