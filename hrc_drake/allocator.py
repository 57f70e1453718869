"""Keep freed heap memory in the process during a simulation (glibc only).

A cell's ticks allocate many numpy temporaries of 0.1-1 MB (GP kernels, particle clouds, swept
volumes). glibc serves blocks above its mmap threshold (128 KiB at start) with a fresh mmap and
trims the heap top above 128 KiB, so every such temporary is page-faulted in again on every
tick. glibc raises the threshold by itself only after it frees a large mmapped block, which
depends on what was imported before: measured here, a process spent either ~17 k or ~1.7 M page
faults (5 s of kernel time against 3.4 s of user time) on the same 12 k GP kernel evaluations,
depending on its start-up. Fixing the thresholds makes every run take the fast path.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os

#: mallopt parameters (malloc.h)
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
#: glibc's largest dynamic mmap threshold on 64-bit systems (4 MiB * sizeof(long))
MMAP_THRESHOLD_BYTES = 32 << 20
TRIM_THRESHOLD_BYTES = 64 << 20
#: set to "0" to leave the allocator as it is (to measure the difference)
OPT_OUT_VARIABLE = "HRC_DRAKE_MALLOC_TUNING"

_tuned: bool | None = None


def keep_freed_memory() -> bool:
    """Raise glibc's mmap and trim thresholds once per process; True when they are set.

    Does nothing (False) off glibc, or when the environment sets HRC_DRAKE_MALLOC_TUNING=0.
    Costs at most TRIM_THRESHOLD_BYTES of freed memory kept by the process.
    """
    global _tuned
    if _tuned is not None:
        return _tuned
    _tuned = False
    if os.environ.get(OPT_OUT_VARIABLE, "1") == "0":
        return _tuned
    name = ctypes.util.find_library("c")
    if name is None:
        return _tuned
    try:
        libc = ctypes.CDLL(name)
    except OSError:
        return _tuned
    if not hasattr(libc, "gnu_get_libc_version"):  # glibc only: mallopt's parameters differ elsewhere
        return _tuned
    _tuned = bool(libc.mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)) and bool(
        libc.mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES)
    )
    return _tuned
