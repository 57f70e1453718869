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
  `hrc-drake campaign SPEC --out TMP --workers 0`;
- import (issue 55): `hrc-drake import` with hostile file names (line breaks of every kind,
  controls, quotes), special files (/dev/zero, a FIFO, a folder, a link loop), a 40 MiB file,
  degenerate recordings (empty, garbage bytes, zeros, coincident shoulders, 1e308, NaN, wrong
  units), option values out of range and outputs landing on inputs (`tests/cell/fuzz_untrusted.py`).
  Clean: refused (exit 2, "error: ...", no file left behind) or written and loadable (a written
  scenario keeps its cell's safety mode); never an input changed, never a peak RSS over 1 GiB;
- text (issue 55): box_usb with its operator's name, an action's name or its description replaced
  by formulas, markup, mathtext, line breaks, path separators, run as a 2 s `hrc-drake simulate
  --out DIR`. Clean: refused, or every report file written and no name cell of events.csv that
  starts like a spreadsheet formula.
Alias and campaign mutants pass only when refused cleanly within QUICK_TIMEOUT_S. A mutant fails
on a traceback, an internal error (exit 1), a timeout, or a simulate that refuses what validate
accepted. The suite runs 30 leaf mutants (tests/cell/test_fuzz.py); this script runs as many as
asked, in parallel worker processes (each mutant in its own process, so a Drake abort is caught).

Prints a progress line every 5 %, the failures with their messages, then as its last line one
JSON object: mutants, refused, accepted, failed, seconds, families (family -> mutants), failures
(label -> message), and per family `<family>.cases`, `<family>.clean`; for import also
`import.peak_rss_mb` and `import.files_overwritten`.

Usage:
    PYTHONPATH=. python3 tools/fuzz_scenarios.py [--sample N] [--seed S] [--workers W] [--only FILE]
                                                 [--family leaf,alias,campaign,import,text]
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

from hrc_drake.untrusted import FORMULA_STARTS  # noqa: E402
from tests.cell.fuzz import alias_sites, campaign_mutants, mutant_text, mutation_sites  # noqa: E402
from tests.cell.fuzz_untrusted import import_cases, text_cases  # noqa: E402

FAMILIES = ("leaf", "alias", "campaign", "import", "text")
#: the most memory (RSS) an import may take on any input
MAX_IMPORT_RSS_MB = 1024.0
#: runs `hrc-drake ARGS` and writes its peak RSS (KiB) to $FUZZ_RSS_FILE
_MEASURED = """
import os, resource, sys
from hrc_drake.cli import main
try:
    code = main(sys.argv[1:])
except SystemExit as stop:
    code = stop.code
finally:
    with open(os.environ["FUZZ_RSS_FILE"], "w") as rss:
        rss.write(str(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss))
sys.exit(code)
"""
REPORT_FILES = ("metrics.json", "events.csv", "gantt.png", "safety.png")
#: the peak RSS (MB) of every import case run (appended by the checking threads)
_import_rss: list[float] = []

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


def _measured(args: list[str], rss_file: Path, timeout: float) -> tuple[int, str, float]:
    """Exit code, output and peak RSS (MB) of `hrc-drake args` in its own process."""
    import os

    env = {**os.environ, "FUZZ_RSS_FILE": str(rss_file)}
    try:
        proc = subprocess.run([sys.executable, "-c", _MEASURED, *args], capture_output=True, text=True,
                              timeout=timeout, cwd=ROOT, env=env, errors="replace")
    except subprocess.TimeoutExpired:
        return -9, f"timed out after {timeout} s", 0.0
    rss = float(rss_file.read_text()) / 1024.0 if rss_file.is_file() else 0.0
    return proc.returncode, proc.stdout + proc.stderr, rss


def _listing(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


def _digest(path: Path) -> bytes | None:
    import hashlib

    return hashlib.sha256(path.read_bytes()).digest() if path.is_file() and not path.is_symlink() else None


def check_import_case(setup, mutant: Path) -> tuple[str, str]:
    """("refused" | "accepted" | "failed", message) of one import case, in a folder of its own."""
    folder = mutant.with_suffix("")
    folder.mkdir()
    args, inputs = setup(folder)
    before = {path: _digest(path) for path in inputs}
    listing = _listing(folder)
    code, text, rss = _measured(["import", *args], mutant.with_suffix(".rss"), QUICK_TIMEOUT_S)
    _import_rss.append(rss)
    changed = [str(path) for path, digest in before.items() if digest is not None and _digest(path) != digest]
    if changed:
        return "failed", f"overwrote its input(s) {changed}: exit {code}: {text.strip()[-300:]}"
    if rss > MAX_IMPORT_RSS_MB:
        return "failed", f"peak RSS {rss:.0f} MB: exit {code}"
    if code == 2 and "error: " in text and "Traceback" not in text:
        left = sorted(_listing(folder) - listing)
        return ("failed", f"refused but left {left} behind") if left else ("refused", "")
    if code != 0 or "Traceback" in text:
        return "failed", f"exit {code}: {text.strip()[-400:]}"
    return _written_import_is_whole(args)


def _written_import_is_whole(args: list[str]) -> tuple[str, str]:
    """("accepted", "") when the skeleton written loads and a scenario written keeps its cell's
    safety mode; else ("failed", why)."""
    from hrc_drake.cell.scenario import load_scenario
    from hrc_drake.human.recorded import load_skeleton_csv

    out = Path(args[args.index("--out") + 1])
    try:
        load_skeleton_csv(out)
        if "--cell" in args:
            written = load_scenario(out.with_suffix(".yaml"))
            cell = load_scenario(args[args.index("--cell") + 1])
            if written.safety != cell.safety:
                return "failed", (f"the written scenario's safety is {written.safety!r}, its cell's "
                                  f"{cell.safety!r}")
    except Exception as err:  # noqa: BLE001 - any failure to load what was written is the finding
        return "failed", f"accepted, but what it wrote does not load: {err}"
    return "accepted", ""


def check_text_case(text: str, mutant: Path) -> tuple[str, str]:
    """("refused" | "accepted" | "failed", message) of one scenario with hostile names, simulated."""
    import csv

    mutant.write_text(text)
    out = mutant.with_suffix(".out")
    code, output = _command("simulate", str(mutant), "--duration", "2", "--out", str(out))
    if code == 2 and "error: " in output and "Traceback" not in output:
        return "refused", ""
    if code != 0 or "Traceback" in output:
        return "failed", f"exit {code}: {output.strip()[-400:]}"
    missing = [name for name in REPORT_FILES if not (out / name).is_file()]
    if missing:
        return "failed", f"accepted, but {missing} not written"
    with (out / "events.csv").open(newline="") as handle:
        for row in csv.DictReader(handle):
            for column in ("agent", "action", "kind", "detail"):
                if row[column].startswith(FORMULA_STARTS):
                    return "failed", f"events.csv {column} {row[column]!r} starts like a formula"
    return "accepted", ""


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
    parser.add_argument("--family", default=",".join(FAMILIES),
                        help=f"comma-separated families to run (default: all of {', '.join(FAMILIES)})")
    args = parser.parse_args(argv)
    chosen = [f.strip() for f in args.family.split(",") if f.strip()]
    unknown = [f for f in chosen if f not in FAMILIES]
    if unknown or not chosen:
        parser.error(f"--family: unknown {unknown or args.family!r}; the families: {', '.join(FAMILIES)}")
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
        "import": [(label, check_import_case, (setup,)) for label, setup in import_cases()],
        "text": [(label, check_text_case, (text,)) for label, text in text_cases()],
    }
    families = {family: mutants for family, mutants in families.items() if family in chosen}
    rng = random.Random(args.seed)
    for family, mutants in families.items():
        if args.sample is not None and args.sample < len(mutants):
            families[family] = rng.sample(mutants, args.sample)
    sites = [(family, *mutant) for family, mutants in families.items() for mutant in mutants]
    counts = {"refused": 0, "accepted": 0, "failed": 0}
    clean = dict.fromkeys(families, 0)
    failures = {}
    start = time.perf_counter()
    print(f"{len(sites)} mutants ({', '.join(f'{len(m)} {f}' for f, m in families.items())}) of {len(paths)} "
          f"scenarios, {args.workers} workers", flush=True)
    with tempfile.TemporaryDirectory() as tmp, ThreadPoolExecutor(args.workers) as pool:
        # each mutant its own file: two mutations of one leaf may run at once
        futures = [(family, label, pool.submit(check, *arguments, Path(tmp) / f"{k}_mutant.yaml"))
                   for k, (family, label, check, arguments) in enumerate(sites)]
        step = max(1, len(futures) // 20)
        for k, (family, label, future) in enumerate(futures, start=1):
            outcome, message = future.result()
            counts[outcome] += 1
            clean[family] += outcome != "failed"
            if outcome == "failed":
                failures[label] = message
                print(f"FAILED {label}: {message}", flush=True)
            if k % step == 0 or k == len(futures):
                print(f"  {k}/{len(futures)}  refused {counts['refused']}  accepted {counts['accepted']}  "
                      f"failed {counts['failed']}  ({time.perf_counter() - start:.0f} s)", flush=True)
    result = {"mutants": len(sites), **counts, "seconds": round(time.perf_counter() - start, 1),
              "families": {family: len(mutants) for family, mutants in families.items()},
              "failures": failures}
    for family, mutants in families.items():
        result[f"{family}.cases"], result[f"{family}.clean"] = len(mutants), clean[family]
    if "import" in families:
        result["import.files_overwritten"] = sum(m.startswith("overwrote") for m in failures.values())
        result["import.peak_rss_mb"] = round(max(_import_rss, default=0.0), 1)
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    sys.exit(1 if main()["failed"] else 0)
