"""The allocator tuning: freed numpy temporaries stay in the process (no page fault per tick)."""

from __future__ import annotations

import ctypes.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

# Five 100 kB blocks from malloc, written, freed, 300 times; prints the tuning's result and the
# minor page faults of the loop. Untuned glibc trims the freed heap top (> 128 KiB) every round and
# faults the pages in again on the next one: ~20 000 faults.
CHURN = r"""
import ctypes, ctypes.util, resource
from hrc_drake.allocator import keep_freed_memory
tuned = keep_freed_memory()
libc = ctypes.CDLL(ctypes.util.find_library("c"))
libc.malloc.restype = ctypes.c_void_p
libc.free.argtypes = [ctypes.c_void_p]
size = 100_000
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(300):
    blocks = [libc.malloc(size) for _ in range(5)]
    for block in blocks:
        ctypes.memset(block, 1, size)
    for block in reversed(blocks):
        libc.free(block)
print(tuned, resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""

pytestmark = pytest.mark.skipif(
    not sys.platform.startswith("linux") or ctypes.util.find_library("c") is None,
    reason="the tuning applies to glibc only",
)


def _churn(opt_out: bool) -> tuple[str, int]:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    env.pop("HRC_DRAKE_MALLOC_TUNING", None)
    if opt_out:
        env["HRC_DRAKE_MALLOC_TUNING"] = "0"
    out = subprocess.run([sys.executable, "-c", CHURN], env=env, capture_output=True, text=True, check=True)
    tuned, faults = out.stdout.split()
    return tuned, int(faults)


def test_tuned_allocator_keeps_freed_blocks():
    tuned, faults = _churn(opt_out=False)
    assert tuned == "True"
    assert faults < 2000, f"{faults} page faults for 300 rounds of 5 x 100 kB"


def test_opt_out_leaves_glibc_default_which_faults_every_round():
    tuned, faults = _churn(opt_out=True)
    assert tuned == "False"
    assert faults > 10_000, f"only {faults} page faults: untuned glibc no longer trims the heap"
