"""Config types and bounds shared by several areas (the bottom layer): a rigid pose, the run-length
bound, the replay frame budget.

No `from __future__ import annotations`: pydrake's typed YAML loader reads the annotations
as real types at run time.
"""

from dataclasses import dataclass, field

#: The longest simulated run a scenario or the command line may ask for (s): a week.
MAX_SIMULATED_DURATION = 7 * 24 * 3600.0


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
