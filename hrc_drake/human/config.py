"""Configs of the human model: anthropometrics, the synthetic operator and its actions,
the depth camera and the occluders that hide points from it.

No `from __future__ import annotations`: pydrake's typed YAML loader reads the annotations
as real types at run time.
"""

import math
from dataclasses import dataclass, field
from typing import Union

from hrc_drake.config_common import Pose
from hrc_drake.distributions import Distribution, validate_distribution
from hrc_drake.errors import check

#: the hip heights (m) a `Segments.hip_height` may set: a low stool to a tall person standing
HIP_HEIGHT_RANGE = (0.3, 1.5)


@dataclass
class Segments:
    """Operator anthropometrics (m)."""

    torso: float = 0.50
    neck: float = 0.25
    shoulder_width: float = 0.40
    upper_arm: float = 0.30
    forearm: float = 0.27
    #: the hip's height above the floor (m): 0 stands (the height follows the stature, `BodyModel`);
    #: a value in [0.3, 1.5] m sets it, e.g. a person seated at a table (`human.calibration`)
    hip_height: float = 0.0


@dataclass
class OperatorAction:
    """A human action: the hand(s) reach the goals in order, taking `duration` in total (the
    action's one time: a flow action's `duration` is only a timed scheduler's prior).

    hand: left | right | both.
    """

    name: str = ""
    goals: list[str] = field(default_factory=list)
    hand: str = "right"
    duration: Distribution = field(default_factory=Distribution)
    #: the goal sphere G_a whose entry by a hand marks this action for an action detector
    #: (thesis Ch. 2); "" means the action's first goal, which must then be a goal sphere
    region: str = ""


@dataclass
class IdealBehaviour:
    """The ideal operator: the head turns exactly to the goal `operator.HEAD_LEAD` = 0.3 s before
    the hand moves (thesis 3.1.2), no glances, pauses, mistakes or motion noise, every person
    equally fast. The shipped cells and the README's figures are runs of this behaviour."""

    def validate(self, path: str) -> None:
        """Nothing to check."""


@dataclass
class RealisticBehaviour:
    """A less ideal operator (`human.behaviour`): the eyes lead the hand by a random time, glance
    at other goals and at the robot, gaze and hands wobble smoothly, reaches pause or start
    towards a wrong goal, and each person has a speed of their own. Figures marked "assumption"
    come from no study; the others are cited."""

    #: Time by which the gaze leads the hand's movement onset towards each goal (s). Land, Mennie
    #: & Rusted 1999 (Perception 28:1311): the first fixation on an object led the first sign of
    #: its manipulation by 0.56 s on average; Land & Hayhoe 2001 (Vision Res. 41:3559): the eyes
    #: usually reach the next object before any sign of manipulation. The spread (0.2 s) is an
    #: assumption.
    eye_hand_lead: Distribution = field(
        default_factory=lambda: Distribution("lognormal", mean=0.56, std=0.2))
    #: Glances away from the task per second of gaze on it (1/s): the gaze fixates another goal or
    #: the robot, then returns. Assumption: Land et al. 1999 found very few fixations irrelevant
    #: to the task at hand; a robot moving next to the operator draws some.
    glance_rate: float = 0.3
    #: Fixation time of a glance (s): Rayner 1998 (Psychol. Bull. 124:372) reports mean
    #: fixations of about 330 ms in scene perception; the spread (0.1 s) is an assumption.
    glance_duration: Distribution = field(
        default_factory=lambda: Distribution("lognormal", mean=0.33, std=0.1))
    #: Share of the glances that go to the robot, the rest to other goals (assumption).
    glance_at_robot: float = 0.5
    #: Standard deviation of the smooth gaze wobble, per head angle (rad; assumption, ~2 deg).
    gaze_noise_std: float = 0.035
    #: Correlation time of the gaze wobble (s; assumption).
    gaze_noise_time: float = 0.4
    #: Standard deviation of the smooth wrist wobble, per coordinate (m; assumption, the order of
    #: the end-point scatter of repeated reaches).
    hand_noise_std: float = 0.01
    #: Correlation time of the wrist wobble (s; assumption).
    hand_noise_time: float = 0.3
    #: Probability that a reach pauses half-way (assumption).
    hesitation_probability: float = 0.1
    #: How long a hesitation holds the hand still (s; assumption).
    hesitation_duration: Distribution = field(
        default_factory=lambda: Distribution("lognormal", mean=0.4, std=0.15))
    #: Probability that a reach starts towards another goal of the layout, then turns back to the
    #: right one (assumption).
    abort_probability: float = 0.05
    #: Share of the way to the wrong goal covered before turning back (assumption).
    abort_fraction: float = 0.4
    #: Standard deviation of the person's speed factor (normal around 1, drawn once per
    #: operator), which divides the reach times (assumption: persons differ by ~15 %).
    speed_std: float = 0.15

    def validate(self, path: str) -> None:
        """Raise `ConfigError` naming the field of a value the operator cannot use."""
        for name in ("eye_hand_lead", "glance_duration", "hesitation_duration"):
            validate_distribution(getattr(self, name), f"{path}.{name}", positive=True)
        for name, high in (("glance_rate", 10.0), ("gaze_noise_std", 0.5), ("hand_noise_std", 0.1),
                           ("speed_std", 0.5)):
            value = getattr(self, name)
            check(math.isfinite(value) and 0.0 <= value <= high, f"{path}.{name}",
                  f"must be a number in [0, {high:g}], got {value!r}")
        for name in ("gaze_noise_time", "hand_noise_time"):
            value = getattr(self, name)
            check(math.isfinite(value) and 0.01 <= value <= 60.0, f"{path}.{name}",
                  f"must be a time in [0.01, 60] s, got {value!r}")
        for name in ("glance_at_robot", "hesitation_probability", "abort_probability"):
            value = getattr(self, name)
            check(math.isfinite(value) and 0.0 <= value <= 1.0, f"{path}.{name}",
                  f"must be a probability in [0, 1], got {value!r}")
        check(math.isfinite(self.abort_fraction) and 0.0 < self.abort_fraction < 1.0,
              f"{path}.abort_fraction", f"must be in (0, 1), got {self.abort_fraction!r}")


#: How the synthetic operator behaves, chosen by tag (`behaviour: !RealisticBehaviour {}`).
OperatorBehaviour = Union[IdealBehaviour, RealisticBehaviour]  # noqa: UP007 (the YAML loader needs it)


@dataclass
class Operator:
    """The simulated operator, or a recorded skeleton file (CSV) to replay."""

    name: str = "human"
    segments: Segments = field(default_factory=Segments)
    base: Pose = field(default_factory=lambda: Pose(xyz=[1.05, 0.0, 0.0], rpy=[0.0, 0.0, 3.14159]))
    pattern: list[str] = field(default_factory=list)
    actions: list[OperatorAction] = field(default_factory=list)
    #: optional CSV of recorded skeleton frames (time + 8x3 points + 8 flags), relative to the scenario
    recorded: str = ""
    #: how the synthetic operator moves and looks: ideal (default) or realistic
    behaviour: OperatorBehaviour = field(default_factory=IdealBehaviour)


@dataclass
class Occluder:
    """A box that hides what is behind it from the camera."""

    name: str = ""
    center: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    size: list[float] = field(default_factory=lambda: [0.1, 0.1, 0.1])


@dataclass
class AnalyticDepthCamera:
    """The analytic camera (the fast default): sight lines against the occluder boxes and the
    robot's capsules, in a 60 deg view cone (`human.camera.DepthCameraModel`, thesis Ch. 9)."""

    def validate(self, path: str) -> None:
        """Nothing to check."""


@dataclass
class RenderedDepthCamera:
    """A depth image rendered by Drake (`RgbdSensor`, `RenderEngineVtk`) of the whole scene: robot,
    human body capsules, table, buffers, occluders (`human.camera.RenderedCameraModel`, thesis
    Ch. 9: a point is untracked where the depth map is in front of it, and L_c1 of eq. (9.10)
    reads the same depth map). Defaults: the Kinect v2 (the thesis' sensor, 9.1.3), whose depth
    camera is 512 x 424 pixels, 70.6 x 60 deg field of view, 0.5-4.5 m range (Microsoft Kinect
    for Windows v2 specifications; Fankhauser et al., "Kinect v2 for mobile robot navigation:
    evaluation and modeling", ICAR 2015). The default resolution is half of it on each axis,
    the same field of view: 7 mm per pixel at the operator's 1.3 m, and ~1 ms less per frame
    (tools/bench_tracking.py `render_ms_per_frame`).
    """

    #: image width (pixels); the Kinect v2 has 512
    width: int = 256
    #: image height (pixels); the Kinect v2 has 424
    height: int = 212
    #: horizontal field of view (deg), Kinect v2: 70.6
    fov_x: float = 70.6
    #: vertical field of view (deg), Kinect v2: 60
    fov_y: float = 60.0
    #: nearest measured depth (m), Kinect v2: 0.5; nearer surfaces give no depth and hide what
    #: is behind them
    min_depth: float = 0.5
    #: farthest measured depth (m), Kinect v2: 4.5; a point beyond it is untracked
    max_depth: float = 4.5
    #: a point is hidden where the depth image is in front of it by more than this plus the
    #: radius of its own body capsule (the skeletal points lie inside the body) (m)
    depth_tolerance: float = 0.03
    #: the jitter of a tracked point is camera.noise_std at 1 m depth times (z / 1 m) to this
    #: power. ASSUMPTION: quadratic, as the axial noise of depth cameras (Khoshelham and Oude
    #: Elberink 2012 for the Kinect v1; Fankhauser et al. 2015 measure a Kinect v2 axial noise
    #: growing with depth, 1-4 mm over 1-3 m, below a skeleton tracker's centimetre jitter)
    jitter_exponent: float = 2.0
    #: probability per frame that a point the depth image hides stays "tracked", measured on
    #: the surface in front of it (the back-projected depth of a pixel near its own): the wrong
    #: surface a skeleton tracker jumps to. ASSUMPTION: no published rate for this cell
    wrong_surface_probability: float = 0.05
    #: the wrong surface is the depth of a pixel at most this many pixels from the point's own
    wrong_surface_pixels: int = 3

    def validate(self, path: str) -> None:
        """Each field in its plausible range (`ConfigError` naming the field)."""
        for name, high in (("width", 2048), ("height", 2048), ("wrong_surface_pixels", 64)):
            value = getattr(self, name)
            low = 0 if name == "wrong_surface_pixels" else 8
            check(isinstance(value, int) and not isinstance(value, bool) and low <= value <= high,
                  f"{path}.{name}", f"must be an integer in [{low}, {high}], got {value!r}")
        for name in ("fov_x", "fov_y"):
            value = getattr(self, name)
            check(math.isfinite(value) and 1.0 <= value <= 170.0, f"{path}.{name}",
                  f"must be in [1, 170] deg, got {value!r}")
        check(math.isfinite(self.min_depth) and 0.01 <= self.min_depth <= 10.0, f"{path}.min_depth",
              f"must be in [0.01, 10] m, got {self.min_depth!r}")
        check(math.isfinite(self.max_depth) and self.min_depth < self.max_depth <= 20.0, f"{path}.max_depth",
              f"must be in (min_depth = {self.min_depth:g}, 20] m, got {self.max_depth!r}")
        check(math.isfinite(self.depth_tolerance) and 0.0 <= self.depth_tolerance <= 0.5,
              f"{path}.depth_tolerance", f"must be in [0, 0.5] m, got {self.depth_tolerance!r}")
        check(math.isfinite(self.jitter_exponent) and 0.0 <= self.jitter_exponent <= 4.0,
              f"{path}.jitter_exponent", f"must be in [0, 4], got {self.jitter_exponent!r}")
        check(math.isfinite(self.wrong_surface_probability) and 0.0 <= self.wrong_surface_probability <= 1.0,
              f"{path}.wrong_surface_probability",
              f"must be a probability in [0, 1], got {self.wrong_surface_probability!r}")


#: The camera's measurement model, chosen by tag (`sensor: !RenderedDepthCamera {}`).
DepthSensor = Union[AnalyticDepthCamera, RenderedDepthCamera]  # noqa: UP007 (the YAML loader needs it)


@dataclass
class Camera:
    """The depth camera that tracks the skeleton."""

    position: list[float] = field(default_factory=lambda: [1.6, 0.0, 1.6])
    target: list[float] = field(default_factory=lambda: [0.0, 0.0, 1.0])
    rate: float = 30.0
    #: measurement noise per coordinate (m); with a rendered sensor, the jitter at 1 m depth
    noise_std: float = 0.01
    #: points whose line of sight passes within this distance of an occluder are lost
    margin: float = 0.0
    #: the gaze flag F is invalid when the face turns more than this from the camera (rad)
    gaze_valid_angle: float = 1.2
    #: how depth is measured: the analytic sight-line test (default) or a rendered depth image
    sensor: DepthSensor = field(default_factory=AnalyticDepthCamera)
