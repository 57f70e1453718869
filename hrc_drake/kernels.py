"""Compiled kernels (numba): the shared primitives, and how every group of kernels compiles.

Each subpackage keeps the numba forms of its own algorithms beside them, in a private
`_kernels.py` (`human`, `motion`, `perception`, `intention`, `prediction`, `scheduling`,
`safety`: see `GROUPS`): per-frame geometry and per-step models that numpy runs as many calls
on tiny arrays, written as loops (DESIGN.md, performance rules). This module holds what several
of them use: Ericson's clamped closest points of two segments (Real-Time Collision Detection,
5.1.9) as `motion.geometry` states it, the clearances of capsule pairs (the recorder, the speed
scaler, the safety rules), the closest-point parameters of capsule pairs (the safety rules'
numpy reference), Gaussian elimination with partial pivoting, and `_arrays`, the argument
conversion every wrapper uses. Their numpy forms stay the reference the tests compare against
(tests/test_kernels.py).

Compilation: a kernel compiles when it is first called (numba's lazy compile), so a cell
compiles only the groups its systems use, and caches it on disk (`cache=True`: next to its
file, in `NUMBA_CACHE_DIR`, or numba's user cache when that is not writable). When a group
compiles because it is not in the cache, stderr says so once per process and group ("compiling
kernels for the particle filter (first run only) ..."; a numba "numba:compile" event listener,
`_FirstRunNotice`). numba stamps a cached kernel with its own file only, so `register_group`
adds the files of the kernels it calls from another module (these primitives, the skeleton) to
the stamp: editing a primitive recompiles its callers. `warm_up()` compiles or loads the groups
named (all by default), for the tests and `tools/bench_cell.py`, which reports how long each
group takes to compile from an empty cache. `hrc-drake simulate` compiles a first run's groups
ahead (`compile_ahead`, the groups of `cell.build.kernel_groups`): one background process per
CPU while the cell builds, sharing the groups' warm-up calls by claiming each in a temporary
folder, so that the run loads them from the cache instead of compiling one after another
(`campaign` and `search` the same, once for all their local workers).

Small products and reductions are written as loops: numba's ndarray.min/max, np.linalg.solve
and slice assignments each take it a second or more to compile.
"""

from __future__ import annotations

import hashlib
import importlib
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from numba import njit
from numba.core import event

_EPS = 1e-12
_FLOAT64 = np.dtype(np.float64)

#: The groups of kernels, one per module: name -> (module, what its kernels serve, as the
#: first-run message names it). `tools/bench_cell.py` reports `kernel_compile_s.<name>`.
GROUPS: dict[str, tuple[str, str]] = {
    "geometry": ("hrc_drake.kernels", "the capsule geometry"),
    "human": ("hrc_drake.human._kernels", "the camera and the body model"),
    "motion": ("hrc_drake.motion._kernels", "the human motion predictor"),
    "perception": ("hrc_drake.perception._kernels", "the Kalman trackers and the particle filter"),
    "intention": ("hrc_drake.intention._kernels", "the intention estimator and the action segmenter"),
    "prediction": ("hrc_drake.prediction._kernels", "the waiting-time predictor"),
    "scheduling": ("hrc_drake.scheduling._kernels", "the Monte Carlo scheduler"),
    "safety": ("hrc_drake.safety._kernels", "the ISO/TS 15066 safety rules"),
}


@njit(cache=True, inline="always")
def _closest_on_segments(a, b, c, e, f):
    """Closest-point parameters (s, t) of segments p1 + s d1, p2 + t d2 from a = d1.d1, b = d1.d2,
    c = d1.r, e = d2.d2, f = d2.r, r = p1 - p2 (Ericson 5.1.9; a zero-length segment is a point)."""
    if a <= _EPS and e <= _EPS:
        return 0.0, 0.0
    if a <= _EPS:
        return 0.0, min(max(f / e, 0.0), 1.0)
    if e <= _EPS:
        return min(max(-c / a, 0.0), 1.0), 0.0
    denom = a * e - b * b
    s = 0.0
    if denom > _EPS * max(a * e, _EPS):  # not parallel: else any s, take 0
        s = min(max((b * f - c * e) / denom, 0.0), 1.0)
    t = (b * s + f) / e
    if t < 0.0:
        return min(max(-c / a, 0.0), 1.0), 0.0
    if t > 1.0:
        return min(max((b - c) / a, 0.0), 1.0), 1.0
    return s, t


@njit(cache=True, inline="always")
def _segment_distance(p, q, u, v):
    """Distance between segments p -> q and u -> v (each a (3,) array)."""
    d1x, d1y, d1z = q[0] - p[0], q[1] - p[1], q[2] - p[2]
    d2x, d2y, d2z = v[0] - u[0], v[1] - u[1], v[2] - u[2]
    rx, ry, rz = p[0] - u[0], p[1] - u[1], p[2] - u[2]
    a = d1x * d1x + d1y * d1y + d1z * d1z
    b = d1x * d2x + d1y * d2y + d1z * d2z
    c = d1x * rx + d1y * ry + d1z * rz
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    s, t = _closest_on_segments(a, b, c, e, f)
    gx = rx + s * d1x - t * d2x
    gy = ry + s * d1y - t * d2y
    gz = rz + s * d1z - t * d2z
    return math.sqrt(gx * gx + gy * gy + gz * gz)


@njit(cache=True)
def _segment_pair_distances(start_a, end_a, start_b, end_b):
    """(Ka, Kb) distances between every segment of set A (Ka, 3) and every one of set B (Kb, 3)."""
    out = np.empty((start_a.shape[0], start_b.shape[0]))
    for i in range(start_a.shape[0]):
        for j in range(start_b.shape[0]):
            out[i, j] = _segment_distance(start_a[i], end_a[i], start_b[j], end_b[j])
    return out


@njit(cache=True)
def _capsule_clearances(start_a, end_a, radius_a, start_b, end_b, radius_b):
    out = _segment_pair_distances(start_a, end_a, start_b, end_b)
    for i in range(out.shape[0]):
        for j in range(out.shape[1]):
            out[i, j] -= radius_a[i] + radius_b[j]
    return out


@njit(cache=True)
def _pair_closest_parameters(start_a, end_a, start_b, end_b, index_a, index_b):
    """(N, 2) closest-point parameters (s, t) of the segment pairs (index_a[n], index_b[n]) of sets
    A and B: the points start + s (end - start) of each (`_closest_on_segments`)."""
    out = np.empty((index_a.shape[0], 2))
    for n in range(index_a.shape[0]):
        i, j = index_a[n], index_b[n]
        d1x, d1y, d1z = end_a[i, 0] - start_a[i, 0], end_a[i, 1] - start_a[i, 1], end_a[i, 2] - start_a[i, 2]
        d2x, d2y, d2z = end_b[j, 0] - start_b[j, 0], end_b[j, 1] - start_b[j, 1], end_b[j, 2] - start_b[j, 2]
        rx, ry, rz = (start_a[i, 0] - start_b[j, 0], start_a[i, 1] - start_b[j, 1],
                      start_a[i, 2] - start_b[j, 2])
        s, t = _closest_on_segments(d1x * d1x + d1y * d1y + d1z * d1z, d1x * d2x + d1y * d2y + d1z * d2z,
                                    d1x * rx + d1y * ry + d1z * rz, d2x * d2x + d2y * d2y + d2z * d2z,
                                    d2x * rx + d2y * ry + d2z * rz)
        out[n, 0], out[n, 1] = s, t
    return out


@njit(cache=True)
def _solve_pivoting(matrix, rhs):
    """matrix^-1 rhs (S x S by S x R) by Gaussian elimination with partial pivoting, as LAPACK's
    getrf/getrs order it (written out: numba's np.linalg.solve takes seconds to compile)."""
    size = matrix.shape[0]
    a = matrix.copy()
    b = rhs.copy()
    for col in range(size):
        pivot = col
        for row in range(col + 1, size):
            if abs(a[row, col]) > abs(a[pivot, col]):
                pivot = row
        if pivot != col:
            for c in range(size):
                a[col, c], a[pivot, c] = a[pivot, c], a[col, c]
            for c in range(b.shape[1]):
                b[col, c], b[pivot, c] = b[pivot, c], b[col, c]
        for row in range(col + 1, size):
            factor = a[row, col] / a[col, col]
            for c in range(col + 1, size):
                a[row, c] -= factor * a[col, c]
            for c in range(b.shape[1]):
                b[row, c] -= factor * b[col, c]
    for row in range(size - 1, -1, -1):
        for c in range(b.shape[1]):
            total = b[row, c]
            for k in range(row + 1, size):
                total -= a[row, k] * b[k, c]
            b[row, c] = total / a[row, row]
    return b


def _arrays(*arrays):
    """The arrays as writeable C-ordered float64 (copies only where needed): one compiled
    specialisation per kernel (numba compiles another for read-only or strided arrays)."""
    # flags.carray: C-contiguous, aligned and writeable in one test (this runs ~1e5 times a minute)
    return tuple([a if type(a) is np.ndarray and a.dtype is _FLOAT64 and a.flags.carray
                  else np.array(a, dtype=np.float64, order="C") for a in arrays])


def capsule_clearances(start_a, end_a, radius_a, start_b, end_b, radius_b) -> np.ndarray:
    """(Ka, Kb) clearance of every capsule pair of sets A and B: segment distance minus both radii."""
    return _capsule_clearances(*_arrays(start_a, end_a, radius_a, start_b, end_b, radius_b))


def pair_closest_parameters(start_a, end_a, start_b, end_b, index_a, index_b) -> np.ndarray:
    """(N, 2) closest-point parameters (s, t) of the segment pairs (index_a, index_b) of sets A
    (Ka, 3) and B (Kb, 3) (`motion.geometry.segment_segment_closest` is the reference)."""
    index_a = np.ascontiguousarray(index_a, dtype=np.int64)
    index_b = np.ascontiguousarray(index_b, dtype=np.int64)
    return _pair_closest_parameters(*_arrays(start_a, end_a, start_b, end_b), index_a, index_b)


class _FirstRunNotice(event.Listener):
    """Says on stderr, once per process and group, that a group's kernels compile. numba starts a
    "numba:compile" event only when a kernel has no compiled form in memory or in the disk
    cache, so nothing is said when the cache has the group. A kernel compiled inside another's
    compilation (a callee of another group) is part of the caller's; other numba code is left out."""

    def __init__(self):
        self._depth = 0
        self._told: set[str] = set()
        self._descriptions = dict(GROUPS.values())

    def on_start(self, ev):
        self._depth += 1
        if self._depth > 1:
            return
        dispatcher = (ev.data or {}).get("dispatcher")
        module = getattr(getattr(dispatcher, "py_func", None), "__module__", None)
        description = self._descriptions.get(module)
        if description is None or module in self._told:
            return
        self._told.add(module)
        print(f"compiling kernels for {description} (first run only) ...", file=sys.stderr, flush=True)

    def on_end(self, ev):
        self._depth -= 1


_NOTICE = _FirstRunNotice()
event.register("numba:compile", _NOTICE)


def _file_stamp(path: str) -> bytes:
    """The SHA-256 of a file's source (numba 0.68 stamps a cached kernel with its own file's so):
    a checkout that leaves the text alone keeps the cache."""
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).digest()


def register_group(namespace: dict, *dependencies) -> None:
    """Called at the end of a group's module with its `globals()`: stamps the disk cache of every
    kernel there also with the files of `dependencies`, the modules whose kernels it calls or
    inlines (numba stamps a cached kernel with its own file's only, and would keep the old code
    of a callee edited in another file)."""
    from numba.core.dispatcher import Dispatcher

    module = namespace.get("__name__")
    if module not in dict(GROUPS.values()):
        raise ValueError(f"{module} is not a group of hrc_drake.kernels.GROUPS")
    extra = tuple(_file_stamp(m.__file__) for m in dependencies)
    if not extra:
        return
    for value in namespace.values():
        if isinstance(value, Dispatcher) and getattr(value.py_func, "__module__", None) == module:
            try:
                cache_file = value._cache._cache_file
            except AttributeError:  # no disk cache, or another numba's layout: its own stamp only
                continue
            cache_file._source_stamp = (cache_file._source_stamp, *extra)


def _warm_up_steps() -> list:
    """Calls that compile (or load) every kernel here on tiny inputs, each on its own (`warm_up`)."""
    one, index = np.zeros((1, 3)), np.zeros(1, dtype=np.int64)
    return [lambda: capsule_clearances(one, one + 1.0, np.ones(1), one, one + 1.0, np.ones(1)),
            lambda: pair_closest_parameters(one, one + 1.0, one, one + 1.0, index, index),
            lambda: _solve_pivoting(np.eye(2), np.ones((2, 1)))]


def _warm_up_calls(groups) -> list[tuple[str, object]]:
    """(key "<group>.<k>", call) of every warm-up call of `groups`, in order."""
    return [(f"{name}.{k}", step) for name in groups
            for k, step in enumerate(importlib.import_module(GROUPS[name][0])._warm_up_steps())]


def warm_up(groups=None, start: float = 0.0, claims: str | None = None) -> float:
    """Compile (or load from the disk cache) every kernel of `groups` (names of `GROUPS`; all by
    default) and return the seconds it took. A cell needs none of this (each kernel compiles
    when first called): it is for the tests, the benchmarks and `compile_ahead`, whose processes
    go round the same calls from different `start`s (a fraction of the way through them) and
    make only the calls they claim first in the folder `claims` (one empty file per call)."""
    started = time.perf_counter()
    steps = _warm_up_calls(GROUPS if groups is None else groups)
    first = int(start * len(steps)) % max(len(steps), 1)
    for key, step in steps[first:] + steps[:first]:
        if claims is not None:
            try:
                os.close(os.open(os.path.join(claims, key), os.O_CREAT | os.O_EXCL | os.O_WRONLY))
            except FileExistsError:  # another process compiles it
                continue
        step()
    return time.perf_counter() - started


def _group_kernels(name: str) -> list:
    """The numba dispatchers a group's module defines (not those it imports from another) that
    compile on their own: an inline="always" one only ever compiles into its callers."""
    from numba.core.dispatcher import Dispatcher

    module_name = GROUPS[name][0]
    module = importlib.import_module(module_name)
    return [value for value in vars(module).values()
            if isinstance(value, Dispatcher) and getattr(value.py_func, "__module__", None) == module_name
            and value.targetoptions.get("inline") != "always"]


def uncached_groups(groups) -> list[str]:
    """The names of `groups` with a kernel that has no up-to-date compiled form in numba's disk
    cache (its index is missing, or stamped with another source or numba), in the given order.
    A group whose kernels have no disk cache at all is left out: compiling it elsewhere would
    not help."""
    unknown = [name for name in groups if name not in GROUPS]
    if unknown:
        raise ValueError(f"unknown kernel group(s) {unknown}: the groups are {sorted(GROUPS)}")
    out = []
    for name in groups:
        for kernel in _group_kernels(name):
            cache_file = getattr(getattr(kernel, "_cache", None), "_cache_file", None)
            load_index = getattr(cache_file, "_load_index", None)
            if load_index is None:  # numba's NullCache (no cache=True), or another numba's layout
                continue
            if not load_index():
                out.append(name)
                break
    return out


#: the most background processes `compile_ahead` starts by default: each holds up to ~300 MB
#: while it compiles (all groups in one process: 308 MB peak), and the longest call (~1.5 s)
#: bounds the time however many there are
MAX_AHEAD_PROCESSES = 4

# Run by each background process of `compile_ahead`: argv = start, claims folder, groups.
_AHEAD_CODE = ("import sys; from hrc_drake import kernels; "
               "kernels.warm_up(sys.argv[3:], float(sys.argv[1]), sys.argv[2])")


class KernelsAhead:
    """The background processes of `compile_ahead`. `wait()` before the first kernel runs;
    `stop()` (or leaving a `with` block) ends those still running."""

    def __init__(self, groups: list[str] = (), processes: list[tuple[subprocess.Popen, object]] = (),
                 claims: tempfile.TemporaryDirectory | None = None):
        self.groups = list(groups)  # the groups compiling in the background
        self._processes = list(processes)
        self._claims = claims

    def wait(self) -> float:
        """Wait for every process; return the seconds waited. What a process that failed left
        undone compiles when first used (as without `compile_ahead`), and stderr says so."""
        started = time.perf_counter()
        for process, log in self._processes:
            code = process.wait()
            if code != 0:
                log.seek(0)
                lines = log.read().decode(errors="replace").strip().splitlines()
                why = f": {lines[-1]}" if lines else ""
                print(f"a process compiling kernels ahead failed (exit {code}{why}); what it left undone "
                      "compiles when first used", file=sys.stderr, flush=True)
                _NOTICE._told.difference_update(GROUPS[name][0] for name in self.groups)
        self._close()
        return time.perf_counter() - started

    def stop(self) -> None:
        """End the processes still running (the caller failed or was interrupted)."""
        for process, _ in self._processes:
            if process.poll() is None:
                process.kill()
                process.wait()
        self._close()

    def _close(self) -> None:
        for _, log in self._processes:
            log.close()
        self._processes = []
        if self._claims is not None:
            self._claims.cleanup()
            self._claims = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()


def compile_ahead(groups, processes: int | None = None) -> KernelsAhead:
    """Compile the kernel groups of `groups` that the disk cache lacks (`uncached_groups`) in
    background processes while the caller goes on building a cell; after `wait()` its kernels
    load from the cache instead of compiling one after another on first use. The `processes`
    (default: the CPU count, at most `MAX_AHEAD_PROCESSES`; never more than there are calls) go
    round all the groups' `warm_up` calls from starts spread evenly, each making the calls no
    other has claimed. Says so once on stderr. Changes no result: a kernel compiled here is the
    one the caller would compile."""
    todo = uncached_groups(list(groups))
    if not todo:
        return KernelsAhead()
    count = min(max(1, processes or min(os.cpu_count() or 1, MAX_AHEAD_PROCESSES)), len(_warm_up_calls(todo)))
    claims = tempfile.TemporaryDirectory(prefix="hrc_drake_kernels_")
    # the children import this very package, wherever the caller found it
    package_root = str(Path(__file__).resolve().parent.parent)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [package_root, *filter(None, [os.environ.get("PYTHONPATH")])]))
    started = []
    for k in range(count):
        log = tempfile.TemporaryFile()
        process = subprocess.Popen([sys.executable, "-c", _AHEAD_CODE, repr(k / count), claims.name, *todo],
                                   env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=log)
        started.append((process, log))
    descriptions = ", ".join(GROUPS[name][1] for name in todo)
    print(f"compiling kernels for {descriptions} (first run only, {count} background "
          f"process{'es' if count > 1 else ''}) ...", file=sys.stderr, flush=True)
    _NOTICE._told.update(GROUPS[name][0] for name in todo)
    return KernelsAhead(todo, started, claims)
