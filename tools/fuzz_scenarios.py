"""Fuzz the scenario and campaign checks with three families of mutants (`tests/cell/fuzz.py`),
all of them or a seeded sample of each:
- leaf: every mutation of every leaf of every file in diagrams/ (type, sign, NaN, huge, empty,
  unknown name), run as `hrc-drake validate` and, where validate accepts it, as a 2 s
  `hrc-drake simulate`. It passes when validate refuses it with a clean message (exit 2,
  "error: ..."), or when validate and simulate both accept it (exit 0);
- alias: an alias bomb ("billion laughs") as each top-level field and as the deepest leaf of
  each scenario, and a self-referring alias, run as `hrc-drake validate`;
- campaign: bad seeds, run counts past the limit, unknown scenarios, wrong types, bad variants,
  alias bombs as the spec and in a variant override, in each file of diagrams/campaigns/, run as
  `hrc-drake campaign SPEC --out TMP --workers 0`.
Alias and campaign mutants pass only when refused cleanly within QUICK_TIMEOUT_S. A mutant fails
on a traceback, an internal error (exit 1), a timeout, or a simulate that refuses what validate
accepted. The suite runs 30 leaf mutants (tests/cell/test_fuzz.py); this script runs as many as
asked, in parallel worker processes (each mutant in its own process, so a Drake abort is caught).

Prints a progress line every 5 %, the failures with their messages, then as its last line one
JSON object: mutants, refused, accepted, failed, seconds, families (family -> mutants), and
failures (label -> message).

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

from tests.cell.fuzz import alias_sites, campaign_mutants, mutant_text, mutation_sites  # noqa: E402

TIMEOUT_S = 300
#: an alias or campaign mutant is refused while loading: it has this long (s), even on a busy machine
QUICK_TIMEOUT_S = 30


def _command(*args, timeout: float = TIMEOUT_S) -> tuple[int, str]:
    """Exit code and output of `hrc-drake args` in its own process (-9 for a timeout)."""
    try:
        proc = subprocess.run([sys.executable, "-m", "hrc_drake.cli", *args], capture_output=True, text=True,
                              timeout=timeout, cwd=ROOT)
    except subprocess.TimeoutExpired:
        return -9, f"timed out after {timeout} s"
    return proc.returncode, proc.stdout + proc.stderr


def _refused(code: int, text: str) -> tuple[str, str]:
    """("refused", "") for a clean refusal (exit 2, "error: ..."), else ("failed", why)."""
    if code == 2 and "error: " in text and "Traceback" not in text:
        return "refused", ""
    return "failed", f"not refused cleanly: exit {code}: {text.strip()[-400:]}"


def check_alias_mutant(path: Path, where: tuple, new, mutant: Path) -> tuple[str, str]:
    """("refused" | "failed", message) of one alias mutant, written to `mutant`."""
    mutant.write_text(mutant_text(path, where, new))
    return _refused(*_command("validate", str(mutant), timeout=QUICK_TIMEOUT_S))


def check_campaign_mutant(text: str, mutant: Path) -> tuple[str, str]:
    """("refused" | "failed", message) of one campaign mutant, written to `mutant`."""
    mutant.write_text(text)
    out = mutant.with_suffix(".out")
    return _refused(*_command("campaign", str(mutant), "--out", str(out), "--workers", "0",
                              timeout=QUICK_TIMEOUT_S))


def check_mutant(path: Path, where: tuple, new, mutant: Path) -> tuple[str, str]:
    """("refused" | "accepted" | "failed", message) of one leaf mutant, written to `mutant`."""
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
    parser.add_argument("--sample", type=int, default=None,
                        help="mutants to draw of each family (default: all)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the sample")
    parser.add_argument("--workers", type=int, default=2, help="mutants checked at once")
    parser.add_argument("--only", default=None, help="only this file of diagrams/, e.g. pcb_ic.yaml")
    args = parser.parse_args(argv)
    paths = sorted((ROOT / "diagrams").glob(args.only or "*.yaml"))
    if not paths:
        parser.error(f"no scenario matches {args.only!r} in diagrams/")
    specs = [] if args.only else sorted((ROOT / "diagrams" / "campaigns").glob("*.yaml"))
    families = {  # family -> [(label, check, its arguments but the mutant's file)]
        "leaf": [(label, check_mutant, (path, where, new))
                 for path in paths for label, where, new in mutation_sites(path)],
        "alias": [(label, check_alias_mutant, (path, where, new))
                  for path in paths for label, where, new in alias_sites(path)],
        "campaign": [(label, check_campaign_mutant, (text,)) for spec in specs
                     for label, text in campaign_mutants(spec)],
    }
    rng = random.Random(args.seed)
    for family, mutants in families.items():
        if args.sample is not None and args.sample < len(mutants):
            families[family] = rng.sample(mutants, args.sample)
    sites = [mutant for mutants in families.values() for mutant in mutants]
    counts = {"refused": 0, "accepted": 0, "failed": 0}
    failures = {}
    start = time.perf_counter()
    print(f"{len(sites)} mutants ({', '.join(f'{len(m)} {f}' for f, m in families.items())}) of {len(paths)} "
          f"scenarios, {args.workers} workers", flush=True)
    with tempfile.TemporaryDirectory() as tmp, ThreadPoolExecutor(args.workers) as pool:
        # each mutant its own file: two mutations of one leaf may run at once
        futures = [(label, pool.submit(check, *arguments, Path(tmp) / f"{k}_mutant.yaml"))
                   for k, (label, check, arguments) in enumerate(sites)]
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
              "families": {family: len(mutants) for family, mutants in families.items()},
              "failures": failures}
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    sys.exit(1 if main()["failed"] else 0)
