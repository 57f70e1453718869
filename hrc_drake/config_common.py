"""Config types shared by several areas (the bottom layer): a rigid pose.

No `from __future__ import annotations`: pydrake's typed YAML loader reads the annotations
as real types at run time.
"""

from dataclasses import dataclass, field


@dataclass
class Pose:
    """A rigid pose: translation (m) and roll-pitch-yaw (rad), world frame unless stated."""

    xyz: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    rpy: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
