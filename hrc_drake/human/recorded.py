"""Recorded skeleton streams as CSV: one row per camera frame (thesis Ch. 9 data format).

Header: `time`, then `<point>_x,<point>_y,<point>_z` for the 8 points of
`messages.SKELETON_POINTS` in order, then `<point>_tracked` (0/1) for the 8 points.
Coordinates may be NaN (or empty) only where the point is untracked. Times strictly increase.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from hrc_drake.messages import L_ELBOW, L_SHOULDER, L_WRIST, R_ELBOW, R_SHOULDER, R_WRIST, SKELETON_POINTS

#: metres per unit of a recording's coordinates
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
#: median segment lengths (m) a recorded adult can have: generous bounds around an adult's upper arm,
#: forearm and shoulder width of roughly 0.3, 0.25 and 0.4 m, wide enough for fitted arm models
#: (LEGO Human1's upper arm is 0.214 m); units or data that put a segment outside are refused with
#: the measured length
SEGMENT_RANGES_M = {"upper arm": (0.12, 0.55), "forearm": (0.12, 0.50), "shoulder width": (0.15, 0.70)}
#: the farthest (m, along any axis) a recorded skeleton's point may lie from the cell's origin
MAX_COORDINATE_M = 100.0

HEADER: tuple[str, ...] = (
    ("time",)
    + tuple(f"{name}_{axis}" for name in SKELETON_POINTS for axis in "xyz")
    + tuple(f"{name}_tracked" for name in SKELETON_POINTS)
)


def _number(text: str, path, line: int, column: str) -> float:
    text = text.strip()
    if text == "" or text.lower() == "nan":
        return math.nan
    try:
        return float(text)
    except ValueError:
        raise ValueError(f"{path}:{line}: column {column!r}: {text!r} is not a number") from None


def load_skeleton_csv(path):
    """Read a skeleton CSV -> times (T,), points (T, 8, 3) with NaN where untracked, tracked (T, 8) bool.

    Raises ValueError naming the file (and line) for anything it cannot read: not UTF-8, not
    CSV, a bad header, a row of the wrong length, a value that is not a number, a flag not 0/1,
    a tracked point with a NaN coordinate, time not increasing, no rows.
    """
    path = Path(path)
    try:
        return _read_skeleton_csv(path)
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: not UTF-8 text (byte {err.start}): save the file as UTF-8") from None
    except csv.Error as err:
        raise ValueError(f"{path}: not a readable CSV file: {err}") from None
    except OSError as err:
        raise ValueError(f"{path}: cannot read it: {err.strerror or err}") from None


def _read_skeleton_csv(path: Path):
    with path.open(newline="", encoding="utf-8") as handle:
        reader = csv.reader(handle)
        try:
            header = [h.strip() for h in next(reader)]
        except StopIteration:
            raise ValueError(f"{path}: empty file, expected the header {','.join(HEADER[:4])},...") from None
        if tuple(header) != HEADER:
            missing = [h for h in HEADER if h not in header]
            raise ValueError(f"{path}:1: bad header; expected {len(HEADER)} columns "
                             f"'{','.join(HEADER[:4])},...' in order (missing: {missing[:5]})")
        times, points, tracked = [], [], []
        for line, row in enumerate(reader, start=2):
            if not row or all(not cell.strip() for cell in row):
                continue
            if len(row) != len(HEADER):
                raise ValueError(f"{path}:{line}: expected {len(HEADER)} values, got {len(row)}")
            values = [_number(cell, path, line, HEADER[i]) for i, cell in enumerate(row)]
            time = values[0]
            if not math.isfinite(time):
                raise ValueError(f"{path}:{line}: time must be a finite number, got {row[0]!r}")
            if times and time <= times[-1]:
                raise ValueError(f"{path}:{line}: time {time} does not increase (previous {times[-1]})")
            frame = np.array(values[1:25], dtype=float).reshape(8, 3)
            flags = values[25:]
            for k, flag in enumerate(flags):
                if flag not in (0.0, 1.0):
                    raise ValueError(f"{path}:{line}: column {HEADER[25 + k]!r} must be 0 or 1, "
                                     f"got {row[25 + k]!r}")
            flags = np.array(flags) == 1.0
            bad = flags & ~np.all(np.isfinite(frame), axis=1)
            if bad.any():
                name = SKELETON_POINTS[int(np.argmax(bad))]
                raise ValueError(f"{path}:{line}: point {name!r} is tracked but has a NaN or inf coordinate")
            frame[~flags] = np.nan
            times.append(time)
            points.append(frame)
            tracked.append(flags)
    if not times:
        raise ValueError(f"{path}: no data rows after the header")
    times, points, tracked = np.array(times), np.array(points), np.array(tracked, dtype=bool)
    _check_plausible(path, points, tracked)
    return times, points, tracked


def _check_plausible(path: Path, points: np.ndarray, tracked: np.ndarray) -> None:
    """ValueError unless every tracked point lies within MAX_COORDINATE_M of the cell's origin and
    the arms' segments have an adult's lengths (`check_segment_lengths`)."""
    far = tracked & (np.abs(np.nan_to_num(points)).max(axis=2) > MAX_COORDINATE_M)
    if far.any():
        row, point = np.argwhere(far)[0]
        raise ValueError(f"{path}: data row {row + 1}: point {SKELETON_POINTS[point]!r} is "
                         f"{np.abs(points[row, point]).max():.4g} m from the cell's origin along an axis; "
                         f"a recorded person stays within {MAX_COORDINATE_M:g} m")
    check_segment_lengths(points, tracked, str(path))


def save_skeleton_csv(path, times, points, tracked=None) -> None:
    """Write times (T,), points (T, 8, 3), tracked (T, 8) (default: finite rows) as a skeleton CSV."""
    times = np.asarray(times, dtype=float).reshape(-1)
    points = np.asarray(points, dtype=float)
    if points.shape != (times.size, 8, 3):
        raise ValueError(f"save_skeleton_csv: points must be ({times.size}, 8, 3), got {points.shape}")
    if tracked is None:
        tracked = np.all(np.isfinite(points), axis=2)
    tracked = np.asarray(tracked, dtype=bool)
    if tracked.shape != (times.size, 8):
        raise ValueError(f"save_skeleton_csv: tracked must be ({times.size}, 8), got {tracked.shape}")
    if not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
        raise ValueError("save_skeleton_csv: times must be finite and strictly increasing")
    bad = tracked & ~np.all(np.isfinite(points), axis=2)
    if bad.any():
        row, point = np.argwhere(bad)[0]
        raise ValueError(f"save_skeleton_csv: row {row} point {SKELETON_POINTS[point]!r} is tracked "
                         "but not finite")
    with Path(path).open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(HEADER)
        for t, frame, flags in zip(times, points, tracked, strict=True):
            coords = ["nan" if not flag else repr(float(v))
                      for flag, row in zip(flags, frame, strict=True) for v in row]
            writer.writerow([repr(float(t))] + coords + [str(int(f)) for f in flags])


def frame_at(times: np.ndarray, t: float) -> int:
    """Index of the last sample with time <= t (0 before the first one)."""
    return max(int(np.searchsorted(times, t, side="right")) - 1, 0)


def _segment_pairs():
    return {"upper arm": ((L_SHOULDER, L_ELBOW), (R_SHOULDER, R_ELBOW)),
            "forearm": ((L_ELBOW, L_WRIST), (R_ELBOW, R_WRIST)),
            "shoulder width": ((L_SHOULDER, R_SHOULDER),)}


def check_segment_lengths(points, tracked, where: str, units: str = "m") -> None:
    """ValueError naming `where` unless each segment's median length (over the frames that hold
    both ends; points (T, 8, 3) m, tracked (T, 8)) lies in SEGMENT_RANGES_M: zeros, coincident
    shoulders, 1e308 values or centimetres read as metres give a person no one is."""
    for segment, pairs in _segment_pairs().items():
        low, high = SEGMENT_RANGES_M[segment]
        for a, b in pairs:
            both = tracked[:, a] & tracked[:, b]
            if not both.any():
                continue
            with np.errstate(over="ignore", invalid="ignore"):
                length = float(np.median(np.linalg.norm(points[both, a] - points[both, b], axis=1)))
            if not (math.isfinite(length) and low <= length <= high):
                # the same numbers read in another unit
                hint = next((f" (in {u}? it would be {length * UNITS[u] / UNITS[units]:.3g} m: --units {u})"
                             for u in UNITS if u != units and math.isfinite(length)
                             and low <= length * UNITS[u] / UNITS[units] <= high), "")
                raise ValueError(f"{where}: the {segment} ({SKELETON_POINTS[a]} to {SKELETON_POINTS[b]}) is "
                                 f"{length:.4g} m long in the median frame, outside an adult's {low}-{high} m"
                                 f"{hint}: not a person's recording in {units}")
