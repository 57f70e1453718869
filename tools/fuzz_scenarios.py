"""Fuzz the scenario checks: every mutation of every leaf of every file in diagrams/ (type, sign,
NaN, huge, empty, unknown name; `tests/cell/fuzz.py`), or a seeded sample of them, each run as
`hrc-drake validate` and, where validate accepts it, as a 2 s `hrc-drake simulate`.

A mutant passes when validate refuses it with a clean message (exit 2, "error: ..."), or when
validate and simulate both accept it (exit 0). It fails on a traceback, an internal error
(exit 1), or a simulate that refuses what validate accepted. The suite runs 30 of them
(tests/cell/test_fuzz.py); this script runs as many as asked, in parallel worker processes
(each mutant in its own process, so a Drake abort is caught too).

Prints a progress line every 5 %, the failures with their messages, then as its last line one
JSON object: mutants, refused, accepted, failed, seconds, and failures (label -> message).

Usage:
    PYTHONPATH=. python3 tools/fuzz_scenarios.py [--sample N] [--seed S] [--workers W] [--only FILE]
"""

from __future__ import annotations

import argparse
import json
import random
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.cell.fuzz import mutant_text, mutation_sites  # noqa: E402

TIMEOUT_S = 300


def _command(*args) -> tuple[int, str]:
    """Exit code and output of `hrc-drake args` in its own process (-9 for a timeout)."""
    try:
        proc = subprocess.run([sys.executable, "-m", "hrc_drake.cli", *args], capture_output=True, text=True,
                              timeout=TIMEOUT_S, cwd=ROOT)
    except subprocess.TimeoutExpired:
        return -9, f"timed out after {TIMEOUT_S} s"
    return proc.returncode, proc.stdout + proc.stderr


def check_mutant(path: Path, where: tuple, new, folder: Path) -> tuple[str, str]:
    """("refused" | "accepted" | "failed", message) of one mutant."""
    mutant = folder / f"{'_'.join(map(str, where))}_{path.name}"
    mutant.write_text(mutant_text(path, where, new))
    code, text = _command("validate", str(mutant))
    if code == 2 and "error: " in text and "Traceback" not in text:
        return "refused", ""
    if code != 0 or "Traceback" in text:
        return "failed", f"validate exit {code}: {text.strip()[-400:]}"
    code, text = _command("simulate", str(mutant), "--duration", "2")
    if code != 0 or "Traceback" in text:
        return "failed", f"validate accepted it; simulate exit {code}: {text.strip()[-400:]}"
    return "accepted", ""


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sample", type=int, default=None, help="mutants to draw (default: all)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the sample")
    parser.add_argument("--workers", type=int, default=2, help="mutants checked at once")
    parser.add_argument("--only", default=None, help="only this file of diagrams/, e.g. pcb_ic.yaml")
    args = parser.parse_args(argv)
    paths = sorted((ROOT / "diagrams").glob(args.only or "*.yaml"))
    if not paths:
        parser.error(f"no scenario matches {args.only!r} in diagrams/")
    sites = [(path, site) for path in paths for site in mutation_sites(path)]
    if args.sample is not None and args.sample < len(sites):
        sites = random.Random(args.seed).sample(sites, args.sample)
    counts = {"refused": 0, "accepted": 0, "failed": 0}
    failures = {}
    start = time.perf_counter()
    print(f"{len(sites)} mutants of {len(paths)} scenarios, {args.workers} workers", flush=True)
    with tempfile.TemporaryDirectory() as tmp, ThreadPoolExecutor(args.workers) as pool:
        futures = [(site[0], pool.submit(check_mutant, path, site[1], site[2], Path(tmp)))
                   for path, site in sites]
        step = max(1, len(futures) // 20)
        for k, (label, future) in enumerate(futures, start=1):
            outcome, message = future.result()
            counts[outcome] += 1
            if outcome == "failed":
                failures[label] = message
                print(f"FAILED {label}: {message}", flush=True)
            if k % step == 0 or k == len(futures):
                print(f"  {k}/{len(futures)}  refused {counts['refused']}  accepted {counts['accepted']}  "
                      f"failed {counts['failed']}  ({time.perf_counter() - start:.0f} s)", flush=True)
    result = {"mutants": len(sites), **counts, "seconds": round(time.perf_counter() - start, 1),
              "failures": failures}
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    sys.exit(1 if main()["failed"] else 0)
