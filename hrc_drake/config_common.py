"""Config types and bounds shared by several areas (the bottom layer): a rigid pose, the run-length
bound, the replay frame budget.

No `from __future__ import annotations`: pydrake's typed YAML loader reads the annotations
as real types at run time.
"""

import math
from dataclasses import dataclass, field

from hrc_drake.errors import check

#: The longest simulated run a scenario or the command line may ask for (s): a week.
MAX_SIMULATED_DURATION = 7 * 24 * 3600.0

# Plausibility ranges of a scenario's physical quantities (README "Scenario checks"). A value
# outside is a typo or a unit slip (mm for m, ms for s), refused with its range; each bound
# is loose by a factor of ten or more around any real assembly cell.
#: |coordinate| of any position in the cell (m): a cell fits in a 40 m box around the origin
MAX_CELL_COORDINATE = 20.0
#: a size of the table, an occluder or the robot workspace (m)
MAX_OBJECT_SIZE = 10.0
#: the radius of a goal region (m)
MAX_GOAL_RADIUS = 2.0
#: |angle| of a roll, pitch or yaw (rad): one turn
MAX_ANGLE = 2 * 3.141592653589793
#: any parameter of an action's duration (mean, std, bounds, samples) and a robot's dwell (s)
MAX_ACTION_DURATION = 3600.0
#: a segment of the operator's body (m): torso, neck, shoulder width, upper arm, forearm
MAX_SEGMENT_LENGTH = 1.0
#: the depth camera's noise standard deviation (m): beyond it the camera sees nothing
MAX_CAMERA_NOISE = 0.5
#: parts in a buffer (capacity or initial) and units of a shared resource
MAX_PARTS = 10_000
#: one part's mass (kg): the heaviest payload of a collaborative robot's arm is well below it
MAX_PART_MASS = 100.0
#: the time step of a dynamic plant (s): below 0.5 ms a cell runs slower than real time
MIN_TIME_STEP, MAX_TIME_STEP = 5e-4, 0.05
#: the minimum human-robot distance a cell must keep, for reports (m)
MAX_SAFETY_DISTANCE = 2.0


@dataclass
class Pose:
    """A rigid pose: translation (m) and roll-pitch-yaw (rad), world frame unless stated."""

    xyz: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    rpy: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])


#: Default replay budget: 10 minutes at 10 frames per second. Meshcat keeps every recorded
#: frame in memory (~40 kB each) and writes ~3-6 kB per frame of HTML, so 6,000 frames keep a
#: 2 h replay under 50 MB and its run's memory that of a 10 min run.
REPLAY_MAX_FRAMES = 6000


def replay_fps_within(fps: float, duration: float, max_frames: int = REPLAY_MAX_FRAMES) -> float:
    """The replay rate: `fps`, lowered so that `duration` s records about `max_frames` frames at most."""
    if not (fps > 0 and duration > 0 and max_frames >= 1):
        raise ValueError(f"need fps > 0, duration > 0 and max_frames >= 1, got {fps}, {duration}, "
                         f"{max_frames}")
    return min(fps, max_frames / duration)


def check_number(value, path, name, low=None, high=None, low_open=False):
    """Raise `ConfigError` naming `path.name` unless `value` is a finite number in [low, high]
    ((low, high] with `low_open`; None: unbounded)."""
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
