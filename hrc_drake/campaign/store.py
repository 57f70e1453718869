"""The rows of a campaign in DIR/runs.parquet: rewritten atomically (a new file, then a rename)
at most every `flush_every` seconds (or 20 times the last rewrite's time, for large tables) while
runs finish and at the end, so an interrupted campaign keeps its rows and a rerun skips the runs
already `ok` with the same configuration."""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from pathlib import Path

from hrc_drake.campaign.worker import KEY_COLUMNS, RUN_COLUMNS
from hrc_drake.errors import ScenarioError

RUNS_FILE = "runs.parquet"
#: free space an output folder needs before a campaign starts (bytes): the table, plots, replays
MIN_FREE_BYTES = 50_000_000


def check_output_dir(path: Path, option: str = "--out", min_free: int = MIN_FREE_BYTES) -> None:
    """`path` is, or can be made, a writable folder with room; else `ScenarioError` on `option`."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise ScenarioError(path, option, "exists and is not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path) as probe:
            probe.write(b"x" * 4096)
            probe.flush()
            os.fsync(probe.fileno())
    except OSError as err:
        raise ScenarioError(path, option, f"cannot write there: {err.strerror or err}") from None
    free = shutil.disk_usage(path).free
    if free < min_free:
        raise ScenarioError(
            path,
            option,
            f"the disk is full: {free / 1e6:.1f} MB free, a campaign needs {min_free / 1e6:.0f} MB",
        )


def read_runs(out_dir: Path):
    """DIR/runs.parquet as a DataFrame (empty when there is none)."""
    import pandas as pd

    path = Path(out_dir) / RUNS_FILE
    if not path.is_file():
        return pd.DataFrame(columns=[*KEY_COLUMNS, *RUN_COLUMNS])
    return pd.read_parquet(path)


def sorted_columns(columns) -> list[str]:
    """Key, run columns, then the metrics by name."""
    head = [c for c in (*KEY_COLUMNS, *RUN_COLUMNS) if c in columns]
    return head + sorted(c for c in columns if c not in head)


class RunStore:
    """The rows of one output folder, by (scenario, variant, seed, duration); a new row of a key
    replaces the old one (a rerun of a failed run)."""

    #: a rewrite may take at most this share of the time between rewrites: the whole table is
    #: written each time (~0.12 s for 1,000 rows), so large tables are written less often
    MAX_FLUSH_SHARE = 0.05

    def __init__(self, out_dir: Path, flush_every: float = 2.0):
        self.path = Path(out_dir) / RUNS_FILE
        self.flush_every = flush_every
        self._gap = flush_every
        self._rows: dict[tuple, dict] = {}
        self._dirty = False
        self._last_flush = time.monotonic()
        for row in read_runs(out_dir).to_dict("records"):
            self._rows[self._key(row)] = row

    @staticmethod
    def _key(row: dict) -> tuple:
        return (row["scenario"], row["variant"], int(row["seed"]), float(row["duration"]))

    def is_done(self, key: tuple, config_hash: str) -> bool:
        row = self._rows.get((key[0], key[1], int(key[2]), float(key[3])))
        return row is not None and row["status"] == "ok" and row["config_hash"] == config_hash

    def add(self, row: dict) -> None:
        self._rows[self._key(row)] = row
        self._dirty = True
        if time.monotonic() - self._last_flush >= self._gap:
            self.flush()

    def flush(self) -> None:
        """Write every row to runs.parquet (sorted by key) through a temporary file and a rename."""

        if not self._dirty:
            return
        start = time.monotonic()
        frame = self.frame()
        tmp = self.path.with_name(f".{self.path.name}.{os.getpid()}.tmp")
        frame.to_parquet(tmp, index=False)
        os.replace(tmp, self.path)
        self._dirty = False
        self._last_flush = time.monotonic()
        self._gap = max(self.flush_every, (self._last_flush - start) / self.MAX_FLUSH_SHARE)

    def frame(self):
        """The rows sorted by key, each metric column of one type whatever the order the runs
        finished in: numbers (NaN where missing), true/false (nullable), else text."""
        import pandas as pd

        frame = pd.DataFrame([self._rows[k] for k in sorted(self._rows)])
        if frame.empty:
            return pd.DataFrame(columns=[*KEY_COLUMNS, *RUN_COLUMNS])
        for column in frame.columns:
            if column not in (*KEY_COLUMNS, *RUN_COLUMNS):
                frame[column] = _one_type(frame[column])
        return frame[sorted_columns(frame.columns)]


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
