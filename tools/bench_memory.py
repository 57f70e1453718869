"""Benchmark: peak memory of a long run against a short one (issue 17: bounded long runs).

Runs `hrc-drake simulate SCENARIO --duration D --out DIR` (and, with --replay, also writing a
replay) in a fresh process for each duration, and reads that process's peak resident set size
(`resource.getrusage(RUSAGE_SELF).ru_maxrss` at exit: import, build, simulation, report and
replay included). Memory is flat in simulated time when the long run's peak is within a few
percent of the short one's.

Prints one line per run, then as its last line one JSON object with, per duration D (s):
`peak_rss_mb_<D>`, `peak_rss_mb_replay_<D>`, `replay_mb_<D>` (the HTML file), `wall_s_<D>`, and
`peak_change_percent` / `peak_change_percent_replay` = 100 * (longest / shortest - 1).

Usage:
    PYTHONPATH=. python3 tools/bench_memory.py [--scenario diagrams/torch_clock.yaml]
                                               [--durations 600 7200] [--no-replay] [--smoke]
A 2 h torch_clock run takes ~40 s on a 2-core machine (~200x real time), ~80 s with a replay.
--smoke: one duration of 1 s (with its replay run): the whole path in ~10 s, figures meaningless.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_CHILD = """
import json, resource, sys
from hrc_drake.cli import main
code = main(sys.argv[1:])
print(json.dumps({"code": code, "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def measure(scenario: str, duration: float, replay: Path | None, out: Path) -> dict:
    """Peak RSS (MB), wall time and replay size of one `simulate` in its own process."""
    args = ["simulate", scenario, "--duration", f"{duration:g}", "--out", str(out)]
    if replay is not None:
        args += ["--replay", str(replay)]
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", _CHILD, *args], capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        raise SystemExit(f"simulate failed ({proc.returncode}): {proc.stderr[-800:]}")
    child = json.loads(proc.stdout.strip().splitlines()[-1])
    return {"peak_rss_mb": round(child["peak_rss_mb"], 1), "wall_s": round(wall, 1),
            "replay_mb": round(replay.stat().st_size / 1e6, 2) if replay is not None else None}


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="diagrams/torch_clock.yaml")
    parser.add_argument("--durations", type=float, nargs="+", default=[600.0, 7200.0])
    parser.add_argument("--no-replay", action="store_true", help="skip the runs that write a replay")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    args = parser.parse_args(argv)
    # one short duration: the shortest and the longest run are the same (a change of 0 %)
    durations = [1.0] if args.smoke else sorted(args.durations)
    result: dict = {"scenario": args.scenario}
    with tempfile.TemporaryDirectory() as tmp:
        for duration in durations:
            key = f"{duration:g}"
            plain = measure(args.scenario, duration, None, Path(tmp) / f"out{key}")
            result[f"peak_rss_mb_{key}"] = plain["peak_rss_mb"]
            result[f"wall_s_{key}"] = plain["wall_s"]
            print(f"{key:>7} s: peak {plain['peak_rss_mb']:7.1f} MB   wall {plain['wall_s']:6.1f} s",
                  flush=True)
            if not args.no_replay:
                replay = Path(tmp) / f"replay{key}.html"
                rep = measure(args.scenario, duration, replay, Path(tmp) / f"rout{key}")
                result[f"peak_rss_mb_replay_{key}"] = rep["peak_rss_mb"]
                result[f"replay_mb_{key}"] = rep["replay_mb"]
                print(f"{key:>7} s with replay: peak {rep['peak_rss_mb']:7.1f} MB   replay "
                      f"{rep['replay_mb']:6.2f} MB   wall {rep['wall_s']:6.1f} s", flush=True)
    short, long_ = f"{durations[0]:g}", f"{durations[-1]:g}"
    result["peak_change_percent"] = round(100 * (result[f"peak_rss_mb_{long_}"] /
                                                 result[f"peak_rss_mb_{short}"] - 1), 2)
    if not args.no_replay:
        result["peak_change_percent_replay"] = round(100 * (result[f"peak_rss_mb_replay_{long_}"] /
                                                            result[f"peak_rss_mb_replay_{short}"] - 1), 2)
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    main()
