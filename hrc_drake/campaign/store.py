"""The rows of a campaign in its output folder, kept so that no finished run is lost or mixed:

- `runs.journal.jsonl`: every row is appended there first (one JSON line, flushed to disk) as its
  run finishes: a crash at any instant loses at most the line being written, which reading skips;
- `runs.parquet`: the table, rewritten atomically (a new file, then a rename) at most every
  `flush_every` seconds (or 20 times the last rewrite's time, for large tables) and at the end,
  after which the journal is emptied; reading takes the table, then the journal's rows;
- `campaign.lock`: one campaign writes a folder at a time (an advisory lock the system releases
  when its holder dies; the file names the holder's pid and host for the message to others),
  removed when the campaign ends.

A rerun skips the runs already `ok` with the same configuration; rows whose configuration differs
from the spec's are refused by `check_compatible` (pooled, they would mix two campaigns).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import socket
import tempfile
import time
from pathlib import Path

from hrc_drake.campaign.worker import KEY_COLUMNS, RUN_COLUMNS
from hrc_drake.errors import EnvironmentFailure, ScenarioError

RUNS_FILE = "runs.parquet"
JOURNAL_FILE = "runs.journal.jsonl"
LOCK_FILE = "campaign.lock"
#: free space an output folder needs before a campaign starts (bytes): the table, plots, replays
MIN_FREE_BYTES = 50_000_000


def check_output_dir(path: Path, option: str = "--out", min_free: int = MIN_FREE_BYTES,
                     create: bool = True) -> None:
    """`path` is, or can be made, a writable folder with room; else `ScenarioError` on `option`.
    create=False checks without making anything (the folder of a spec not yet checked)."""
    path = Path(path)
    if path.is_symlink() and not path.exists():
        raise ScenarioError(path, option, f"is a symbolic link to {os.readlink(path)!s}, which does not "
                                          "exist: remove the link or give another folder")
    if path.exists() and not path.is_dir():
        raise ScenarioError(path, option, "exists and is not a folder: give a folder's path")
    if not create:
        existing = next((p for p in (path, *path.absolute().parents) if p.exists()), Path("/"))
        if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
            raise ScenarioError(path, option, f"cannot write there: {existing} is not a writable folder")
        _check_free(path, existing, option, min_free)
        return
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path) as probe:
            probe.write(b"x" * 4096)
            probe.flush()
            os.fsync(probe.fileno())
    except OSError as err:
        raise ScenarioError(path, option, f"cannot write there: {err.strerror or err}") from None
    _check_free(path, path, option, min_free)


def _check_free(path: Path, existing: Path, option: str, min_free: int) -> None:
    free = shutil.disk_usage(existing).free
    if free < min_free:
        raise ScenarioError(
            path,
            option,
            f"the disk is full: {free / 1e6:.1f} MB free, a campaign needs {min_free / 1e6:.0f} MB",
        )


def _empty_table():
    import pandas as pd

    return pd.DataFrame(columns=[*KEY_COLUMNS, *RUN_COLUMNS])


def _damaged(path: Path, what: str):
    return ScenarioError(path, "", f"{what}: move it aside (or delete it) and run the campaign again to "
                                   "start its table afresh")


def read_table(out_dir: Path):
    """DIR/runs.parquet as a DataFrame (empty when there is none); `ScenarioError` naming the file
    and what to do when it is damaged or not a campaign's table."""
    import pandas as pd

    path = Path(out_dir) / RUNS_FILE
    if not path.exists():
        return _empty_table()
    if not path.is_file():
        raise _damaged(path, "is not a file")
    try:
        frame = pd.read_parquet(path)
    except Exception as err:  # noqa: BLE001 - pyarrow raises many kinds for a damaged file
        raise _damaged(path, f"cannot be read as a table ({type(err).__name__}: {err})") from None
    missing = [c for c in (*KEY_COLUMNS, "status", "config_hash") if c not in frame.columns]
    if missing:
        raise _damaged(path, f"is not a campaign's table (no column {', '.join(missing)})")
    return frame


def read_journal(out_dir: Path) -> list[dict]:
    """The rows of DIR/runs.journal.jsonl; a last line cut short by a crash is skipped, a damaged
    line elsewhere is a `ScenarioError`."""
    path = Path(out_dir) / JOURNAL_FILE
    if not path.is_file():
        return []
    lines = path.read_bytes().split(b"\n")
    rows = []
    for number, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            row = json.loads(line)
            if not isinstance(row, dict) or any(c not in row for c in (*KEY_COLUMNS, "status")):
                raise ValueError("not a row")
        except ValueError as err:
            if number == len(lines):  # no newline yet: the line being written when it stopped
                continue
            raise _damaged(path, f"line {number} is not a row ({err})") from None
        rows.append(row)
    return rows


def read_runs(out_dir: Path):
    """Every row of a campaign folder: the table, then the journal's rows (replacing a row of the
    same key), sorted by key, as `RunStore.frame` types them."""
    store = RunStore(out_dir, writable=False)
    return store.frame()


def _row_key(row: dict) -> tuple:
    return (row["scenario"], row["variant"], int(row["seed"]), float(row["duration"]))


def _plain(value):
    """A JSON-ready value of a numpy scalar or array (extra metrics may give lists)."""
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"cannot store a {type(value).__name__} in a row")


class RunStore:
    """The rows of one output folder, by (scenario, variant, seed, duration); a new row of a key
    replaces the old one (a rerun of a failed run). `add` journals the row before it returns."""

    #: a rewrite may take at most this share of the time between rewrites: the whole table is
    #: written each time (~0.12 s for 1,000 rows), so large tables are written less often
    MAX_FLUSH_SHARE = 0.05

    def __init__(self, out_dir: Path, flush_every: float = 2.0, writable: bool = True):
        self.out_dir = Path(out_dir)
        self.path = self.out_dir / RUNS_FILE
        self.journal_path = self.out_dir / JOURNAL_FILE
        self.flush_every = flush_every
        self._gap = flush_every
        self._rows: dict[tuple, dict] = {}
        self._dirty = False
        self._journal = None
        self._last_flush = time.monotonic()
        for row in read_table(out_dir).to_dict("records"):
            self._rows[_row_key(row)] = row
        journaled = read_journal(out_dir)
        for row in journaled:
            self._rows[_row_key(row)] = row
        self._dirty = bool(journaled)
        if writable and journaled:
            self.flush()  # the journal's rows into the table, and a clean journal to append to

    def rows(self) -> list[dict]:
        return list(self._rows.values())

    def is_done(self, key: tuple, config_hash: str) -> bool:
        row = self._rows.get((key[0], key[1], int(key[2]), float(key[3])))
        return row is not None and row["status"] == "ok" and row["config_hash"] == config_hash

    def add(self, row: dict) -> None:
        """Journal `row` (flushed to the disk), then keep it; OSError when it cannot be written."""
        line = json.dumps(row, default=_plain, allow_nan=True) + "\n"
        if self._journal is None:
            self.out_dir.mkdir(parents=True, exist_ok=True)  # a store of a folder not made yet
            self._journal = open(self.journal_path, "a", encoding="utf-8")  # noqa: SIM115 - kept open
        self._journal.write(line)
        self._journal.flush()
        os.fsync(self._journal.fileno())
        self._rows[_row_key(row)] = row
        self._dirty = True
        if time.monotonic() - self._last_flush >= self._gap:
            self.flush()

    def flush(self) -> None:
        """Write every row to runs.parquet (sorted by key) through a temporary file and a rename,
        then empty the journal (its rows are in the table)."""
        if not self._dirty:
            return
        start = time.monotonic()
        frame = self.frame()
        tmp = self.path.with_name(f".{self.path.name}.{os.getpid()}.tmp")
        try:
            frame.to_parquet(tmp, index=False)
            os.replace(tmp, self.path)
        finally:
            tmp.unlink(missing_ok=True)
        if self._journal is not None:
            self._journal.close()
            self._journal = None
        # a crash before this line leaves the journal's rows in both: reading takes them once
        with open(self.journal_path, "w", encoding="utf-8"):
            pass
        self._dirty = False
        self._last_flush = time.monotonic()
        self._gap = max(self.flush_every, (self._last_flush - start) / self.MAX_FLUSH_SHARE)

    def close(self) -> None:
        if self._journal is not None:
            self._journal.close()
            self._journal = None

    def frame(self):
        """The rows sorted by key, each metric column of one type whatever the order the runs
        finished in: numbers (NaN where missing), true/false (nullable), else text."""
        import pandas as pd

        frame = pd.DataFrame([self._rows[k] for k in sorted(self._rows)])
        if frame.empty:
            return _empty_table()
        for column in frame.columns:
            if column not in (*KEY_COLUMNS, *RUN_COLUMNS):
                frame[column] = _one_type(frame[column])
        return frame[sorted_columns(frame.columns)]


def sorted_columns(columns) -> list[str]:
    """Key, run columns, then the metrics by name."""
    head = [c for c in (*KEY_COLUMNS, *RUN_COLUMNS) if c in columns]
    return head + sorted(c for c in columns if c not in head)


def _one_type(column):
    import pandas as pd

    present = [v for v in column if v is not None and not (isinstance(v, float) and v != v)]
    if all(isinstance(v, bool) for v in present) and present:
        return column.map(lambda v: v if isinstance(v, bool) else pd.NA).astype("boolean")
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        if present and all(isinstance(v, int) for v in present) and len(present) == len(column):
            return column.astype("int64")
        return pd.to_numeric(column.map(lambda v: float("nan") if v is None else v)).astype("float64")
    return column


def check_compatible(rows: list[dict], duration: float, config_hashes: dict, out_dir: Path) -> None:
    """Refuse (`ScenarioError`) a spec whose runs would be pooled with rows of another
    configuration in `out_dir`: rows of another duration, or of a (scenario, variant) of the spec
    whose scenario file or overrides changed. More seeds, scenarios or variants extend a table."""
    problems = []
    durations = sorted({float(r["duration"]) for r in rows
                        if not math.isclose(float(r["duration"]), duration)})
    if durations:
        lasting = ", ".join(f"{d:g}" for d in durations)
        problems.append(f"its runs last {lasting} s, this spec's {duration:g} s")
    changed = sorted({(r["scenario"], r["variant"]) for r in rows
                      if (r["scenario"], r["variant"]) in config_hashes
                      and r.get("config_hash") != config_hashes[r["scenario"], r["variant"]]})
    if changed:
        names = ", ".join(f"{s}/{v}" for s, v in changed[:5]) + (" ..." if len(changed) > 5 else "")
        problems.append(f"the scenario file or the overrides of {names} changed since its runs")
    if problems:
        raise ScenarioError(Path(out_dir) / RUNS_FILE, "",
                            "holds the runs of another campaign configuration (" + "; ".join(problems)
                            + "): give another --out, or add --new-spec to move the old results into a "
                            "subfolder and start a new table")


def archive_previous(out_dir: Path) -> Path | None:
    """Move an earlier campaign's results in `out_dir` (all but the lock) into
    `out_dir/previous-<UTC time>/`; returns that folder (None when there was nothing)."""
    out_dir = Path(out_dir)
    entries = [p for p in out_dir.iterdir() if p.name != LOCK_FILE and not p.name.startswith("previous-")]
    if not entries:
        return None
    target = out_dir / time.strftime("previous-%Y%m%dT%H%M%SZ", time.gmtime())
    suffix = 1
    while target.exists():
        suffix += 1
        target = target.with_name(f"{target.name.split('.')[0]}.{suffix}")
    target.mkdir()
    for entry in entries:
        os.replace(entry, target / entry.name)
    return target


class CampaignLock:
    """One writer per campaign folder: an exclusive advisory lock on DIR/campaign.lock (released
    by the system when the holder dies, so a killed campaign leaves no stale lock), the file
    naming the holder's pid and host, and removed when the campaign ends (it is not a result).
    `wait`: seconds to wait for a busy folder (0: refuse)."""

    POLL = 0.5

    def __init__(self, out_dir: Path, wait: float = 0.0, progress=None):
        self.path = Path(out_dir) / LOCK_FILE
        self.wait, self.progress = wait, progress
        self._file = None

    def __enter__(self):
        import fcntl

        deadline = time.monotonic() + self.wait
        told = False
        while True:
            file = open(self.path, "a+", encoding="utf-8")  # noqa: SIM115 - held until __exit__
            try:
                fcntl.flock(file.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                file.close()
                holder = self._holder()
                if time.monotonic() >= deadline:
                    raise EnvironmentFailure(
                        f"{self.path.parent} is in use by another campaign ({holder}); wait for it to "
                        "finish (or add --wait), or give another --out") from None
                if not told and self.progress is not None:
                    print(f"waiting for the campaign that holds {self.path.parent} ({holder}) ...",
                          file=self.progress, flush=True)
                    told = True
                time.sleep(self.POLL)
                continue
            if self._is_at_path(file):
                break
            # the holder removed the file between our open and our lock: lock the one there now
            file.close()
        self._file = file
        self._file.seek(0)
        self._file.truncate()
        self._file.write(json.dumps({"pid": os.getpid(), "host": socket.gethostname(),
                                     "since": time.strftime("%Y-%m-%d %H:%M:%S")}) + "\n")
        self._file.flush()
        return self

    def _is_at_path(self, file) -> bool:
        """Whether `file` is still the lock file at `path` (not one a finished holder removed)."""
        try:
            at_path, held = os.stat(self.path), os.fstat(file.fileno())
        except FileNotFoundError:
            return False
        return (at_path.st_dev, at_path.st_ino) == (held.st_dev, held.st_ino)

    def _holder(self) -> str:
        try:
            owner = json.loads(self.path.read_text() or "{}")
            return f"pid {owner['pid']} on {owner['host']} since {owner['since']}"
        except (OSError, ValueError, KeyError, TypeError):
            return "its holder is not named"

    def __exit__(self, *exc):
        # removed while still held, so no campaign can lock this file after us (`_is_at_path`)
        self.path.unlink(missing_ok=True)
        self._file.close()  # releases the lock
        return False
