"""Real recordings of people as skeleton streams of the thesis's 8 points (Fig. 9.1): a generic
joint-position table and the shipped sets (`datasets`) read into a `Recording`, the points a set
lacks synthesised (and named), the recording placed in a cell and resampled to a camera rate.

Never invented: a point a frame does not hold stays NaN and untracked; resampling interpolates
a point only between two frames that both hold it (a gap stays a gap).
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from hrc_drake.human.recorded import SEGMENT_RANGES_M, UNITS, check_segment_lengths  # noqa: F401
from hrc_drake.messages import (
    HEAD,
    L_ELBOW,
    L_SHOULDER,
    L_WRIST,
    R_ELBOW,
    R_SHOULDER,
    R_WRIST,
    SKELETON_POINTS,
    THORAX,
)

#: metres per unit of a recording's coordinates
#: the largest recording file read (bytes): the shipped ones are under 1 MB, and parsing text costs
#: several times its size in memory (a 200 MB file took 3 GB): larger ones are refused unread
MAX_RECORDING_BYTES = 32 * 1024 * 1024
#: the most frames a resampled recording holds (an hour at 60 Hz, ~0.3 GB while resampling)
MAX_RESAMPLED_FRAMES = 216_000
#: where the operator may be placed: within this distance (m) of the cell's origin
MAX_PLACEMENT_M = 20.0
#: the table top's height range (m)
TABLE_HEIGHT_RANGE_M = (0.3, 1.5)


@dataclass(frozen=True)
class Recording:
    """A real recording as skeleton points: times (T,) s from 0, points (T, 8, 3) m (NaN where a
    frame does not hold the point), tracked (T, 8); `synthesized`: points built from others
    (`synthesize_missing`), `up`: the recording frame's up direction (unit); `fixed`: points the
    source holds constant for the whole recording (kept for placing it, never measurements to
    score against, `flag_stuck_points`)."""

    times: np.ndarray
    points: np.ndarray
    tracked: np.ndarray
    rate: float
    source: str = ""
    synthesized: tuple[str, ...] = ()
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    notes: tuple[str, ...] = field(default_factory=tuple)
    fixed: tuple[str, ...] = ()

    @property
    def frames(self) -> int:
        return len(self.times)


#: a point closer than this to the origin in every frame, or moving less than this over the
#: whole recording, is stuck (m): no sensor holds a real joint that still (`flag_stuck_points`)
STUCK_TOLERANCE = 1e-6


def flag_stuck_points(recording: Recording) -> Recording:
    """A point at the origin in every frame it holds is no measurement: it becomes untracked. A
    point constant over the whole recording (two or more frames) is one the source holds fixed:
    it stays (a recording is placed by its shoulders) and is named in `fixed`, so that nothing
    scores against it. Each case is named in `notes`."""
    points, tracked = recording.points.copy(), recording.tracked.copy()
    notes, fixed = list(recording.notes), list(recording.fixed)
    for k, name in enumerate(SKELETON_POINTS):
        held = points[tracked[:, k], k]
        if len(held) == 0:
            continue
        where = f"{name.replace('_', ' ')}"
        if np.all(np.linalg.norm(held, axis=1) < STUCK_TOLERANCE):
            tracked[:, k] = False
            points[:, k] = np.nan
            notes.append(f"{where} at the origin in all {len(held)} frames: untracked")
        elif len(held) > 1 and np.all(np.ptp(held, axis=0) < STUCK_TOLERANCE) and name not in fixed:
            fixed.append(name)
            notes.append(f"{where} constant over all {len(held)} frames: held fixed by the source, "
                         "not scored")
    return replace(recording, points=points, tracked=tracked, notes=tuple(notes), fixed=tuple(fixed))


def _recording(points: np.ndarray, rate: float, source: str, up, notes=()) -> Recording:
    points = np.asarray(points, dtype=float)
    tracked = np.all(np.isfinite(points), axis=2)
    points = np.where(tracked[..., None], points, np.nan)
    times = np.arange(len(points)) / rate
    up = tuple(float(u) for u in up)
    return flag_stuck_points(Recording(times, points, tracked, float(rate), source, (), up, tuple(notes)))


def _check_rate(rate: float, where: str) -> float:
    if not (isinstance(rate, (int, float)) and math.isfinite(rate) and 0.1 <= rate <= 10_000):
        raise ValueError(f"{where}: the frame rate must be a number of Hz in [0.1, 10000], got {rate!r}")
    return float(rate)


def read_joint_table(path, columns: dict, units: str = "m", rate: float = 30.0, delimiter: str | None = None,
                     header_rows: int = 0, up=(0.0, 0.0, 1.0)) -> Recording:
    """A table of joint positions, one frame per row: `columns` maps skeleton point names
    (`messages.SKELETON_POINTS`) to their (x, y, z) column indices (0-based); `units` m, cm or
    mm; `delimiter` None for whitespace, else e.g. ","; the first `header_rows` rows are skipped.
    Empty or NaN cells leave the point untracked in that frame. ValueError naming the file, line
    and column for anything else."""
    path = Path(path)
    rate = _check_rate(rate, str(path))
    if units not in UNITS:
        raise ValueError(f"{path}: units must be one of {sorted(UNITS)}, got {units!r}")
    unknown = [name for name in columns if name not in SKELETON_POINTS]
    if unknown:
        raise ValueError(f"{path}: unknown skeleton point(s) {unknown}; known: {list(SKELETON_POINTS)}")
    for name, cols in columns.items():
        if len(cols) != 3 or not all(isinstance(c, int) and not isinstance(c, bool) and c >= 0 for c in cols):
            raise ValueError(f"{path}: columns of {name!r} must be 3 column indices >= 0, got {cols!r}")
    rows = _table_rows(path, delimiter, header_rows)
    needed = 1 + max(c for cols in columns.values() for c in cols)
    points = np.full((len(rows), 8, 3), np.nan)
    index = {name: k for k, name in enumerate(SKELETON_POINTS)}
    for n, (line, cells) in enumerate(rows):
        if len(cells) < needed:
            raise ValueError(f"{path}:{line}: {len(cells)} columns, the mapping reads column {needed - 1}")
        for name, cols in columns.items():
            points[n, index[name]] = [_cell(cells[c], path, line, c) for c in cols]
    scale = UNITS[units]
    return _recording(points * scale, rate, str(path), up)


def _table_rows(path: Path, delimiter, header_rows: int) -> list[tuple[int, list[str]]]:
    one_character = isinstance(delimiter, str) and len(delimiter) == 1
    if delimiter is not None and not (delimiter == "\t" or one_character and delimiter.isprintable()
                                      and delimiter != '"'):
        raise ValueError(f"{path}: the delimiter must be one printable character other than a quote, or "
                         f"a tab; got {delimiter!r}")
    if isinstance(header_rows, bool) or not isinstance(header_rows, int) or header_rows < 0:
        raise ValueError(f"{path}: header rows must be a whole number >= 0, got {header_rows!r}")
    check_recording_size(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: not UTF-8 text (byte {err.start})") from None
    except OSError as err:
        raise ValueError(f"{path}: cannot read it: {err.strerror or err}") from None
    lines = text.splitlines()[header_rows:]
    if delimiter is None:
        rows = [(k, line.split()) for k, line in enumerate(lines, start=header_rows + 1)]
    else:
        rows = list(zip(range(header_rows + 1, header_rows + 1 + len(lines)),
                        csv.reader(lines, delimiter=delimiter), strict=True))
    rows = [(k, cells) for k, cells in rows if any(c.strip() for c in cells)]
    if not rows:
        raise ValueError(f"{path}: no frames")
    return rows


def _cell(text: str, path, line: int, column: int) -> float:
    text = text.strip()
    if not text or text.lower() == "nan":
        return math.nan
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{path}:{line}: column {column}: {text!r} is not a number") from None
    return value if math.isfinite(value) else math.nan


#: the LEGO assembly arm keypoints (`data/lego_assembly_arm`): 18 columns, metres, camera frame
#: (x right, y down, z depth)
LEGO_COLUMNS = {"left_wrist": (0, 1, 2), "right_wrist": (3, 4, 5), "left_elbow": (6, 7, 8),
                "right_elbow": (9, 10, 11), "left_shoulder": (12, 13, 14), "right_shoulder": (15, 16, 17)}


def read_lego(path, rate: float) -> Recording:
    """One LEGO trial (`Task*/Human*/trial*.txt`). The source does not state its frame rate
    (4.5 mm per frame median wrist motion: 15-30 Hz); `rate` must be given."""
    recording = read_joint_table(path, LEGO_COLUMNS, "m", rate, None, 0, up=(0.0, -1.0, 0.0))
    return replace(recording, notes=(f"frame rate not stated by the source: {rate:g} Hz assumed",
                                     *recording.notes))


#: KTH hand-over segments (`data/real/kth_handover`) whose origins stand for our points: the upper
#: arm's origin is the shoulder joint, the forearm's the elbow, the hand's the wrist
KTH_SEGMENTS = {"head": "head", "left_shoulder": "LUArm", "right_shoulder": "RUArm", "left_elbow": "LFArm",
                "right_elbow": "RFArm", "left_wrist": "LHand", "right_wrist": "RHand"}
KTH_RATE = 120.0


def read_kth(folder, person: str = "giver") -> Recording:
    """The giver's or taker's upper body of the KTH hand-over: one `<person>_<segment>_pose_saved.csv`
    per segment (header x,y,z,q0..q3, metres, z up, 120 Hz); the segment origins as points."""
    folder = Path(folder)
    if person not in ("giver", "taker"):
        raise ValueError(f"{folder}: person must be 'giver' or 'taker', got {person!r}")
    series = {}
    for name, segment in KTH_SEGMENTS.items():
        path = folder / f"{person}_{segment}_pose_saved.csv"
        if not path.is_file():
            raise ValueError(f"{folder}: no {path.name} (the {name} of the {person})")
        series[name] = read_joint_table(path, {name: (0, 1, 2)}, "m", KTH_RATE, ",", header_rows=1)
    lengths = {len(r.times) for r in series.values()}
    if len(lengths) != 1:
        raise ValueError(f"{folder}: the {person}'s segment files hold different frame counts "
                         f"{sorted(lengths)}")
    index = {name: k for k, name in enumerate(SKELETON_POINTS)}
    points = np.full((lengths.pop(), 8, 3), np.nan)
    for name, recording in series.items():
        points[:, index[name]] = recording.points[:, index[name]]
    return _recording(points, KTH_RATE, f"{folder} ({person})", (0.0, 0.0, 1.0))


def read_vicon_trajectories(path) -> tuple[float, list[str], np.ndarray]:
    """The "Trajectories" section of a Vicon Nexus CSV export: (rate Hz, marker names without the
    subject prefix, positions (T, M, 3) in metres, NaN where a marker was not seen)."""
    path = Path(path)
    rows = [r for _, r in _table_rows(path, ",", 0)]
    if len(rows) < 5 or rows[0][0].strip() != "Trajectories":
        raise ValueError(f"{path}: not a Vicon Nexus export (its first line is not 'Trajectories')")
    try:
        rate = _check_rate(float(rows[1][0]), str(path))
    except ValueError:
        raise ValueError(f"{path}:2: the frame rate {rows[1][0]!r} is not a number of Hz") from None
    names = [cell.split(":")[-1].strip() for cell in rows[2][2::3]]
    names = [n for n in names if n]
    units = {u.strip() for u in rows[4][2:2 + 3 * len(names)]}
    if units - {"mm", ""} or "mm" not in units:
        raise ValueError(f"{path}:5: the trajectories must be in mm, got units {sorted(units)}")
    data = []
    for line, cells in enumerate(rows[5:], start=6):
        if not cells[0].strip().isdigit():
            break  # the next section of the export
        values = [_cell(c, path, line, k + 2) for k, c in enumerate(cells[2:2 + 3 * len(names)])]
        values += [math.nan] * (3 * len(names) - len(values))
        data.append(values)
    if not data:
        raise ValueError(f"{path}: no frames")
    return rate, names, np.array(data).reshape(len(data), len(names), 3) * UNITS["mm"]


def rigid_fit(reference, current) -> tuple[np.ndarray, np.ndarray] | None:
    """(R, t) with current ~ R @ reference + t by least squares (Kabsch) over the markers both
    hold (M, 3) each; None with fewer than 3."""
    both = np.all(np.isfinite(reference), axis=1) & np.all(np.isfinite(current), axis=1)
    if both.sum() < 3:
        return None
    a, b = reference[both], current[both]
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    rotation = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return rotation, cb - rotation @ ca


#: UE ADL (`data/real/ue_adl`): each joint centre from static-trial landmarks and the cluster that
#: carries them: the shoulder at the greater tubercle with the acromion cluster (the joint centre
#: stays with the scapula), the elbow between the epicondyles with the upper arm's, the wrist
#: between the styloid processes with the forearm's
UE_JOINTS = {"shoulder": (("GTH",), "SHO"), "elbow": (("LEP", "MEP"), "UAR"),
             "wrist": (("SPR", "SPU"), "LAR")}


def read_ue_adl(trial, static=None) -> Recording:
    """A trial of the seated reaching set: joint centres rebuilt from the marker clusters with the
    static trial (`static`, default: the folder's `*_static.csv`): each landmark is expressed in
    its cluster's static pose, then carried by the cluster's rigid fit in every frame."""
    trial = Path(trial)
    if static is None:
        found = sorted(trial.parent.glob("*_static.csv"))
        if not found:
            raise ValueError(f"{trial}: no static trial (*_static.csv) beside it for the joint centres")
        static = found[0]
    _, static_names, static_positions = read_vicon_trajectories(static)
    rate, names, positions = read_vicon_trajectories(trial)
    static_mean = np.nanmean(static_positions, axis=0)
    static_index = {n: k for k, n in enumerate(static_names)}
    index = {n: k for k, n in enumerate(names)}
    points = np.full((len(positions), 8, 3), np.nan)
    slots = {"shoulder": (L_SHOULDER, R_SHOULDER), "elbow": (L_ELBOW, R_ELBOW), "wrist": (L_WRIST, R_WRIST)}
    for joint, (landmarks, cluster) in UE_JOINTS.items():
        for side, slot in zip("LR", slots[joint], strict=True):
            markers = [f"{side}{cluster}{k}" for k in range(1, 5)]
            wanted = [f"{side}{m}" for m in landmarks] + markers
            missing = [m for m in wanted if m not in static_index] + [m for m in markers if m not in index]
            if missing:
                raise ValueError(f"{trial}: the markers {missing} are missing (static {static.name})")
            landmark = np.mean([static_mean[static_index[f"{side}{m}"]] for m in landmarks], axis=0)
            reference = static_mean[[static_index[m] for m in markers]]
            for k, frame in enumerate(positions[:, [index[m] for m in markers]]):
                fit = rigid_fit(reference, frame)
                if fit is not None:
                    points[k, slot] = fit[0] @ landmark + fit[1]
    return _recording(points, rate, str(trial), (0.0, 0.0, 1.0),
                      (f"joint centres from the clusters and {static.name}",))


#: the tape measures of `anthropometrics.csv` (UE ADL), mm, and the bounds a person's can have
UE_TAPE_COLUMNS = ("left_upper_arm_mm", "left_lower_arm_mm", "right_upper_arm_mm", "right_lower_arm_mm")
UE_TAPE_RANGE_MM = (120.0, 550.0)


def read_ue_anthropometrics(path) -> dict[str, dict[str, float]]:
    """`anthropometrics.csv` of the UE ADL set: participant -> height_m and the tape-measured
    upper and lower arm lengths (`UE_TAPE_COLUMNS`, mm). Untrusted: a missing column, a value
    that is not a number in range or a repeated participant is refused, naming file and line."""
    path = Path(path)
    if path.stat().st_size > 100_000:
        raise ValueError(f"{path}: {path.stat().st_size} bytes, more than an anthropometrics table's 100 kB")
    with path.open(newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    wanted = ("participant", "height_m", *UE_TAPE_COLUMNS)
    if not rows or any(c not in rows[0] for c in wanted):
        raise ValueError(f"{path}: needs the columns {list(wanted)}")
    out: dict[str, dict[str, float]] = {}
    for line, row in enumerate(rows, start=2):
        name = (row.get("participant") or "").strip()
        if not re.fullmatch(r"[A-Za-z0-9_]+", name) or name in out:
            raise ValueError(f"{path}:{line}: participant {name!r} is empty, not alphanumeric or repeated")
        values = {}
        bounds = [("height_m", (1.0, 2.5))] + [(c, UE_TAPE_RANGE_MM) for c in UE_TAPE_COLUMNS]
        for column, (low, high) in bounds:
            try:
                value = float(row.get(column))
            except (TypeError, ValueError):
                raise ValueError(f"{path}:{line}: {column} {row.get(column)!r} is not a number") from None
            if not (math.isfinite(value) and low <= value <= high):
                raise ValueError(f"{path}:{line}: {column} {value} is outside [{low}, {high}]")
            values[column] = value
        out[name] = values
    return out


def ue_static_segment_lengths(static) -> dict[str, float]:
    """Segment lengths (mm) from a UE ADL static trial, between the landmarks a tape measures:
    upper arm from the acromion (the centroid of its marker cluster) to the elbow (between the
    epicondyles), lower arm from the elbow to the wrist (between the styloid processes); and the
    importer's own upper arm from its shoulder joint centre (the greater tubercle, `UE_JOINTS`).
    Keys: `<side>_upper_arm_mm`, `<side>_lower_arm_mm`, `<side>_joint_centre_upper_arm_mm`."""
    _, names, positions = read_vicon_trajectories(static)
    mean = np.nanmean(positions, axis=0)
    index = {n: k for k, n in enumerate(names)}

    def at(*markers):
        missing = [m for m in markers if m not in index]
        if missing:
            raise ValueError(f"{static}: the markers {missing} are missing")
        return np.mean([mean[index[m]] for m in markers], axis=0)

    out = {}
    for side, name in (("L", "left"), ("R", "right")):
        acromion = at(*(f"{side}SHO{k}" for k in range(1, 5)))
        elbow, wrist = at(f"{side}LEP", f"{side}MEP"), at(f"{side}SPR", f"{side}SPU")
        out[f"{name}_upper_arm_mm"] = 1000.0 * float(np.linalg.norm(acromion - elbow))
        out[f"{name}_lower_arm_mm"] = 1000.0 * float(np.linalg.norm(elbow - wrist))
        out[f"{name}_joint_centre_upper_arm_mm"] = 1000.0 * float(np.linalg.norm(at(f"{side}GTH") - elbow))
    return out


def synthesize_missing(recording: Recording, neck: float = 0.25) -> Recording:
    """The thorax (midpoint of the shoulders, as the body model places it) and the head (`neck` m
    above the thorax along the recording's up) where the recording has none; named in
    `synthesized`. A frame without both shoulders gets neither."""
    points, tracked = recording.points.copy(), recording.tracked.copy()
    made = []
    both = tracked[:, L_SHOULDER] & tracked[:, R_SHOULDER]
    if not tracked[:, THORAX].any():
        points[both, THORAX] = 0.5 * (points[both, L_SHOULDER] + points[both, R_SHOULDER])
        tracked[:, THORAX] = both
        made.append("thorax")
    if not tracked[:, HEAD].any():
        up = np.asarray(recording.up, dtype=float)
        points[tracked[:, THORAX], HEAD] = points[tracked[:, THORAX], THORAX] + neck * up / np.linalg.norm(up)
        tracked[:, HEAD] = tracked[:, THORAX]
        made.append("head")
    return replace(recording, points=points, tracked=tracked,
                   synthesized=tuple(dict.fromkeys((*recording.synthesized, *made))))


@dataclass(frozen=True)
class Placement:
    """Where a recording goes in a cell: its operator stands at `operator_xy` facing `facing`
    (a yaw, rad: pi faces -x, toward a robot at the origin), the low wrist heights (their 5th
    percentile) `wrist_above_table` m above the table top at `table_height`."""

    operator_xy: tuple[float, float] = (1.0, 0.0)
    facing: float = math.pi
    table_height: float = 0.75
    wrist_above_table: float = 0.05


def place_in_cell(recording: Recording, placement: Placement) -> tuple[Recording, np.ndarray, np.ndarray]:
    """The recording moved rigidly into the cell frame (z up): (placed recording, R (3, 3), t (3,)),
    cell = R @ recorded + t. Up becomes +z; the shoulders' facing direction (up x left-to-right,
    median over frames) becomes `placement.facing`; the thorax's median lies over `operator_xy`,
    the wrists' 5th height percentile `wrist_above_table` above the table."""
    p, tr = recording.points, recording.tracked
    up = np.asarray(recording.up, dtype=float)
    up = up / np.linalg.norm(up)
    both = tr[:, L_SHOULDER] & tr[:, R_SHOULDER]
    if not both.any():
        why = "; ".join(note for note in recording.notes if note.endswith("untracked"))
        raise ValueError(f"{recording.source}: no frame holds both shoulders: the facing cannot be found"
                         + (f" ({why})" if why else ""))
    across = np.median(p[both, R_SHOULDER] - p[both, L_SHOULDER], axis=0)  # left to right
    across = across - (across @ up) * up
    # a person's right is forward x up: forward = up x (left -> right)
    forward = np.cross(up, across)
    forward /= np.linalg.norm(forward)
    left = np.cross(up, forward)
    recorded_axes = np.stack([forward, left, up])  # rows: the person's forward, left, up
    c, s = math.cos(placement.facing), math.sin(placement.facing)
    cell_axes = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # rows: the same in the cell
    rotation = cell_axes.T @ recorded_axes
    rotated = p @ rotation.T
    centres = 0.5 * (rotated[both, L_SHOULDER] + rotated[both, R_SHOULDER])  # the body model's thorax
    centre = np.median(centres, axis=0)
    wrists = np.concatenate([rotated[tr[:, L_WRIST], L_WRIST, 2], rotated[tr[:, R_WRIST], R_WRIST, 2]])
    if not len(wrists):
        raise ValueError(f"{recording.source}: no wrist is recorded: the table height cannot be found")
    low = float(np.percentile(wrists, 5))
    shift = np.array([placement.operator_xy[0] - centre[0], placement.operator_xy[1] - centre[1],
                      placement.table_height + placement.wrist_above_table - low])
    placed = replace(recording, points=np.where(tr[..., None], rotated + shift, np.nan), up=(0.0, 0.0, 1.0))
    return placed, rotation, shift


def resample(recording: Recording, rate: float) -> Recording:
    """The recording at `rate` Hz (e.g. the camera's): each point interpolated linearly between
    the two recorded frames around a time when both hold it, untracked otherwise (gaps stay)."""
    rate = _check_rate(rate, recording.source or "resample")
    frames = math.floor(float(recording.times[-1]) * rate + 1e-9) + 1
    if frames > MAX_RESAMPLED_FRAMES:
        raise ValueError(f"{recording.source or 'resample'}: {recording.times[-1]:.6g} s at {rate:g} Hz "
                         f"would be {frames:,} frames; at most {MAX_RESAMPLED_FRAMES:,} are written (check "
                         "the recording's rate, or a lower --camera-rate)")
    times = np.arange(0.0, recording.times[-1] + 1e-9, 1.0 / rate)
    after = np.clip(np.searchsorted(recording.times, times, side="right"), 1, recording.frames - 1)
    before = after - 1
    span = recording.times[after] - recording.times[before]
    w = np.clip((times - recording.times[before]) / np.where(span > 0, span, 1.0), 0.0, 1.0)
    exact_before, exact_after = w <= 1e-9, w >= 1.0 - 1e-9
    tb, ta = recording.tracked[before], recording.tracked[after]
    tracked = (tb & ta) | (tb & exact_before[:, None]) | (ta & exact_after[:, None])
    pb = np.nan_to_num(recording.points[before])
    pa = np.nan_to_num(recording.points[after])
    points = pb + w[:, None, None] * (pa - pb)
    points = np.where(exact_before[:, None, None] & tb[..., None], pb, points)
    points = np.where(exact_after[:, None, None] & ta[..., None], pa, points)
    points = np.where(tracked[..., None], points, np.nan)
    return replace(recording, times=times, points=points, tracked=tracked, rate=float(rate))


def read_columns_file(path) -> dict:
    """A YAML mapping of skeleton point names to [x, y, z] column indices; ScenarioError naming the
    file and the entry at fault."""
    import yaml

    from hrc_drake.errors import ScenarioError, check_input_file, yaml_syntax_error

    path = Path(path)
    check_input_file(path, "column mapping")
    try:
        document = yaml.safe_load(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError as err:
        raise ScenarioError(path, "", f"not UTF-8 text (byte {err.start})") from None
    except yaml.YAMLError as err:
        raise yaml_syntax_error(path, err, "not a YAML mapping") from None
    if not isinstance(document, dict) or not document:
        raise ScenarioError(path, "", "must map skeleton point names to [x, y, z] column indices")
    for name, cols in document.items():
        if name not in SKELETON_POINTS:
            raise ScenarioError(path, str(name), f"unknown skeleton point; known: {list(SKELETON_POINTS)}")
        if not (isinstance(cols, list) and len(cols) == 3
                and all(isinstance(c, int) and not isinstance(c, bool) and 0 <= c < 10_000 for c in cols)):
            raise ScenarioError(path, str(name), f"must be [x, y, z] column indices (0-based), got {cols!r}")
    return {name: tuple(cols) for name, cols in document.items()}


@dataclass(frozen=True)
class ImportedRecording:
    """A recording read, placed in a cell and resampled (`read_recording`), not yet written:
    `resampled` is what the skeleton CSV holds, `recording` what was read (synthesised points
    named), `provenance` the JSON written beside the CSV."""

    recording: Recording
    resampled: Recording
    provenance: dict

    def summary(self, out: Path) -> list[str]:
        """The lines `import_recording` returns for the CSV `out` (its first one: frames, rates,
        source)."""
        out = Path(out)
        untracked = self.provenance["untracked_frames"]
        lines = [f"{out}: {self.resampled.frames} frames at {self.resampled.rate:g} Hz from "
                 f"{self.recording.frames} at {self.recording.rate:g} Hz ({self.recording.source})",
                 f"synthesised: {', '.join(self.recording.synthesized) or 'none'}; untracked frames: "
                 + (", ".join(f"{k} {v}" for k, v in untracked.items() if v) or "none"),
                 f"provenance: {out.with_suffix('.json')}"]
        return lines + [f"note: {note}" for note in self.recording.notes]


def read_recording(kind: str, source: Path, source_rate: float | None = None, person: str = "giver",
                   columns: str | None = None, units: str = "m", delimiter: str | None = None,
                   header_rows: int = 0, up: str = "0,0,1", camera_rate: float = 30.0,
                   operator_xy=(1.0, 0.0), facing: float = math.pi,
                   table_height: float = 0.75) -> ImportedRecording:
    """Read a real recording (`kind` lego, kth, ue or table), synthesise what it lacks, place it in
    a cell and resample it to `camera_rate`, writing nothing (`write_recording` writes it).
    ScenarioError on bad input."""
    from hrc_drake.errors import ScenarioError

    if kind in ("lego", "table") and source_rate is None:
        raise ScenarioError(source, "--rate", f"a {kind} recording needs its frame rate (Hz)")

    try:
        if kind == "lego":
            recording = read_lego(source, source_rate)
        elif kind == "kth":
            recording = read_kth(source, person)
        elif kind == "ue":
            recording = read_ue_adl(source)
        elif kind == "table":
            if columns is None:
                raise ScenarioError(source, "--columns", "a table needs its column mapping (a YAML file)")
            up_axis = _vector(up, "--up")
            recording = read_joint_table(source, read_columns_file(columns), units, source_rate, delimiter,
                                         header_rows, up_axis)
        else:
            raise ScenarioError(source, "", f"unknown recording kind {kind!r}")
        check_segment_lengths(recording.points, recording.tracked, str(source), units)
        recording = synthesize_missing(recording)
        placement = _placement(operator_xy, facing, table_height)
        placed, rotation, shift = place_in_cell(recording, placement)
        resampled = resample(placed, camera_rate)
    except ValueError as err:
        if isinstance(err, ScenarioError):
            raise
        refusal = ScenarioError(source, "", str(err))
        if str(err).startswith(str(source)):  # the reader named the file (and line) already
            refusal.args = (str(err),)
        raise refusal from None
    untracked = {name: int((~resampled.tracked[:, k]).sum()) for k, name in enumerate(SKELETON_POINTS)}
    provenance = {"source": recording.source, "kind": kind, "frames_recorded": recording.frames,
                  "recorded_rate_hz": recording.rate, "frames_written": resampled.frames,
                  "written_rate_hz": resampled.rate, "synthesized": list(recording.synthesized),
                  "untracked_frames": untracked, "rotation": rotation.round(6).tolist(),
                  "translation_m": shift.round(6).tolist(), "placement": {"operator_xy": list(operator_xy),
                  "facing_rad": facing, "table_height_m": table_height}, "notes": list(recording.notes)}
    return ImportedRecording(recording, resampled, provenance)


def write_recording(imported: ImportedRecording, out: Path,
                    write_to: tuple[Path, Path] | None = None) -> list[str]:
    """Write an imported recording as the skeleton CSV `out` (`recorded.save_skeleton_csv`) with
    the JSON of its provenance beside it; returns the summary lines (`ImportedRecording.summary`).
    write_to: the (CSV, JSON) files to write instead (a command's temporary files, renamed to
    `out` and its .json once every output is ready); the summary names the final files."""
    import json

    from hrc_drake.human.recorded import save_skeleton_csv

    out = Path(out)
    if write_to is None:
        out.parent.mkdir(parents=True, exist_ok=True)
        write_to = (out, out.with_suffix(".json"))
    resampled = imported.resampled
    save_skeleton_csv(write_to[0], resampled.times, resampled.points, resampled.tracked)
    Path(write_to[1]).write_text(json.dumps(imported.provenance, indent=2))
    return imported.summary(out)


def import_recording(kind: str, source: Path, out: Path, source_rate: float | None = None,
                     person: str = "giver", columns: str | None = None, units: str = "m",
                     delimiter: str | None = None, header_rows: int = 0, up: str = "0,0,1",
                     camera_rate: float = 30.0, operator_xy=(1.0, 0.0), facing: float = math.pi,
                     table_height: float = 0.75, write_to: tuple[Path, Path] | None = None) -> list[str]:
    """Read a real recording (`kind` lego, kth, ue or table), synthesise what it lacks, place it in
    a cell, resample it to `camera_rate` and write it as a skeleton CSV (`recorded.save_skeleton_csv`)
    with a JSON of its provenance beside it; returns summary lines. ScenarioError on bad input.
    `read_recording` then `write_recording` (write_to: the files to write instead, see there)."""
    imported = read_recording(kind, source, source_rate=source_rate, person=person, columns=columns,
                              units=units, delimiter=delimiter, header_rows=header_rows, up=up,
                              camera_rate=camera_rate, operator_xy=operator_xy, facing=facing,
                              table_height=table_height)
    return write_recording(imported, out, write_to)


def _placement(operator_xy, facing, table_height) -> Placement:
    """The placement options checked: finite, the operator within MAX_PLACEMENT_M of the origin,
    the table top within TABLE_HEIGHT_RANGE_M."""
    from hrc_drake.errors import ScenarioError

    x, y = (float(v) for v in operator_xy)
    for option, value in (("--operator-x", x), ("--operator-y", y)):
        if not (math.isfinite(value) and abs(value) <= MAX_PLACEMENT_M):
            raise ScenarioError("", option, f"must be a finite number of m within +/-{MAX_PLACEMENT_M:g} of "
                                            f"the cell's origin, got {value!r}")
    if not math.isfinite(float(facing)):
        raise ScenarioError("", "--facing", f"must be a finite angle (rad), got {facing!r}")
    low, high = TABLE_HEIGHT_RANGE_M
    if not (math.isfinite(float(table_height)) and low <= table_height <= high):
        raise ScenarioError("", "--table-height", f"must be within {low}-{high} m, got {table_height!r}")
    return Placement((x, y), float(facing), float(table_height))


def check_recording_size(path: Path) -> None:
    """`path` is a regular readable file (not a FIFO or a device, which reading would block on or
    never end) of at most MAX_RECORDING_BYTES; else ScenarioError, before any of it is read."""
    from hrc_drake.errors import ScenarioError, check_input_file

    check_input_file(path, "recording")
    size = path.stat().st_size
    if size > MAX_RECORDING_BYTES:
        raise ScenarioError(path, "", f"is {size / 2**20:.1f} MiB; recordings up to "
                                      f"{MAX_RECORDING_BYTES // 2**20} MiB are read: cut it into parts")


def _vector(text: str, option: str) -> tuple[float, float, float]:
    from hrc_drake.errors import ScenarioError

    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 3 or not all(math.isfinite(v) for v in values) or math.hypot(*values) < 1e-6:
        raise ScenarioError("", option, f"must be three finite numbers x,y,z, not all (near) 0, got {text!r}")
    return values
