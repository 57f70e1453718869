"""Config types shared by several areas (the bottom layer): a rigid pose, the run-length bound.

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
