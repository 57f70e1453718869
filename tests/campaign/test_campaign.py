"""Campaigns (issue #16): the spec's checks, the rows of a sequential in-process run against a
real `LocalCluster` of 2 processes and against `dask scheduler` + 2 `dask worker` processes,
resume after an interruption, a worker that dies, and the statistics."""

from __future__ import annotations

import io
import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from hrc_drake.campaign import analysis, extras, store
from hrc_drake.campaign.engine import run_campaign
from hrc_drake.campaign.spec import load_campaign, make_campaign, scenario_metric_names
from hrc_drake.campaign.worker import TEST_KILL_VARIABLE, TIMING_COLUMNS
from hrc_drake.cell.scenario import Tagged
from hrc_drake.cli import EXIT_BAD_INPUT, EXIT_INTERRUPTED, main
from hrc_drake.errors import ScenarioError
from tests.conftest import DIAGRAMS, REPO

TORCH = DIAGRAMS / "torch_clock.yaml"
SPEC = f"""
name: small
duration: 15
seeds: [1, 2]
scenarios: [{TORCH}]
variants:
  rr: {{scheduler: !RoundRobinScheduler {{wait_quantum: 5.0}}}}
  none: {{}}
metrics: [mean_time_between_products, agents.*.idle_time, min_human_robot_distance, safety.time_below_s]
expect: {{better: rr, than: none, metrics: [agents.human.idle_time]}}
replays: [{{variant: none, seed: 1}}]
"""


def _spec(tmp_path: Path, text: str = SPEC, name: str = "spec.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _comparable(rows: pd.DataFrame) -> pd.DataFrame:
    """The rows without the columns that differ between identical runs (timing, worker)."""
    rows = rows.drop(columns=[c for c in TIMING_COLUMNS if c in rows.columns])
    return rows.sort_values(["scenario", "variant", "seed"]).reset_index(drop=True)


@pytest.fixture(scope="module")
def sequential(tmp_path_factory):
    """The small campaign run in this process through the command line: (its folder, its rows)."""
    tmp = tmp_path_factory.mktemp("sequential")
    out = tmp / "out"
    assert main(["campaign", str(_spec(tmp)), "--out", str(out), "--workers", "0"]) == 0
    return out, pd.read_parquet(out / "runs.parquet")


def test_the_command_writes_rows_summary_tests_plots_and_the_replay(sequential, capsys):
    out, rows = sequential
    assert len(rows) == 4 and set(rows["status"]) == {"ok"}
    assert set(zip(rows["variant"], rows["seed"], strict=True)) == {
        ("rr", 1),
        ("rr", 2),
        ("none", 1),
        ("none", 2),
    }
    assert (rows["duration"] == 15.0).all() and (rows["simulated_time"] == 15.0).all()
    assert {"agents.human.idle_time", "safety.time_below_s", "worker", "run_wall_time", "error"} <= set(rows)
    summary = pd.read_csv(out / "summary.csv")
    assert {"median", "iqr", "mean", "ci95_low", "ci95_high"} <= set(summary)
    assert set(summary["variant"]) == {"rr", "none"}
    idle = summary[(summary["variant"] == "rr") & (summary["metric"] == "agents.human.idle_time")].iloc[0]
    values = rows[rows["variant"] == "rr"]["agents.human.idle_time"]
    assert idle["median"] == pytest.approx(values.median(), rel=1e-5)
    tests = pd.read_csv(out / "tests.csv")
    claimed = tests[(tests["metric"] == "agents.human.idle_time") & (tests["test"] == "wilcoxon_signed_rank")]
    # a = none, b = rr; rr is expected to idle the human less: none greater
    assert claimed.iloc[0]["alternative"] == "greater" and claimed.iloc[0]["claim"] == "rr better than none"
    for stem in ("agents_human_idle_time", "agents_yumi_left_idle_time", "min_human_robot_distance"):
        assert (out / f"box_{stem}.png").stat().st_size > 1000
        assert (out / f"ecdf_{stem}.png").stat().st_size > 1000
    # no product in 15 s: no time between products to draw
    assert not (out / "box_mean_time_between_products.png").exists()
    assert (out / "replays" / "torch_clock__none__1.html").stat().st_size > 100_000
    assert json.loads((out / "campaign.json").read_text())["name"] == "small"


def test_a_local_cluster_of_two_processes_gives_the_sequential_rows(sequential, tmp_path):
    _, expected = sequential
    progress = io.StringIO()
    outcome = run_campaign(load_campaign(_spec(tmp_path)), tmp_path / "out", workers=2, progress=progress)
    rows = pd.read_parquet(tmp_path / "out" / "runs.parquet")
    assert outcome.ran == 4 and outcome.failed == 0
    # bokeh is a dependency: the LocalCluster serves its dashboard on a free port, and says where
    assert outcome.dashboard.startswith("http://") and outcome.dashboard.endswith("/status")
    assert f"Dask dashboard: {outcome.dashboard}" in progress.getvalue()
    assert rows["worker"].str.startswith("tcp://127.0.0.1:").all()
    pd.testing.assert_frame_equal(_comparable(rows), _comparable(expected))


def test_an_interrupted_campaign_keeps_its_rows_and_resumes(sequential, tmp_path):
    _, expected = sequential
    campaign = load_campaign(_spec(tmp_path))
    out = tmp_path / "out"

    class StopAfterTwoRuns:
        """A progress stream that presses Ctrl-C when the second run is reported."""

        def write(self, text):
            if " 2/4 done" in text:
                raise KeyboardInterrupt

        def flush(self):
            pass

    with pytest.raises(KeyboardInterrupt):
        run_campaign(campaign, out, workers=0, progress=StopAfterTwoRuns())
    kept = pd.read_parquet(out / "runs.parquet")
    assert len(kept) == 2 and not (out / "summary.csv").exists()
    outcome = run_campaign(campaign, out, workers=0, progress=None)
    assert (outcome.skipped, outcome.ran) == (2, 2)
    pd.testing.assert_frame_equal(_comparable(pd.read_parquet(out / "runs.parquet")), _comparable(expected))
    again = run_campaign(campaign, out, workers=0, progress=None)
    assert (again.skipped, again.ran) == (4, 0)
    # a changed variant is another configuration: refused, or its rows moved aside with new_spec
    changed = _spec(tmp_path, SPEC.replace("wait_quantum: 5.0", "wait_quantum: 4.0"))
    with pytest.raises(ScenarioError, match="overrides of torch_clock/rr changed"):
        run_campaign(load_campaign(changed), out, workers=0, progress=None)
    assert run_campaign(load_campaign(changed), out, workers=0, progress=None, new_spec=True).ran == 4


def test_a_worker_that_dies_is_retried_once_then_its_run_is_failed(sequential, tmp_path, monkeypatch):
    _, expected = sequential
    marker = tmp_path / "killed-once"
    # rr/2 kills its worker on every attempt; none/2 only on its first (the retry succeeds)
    monkeypatch.setenv(TEST_KILL_VARIABLE, f"rr/2,none/2@{marker}")
    spec = _spec(tmp_path, SPEC.replace("replays: [{variant: none, seed: 1}]", ""))
    outcome = run_campaign(load_campaign(spec), tmp_path / "out", workers=2, progress=None)
    rows = pd.read_parquet(tmp_path / "out" / "runs.parquet").set_index(["variant", "seed"])
    assert marker.exists() and (outcome.ran, outcome.failed) == (4, 1)
    assert rows.loc[("rr", 2), "status"] == "failed" and "KilledWorker" in rows.loc[("rr", 2), "error"]
    ok = rows[rows["status"] == "ok"].reset_index()
    good = expected[~((expected["variant"] == "rr") & (expected["seed"] == 2))]
    columns = sorted(ok.columns.drop(list(TIMING_COLUMNS)))
    # the failed row made the integer columns float: compare values
    pd.testing.assert_frame_equal(_comparable(ok)[columns], _comparable(good)[columns], check_dtype=False)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.slow
def test_a_dask_scheduler_and_two_worker_processes_give_the_sequential_rows(sequential, tmp_path, capsys):
    _, expected = sequential
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    dask = [sys.executable, "-m", "dask"]  # the `dask` command of the environment
    processes = [
        subprocess.Popen(
            [*dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--dashboard-address", ":0"],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    ]
    try:
        for _ in range(2):
            processes.append(
                subprocess.Popen(
                    [*dask, "worker", address, "--nthreads", "1", "--no-dashboard"],
                    env=env,
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                )
            )
        out = tmp_path / "out"
        assert main(["campaign", str(_spec(tmp_path)), "--out", str(out), "--address", address]) == 0
        assert "Dask dashboard: http://" in capsys.readouterr().err  # the scheduler's, on a free port
        rows = pd.read_parquet(out / "runs.parquet")
        assert rows["worker"].str.startswith("tcp://127.0.0.1:").all()
        pd.testing.assert_frame_equal(_comparable(rows), _comparable(expected))
    finally:
        for process in processes:
            process.terminate()
        for process in processes:
            process.wait(timeout=30)


def test_an_unreachable_address_is_a_clear_error_not_a_hang(tmp_path):
    command = [
        sys.executable,
        "-m",
        "hrc_drake.cli",
        "campaign",
        str(_spec(tmp_path)),
        "--out",
        str(tmp_path / "out"),
        "--address",
        f"tcp://127.0.0.1:{_free_port()}",
    ]
    start = time.monotonic()
    done = subprocess.run(command, capture_output=True, text=True, timeout=120, cwd=REPO)
    assert done.returncode == EXIT_BAD_INPUT, done.stderr
    assert "--address" in done.stderr and "no Dask scheduler answers" in done.stderr, done.stderr
    assert not (tmp_path / "out" / "runs.parquet").exists()
    print(f"refused in {time.monotonic() - start:.1f} s")


@pytest.mark.parametrize(
    "change, field, reason",
    [
        (("scenarios: [", "scenarios: [nowhere.yaml, "), "scenarios[0]", "no such scenario file"),
        (("none: {}", "none: {schedulr: !RoundRobinScheduler {}}"), "variants.none.schedulr", "unknown"),
        (
            ("none: {}", "none: {scheduler: !FuzzyScheduler {horizon: -1}}"),
            "variants.none.scheduler.horizon",
            "must be in",
        ),
        (("none: {}", "none: {scheduler: !NoSuchScheduler {}}"), "variants.none.scheduler", "unknown kind"),
        (("agents.*.idle_time", "agents.*.idle_tim"), "metrics[1]", "unknown metric"),
        # a name metrics.json had before issue 54 is told its new one
        (("metrics: [mean_time_between_products", "metrics: [mean_cycle_time"), "metrics[0]",
         "'mean_cycle_time' was renamed mean_time_between_products"),
        (("metrics: [mean_time_between_products", "metrics: [products.*.mean_cycle_time"), "metrics[0]",
         "was renamed products.*.mean_time_between"),
        (("seeds: [1, 2]", "seeds: []"), "seeds", "empty"),
        (("seeds: [1, 2]", "seeds: [1, 2, 1]"), "seeds[2]", "listed twice"),
        (("seeds: [1, 2]", "seeds: {count: 0}"), "seeds.count", "must be an integer"),
        (("better: rr", "better: fuzzy"), "expect[0].better", "unknown variant"),
        (
            ("replays: [{variant: none, seed: 1}]", "replays: [{variant: none, seed: 9}]"),
            "replays[0].seed",
            "not one of",
        ),
        (("duration: 15", "duration: -1"), "duration", "must be a number"),
        (("name: small", "name: small\ncolour: red"), "colour", "unknown key"),
        (("name: small", "name: small\nextra_metrics: [nope]"), "extra_metrics[0]", "unknown extra metrics"),
        (("name: small", "name: small\nextra_metrics: [os:nope]"), "extra_metrics[0]", "cannot import"),
        (("name: small", "name: small\npooled: [{metric: per_product.operator_wait}]"), "pooled[0].metric",
         "not a column of the campaign's extra_metrics"),
        (("name: small",
          "name: small\nextra_metrics: [per_product]\npooled: [{metric: per_product.times, first: -1}]"),
         "pooled[0].first", "integer >= 0"),
    ],
)
def test_a_bad_spec_names_the_file_the_field_and_the_reason(tmp_path, capsys, change, field, reason):
    spec = _spec(tmp_path, SPEC.replace(*change))
    with pytest.raises(ScenarioError) as err:
        load_campaign(spec)
    assert err.value.file == str(spec) and err.value.field == field and reason in err.value.reason, str(
        err.value
    )
    assert main(["campaign", str(spec), "--out", str(tmp_path / "out"), "--workers", "0"]) == EXIT_BAD_INPUT
    assert field in capsys.readouterr().err
    assert not (tmp_path / "out" / "runs.parquet").exists()


def test_an_unusable_out_folder_is_refused_before_any_run(tmp_path, capsys, monkeypatch):
    spec = _spec(tmp_path)
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    for out in (a_file, a_file / "below"):
        assert main(["campaign", str(spec), "--out", str(out), "--workers", "0"]) == EXIT_BAD_INPUT
        assert "--out" in capsys.readouterr().err

    class FullDisk:
        free = 1_000_000

    monkeypatch.setattr(store.shutil, "disk_usage", lambda path: FullDisk())
    assert main(["campaign", str(spec), "--out", str(tmp_path / "out"), "--workers", "0"]) == EXIT_BAD_INPUT
    assert "the disk is full" in capsys.readouterr().err
    assert not (tmp_path / "out" / "runs.parquet").exists()


def test_the_metric_names_of_a_scenario_are_the_scalars_of_its_rows(sequential):
    _, rows = sequential
    from hrc_drake.cell.scenario import load_scenario

    named = set(scenario_metric_names(load_scenario(TORCH)))
    reported = {c for c in rows.columns if c not in (*store.KEY_COLUMNS, *store.RUN_COLUMNS)}
    assert named == reported


def test_compare_redraws_one_campaign_and_compares_two(sequential, tmp_path, capsys):
    out, _ = sequential
    assert main(["compare", str(out), "--out", str(tmp_path / "one")]) == 0
    assert (tmp_path / "one" / "ecdf_agents_human_idle_time.png").is_file()
    assert main(["compare", str(out), str(out), "--out", str(tmp_path / "two")]) == 0
    summary = pd.read_csv(tmp_path / "two" / "summary.csv")
    assert set(summary["variant"]) == {"small/rr", "small/none"}
    assert main(["compare", str(out), str(out)]) == EXIT_BAD_INPUT
    assert main(["compare", str(tmp_path)]) == EXIT_BAD_INPUT


def test_rank_biserial_effect_sizes_and_one_sided_alternatives():
    a, b = np.array([1.0, 2.0, 3.0, 4.0, 5.0]), np.array([2.0, 3.0, 4.0, 5.0, 7.0])
    assert analysis.matched_rank_biserial(a, b) == -1.0  # every difference a - b is negative
    assert analysis.matched_rank_biserial(b, a) == 1.0
    u, p, r = analysis.rank_sum_test(a, b, "less")
    assert u == pytest.approx(8.0) and r == pytest.approx(2 * 8.0 / 25 - 1) and p < 0.5
    claims = [
        {"better": "fuzzy", "than": "uniform",
         "metrics": ["mean_time_between_products", "min_human_robot_distance"]}
    ]
    assert analysis._alternative("fuzzy", "uniform", "mean_time_between_products", claims)[0] == "less"
    assert analysis._alternative("uniform", "fuzzy", "mean_time_between_products", claims)[0] == "greater"
    assert analysis._alternative("fuzzy", "uniform", "min_human_robot_distance", claims)[0] == "greater"
    assert analysis._alternative("fuzzy", "uniform", "safety.time_below_s", claims)[0] == "two-sided"
    values = np.random.default_rng(3).normal(10.0, 1.0, 40)
    low, high = analysis.bootstrap_ci(values, np.random.default_rng(0))
    assert low < values.mean() < high
    assert (low, high) == analysis.bootstrap_ci(values, np.random.default_rng(0))


def test_help_loads_no_dask_pandas_or_pyarrow():
    probe = (
        "import contextlib, io, sys\nfrom hrc_drake.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n    try: main(['--help'])\n"
        "    except SystemExit: pass\n"
        "print(sorted({m.split('.')[0] for m in sys.modules} & {'dask', 'distributed', 'pandas', 'pyarrow'}))"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, cwd=REPO, check=True)
    assert done.stdout.strip() == "[]"


def run_extent(result, scenario) -> dict:
    """An extra-metrics function found by its import path: a scalar and a list column."""
    return {"simulated": result.simulated_time, "seed_twice": [scenario.seed, 2 * scenario.seed]}


def test_per_product_samples_come_from_the_event_log():
    def event(time, seq, kind, agent="human"):
        return SimpleNamespace(time=time, seq=seq, kind=kind, agent=agent)

    events = [event(5, 0, "wait_begin"), event(12, 1, "wait_end"), event(0, 2, "wait_begin", "yumi_left"),
              event(20, 3, "wait_begin"), event(30, 4, "wait_end"), event(35, 5, "wait_begin")]
    result = SimpleNamespace(metrics={"product_times": [10.0, 25.0]}, log=SimpleNamespace(events=events),
                             simulated_time=40.0)
    values = extras.per_product(result, SimpleNamespace(operator=SimpleNamespace(name="human")))
    assert values == {"times": [10.0, 25.0], "cycle_times": [15.0], "operator_wait": [5.0, 7.0],
                      "operator_wait_after_last": 10.0}


def test_extra_metrics_from_the_python_api_are_columns_of_the_rows(tmp_path):
    document = {
        "name": "extras",
        "duration": 15,
        "seeds": [3],
        "scenarios": [str(TORCH)],
        "variants": {"rr": {"scheduler": Tagged("RoundRobinScheduler", {"wait_quantum": 5.0})}},
        "extra_metrics": ["per_product", "tests.campaign.test_campaign:run_extent"],
    }
    campaign = make_campaign(document, tmp_path / "extras.campaign")
    outcome = run_campaign(campaign, tmp_path / "out", workers=0, progress=None)  # with the analysis
    row = pd.read_parquet(tmp_path / "out" / "runs.parquet").iloc[0]
    assert row["status"] == "ok", row["error"]
    assert row["run_extent.simulated"] == 15.0 and list(row["run_extent.seed_twice"]) == [3.0, 6.0]
    assert list(row["per_product.times"]) == [] and row["per_product.operator_wait_after_last"] >= 0.0
    assert outcome.rows["per_product.times"].map(len).tolist() == [0]
    summary = pd.read_csv(tmp_path / "out" / "summary.csv")
    assert "per_product.times" not in set(summary["metric"])  # list columns are kept, not analysed
    # the rows read back (lists as arrays) are written again, and the run counts as done
    again = run_campaign(campaign, tmp_path / "out", workers=0, progress=None, analyze=False)
    assert (again.skipped, again.ran) == (1, 0)
    document["extra_metrics"] = ["per_product"]  # other columns asked: another configuration
    with pytest.raises(ScenarioError, match="another campaign configuration"):
        run_campaign(make_campaign(document, tmp_path / "extras.campaign"), tmp_path / "out", workers=0,
                     progress=None, analyze=False)
    changed = run_campaign(make_campaign(document, tmp_path / "extras.campaign"), tmp_path / "out",
                           workers=0, progress=None, analyze=False, new_spec=True)
    assert (changed.skipped, changed.ran) == (0, 1)


def test_plot_labels_carry_the_unit_the_metric_name_tells():
    assert analysis.metric_label("mean_time_between_products") == "mean_time_between_products (s)"
    assert analysis.metric_label("agents.human.idle_time") == "agents.human.idle_time (s)"
    assert analysis.metric_label("safety.time_below_s") == "safety.time_below_s (s)"
    assert analysis.metric_label("min_human_robot_distance") == "min_human_robot_distance (m)"
    assert analysis.metric_label("safety.fraction_below") == "safety.fraction_below"
    assert analysis.metric_label("products_finished") == "products_finished"


def _worker_processes(parent: int) -> list[int]:
    """The Dask worker processes (multiprocessing spawns) among the children of `parent` (Linux /proc)."""
    found = []
    for status in Path("/proc").glob("[0-9]*/status"):
        try:
            fields = dict(line.split(":\t", 1) for line in status.read_text().splitlines() if ":\t" in line)
            command = (status.parent / "cmdline").read_bytes()
        except OSError:
            continue
        if fields.get("PPid", "").strip() == str(parent) and b"spawn_main" in command:
            found.append(int(status.parent.name))
    return found


def _ignored_signals(pid: int) -> int:
    """The SigIgn mask of process `pid` (Linux /proc)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("SigIgn:"):
            return int(line.split()[1], 16)
    raise AssertionError(f"no SigIgn line for process {pid}")


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads worker signal masks from /proc")
def test_ctrl_c_on_a_local_cluster_prints_one_line_and_no_dask_traceback(tmp_path):
    import signal

    long_runs = SPEC.replace("duration: 15", "duration: 600").replace("seeds: [1, 2]", "seeds: [1, 2, 3]")
    spec = _spec(tmp_path, long_runs)
    command = [sys.executable, "-m", "hrc_drake.cli", "campaign", str(spec), "--out", str(tmp_path / "out"),
               "--workers", "2"]
    # its own process group, which gets the signal as a terminal's Ctrl-C does (workers included);
    # SIGINT handled as at a terminal also when this test runs in the background of a shell
    # without job control (which starts it with SIGINT ignored, and Python keeps that)
    proc = subprocess.Popen(command, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    sigint = 1 << (signal.SIGINT - 1)

    def quiet_workers() -> list[int]:
        """The workers, once both exist and ignore SIGINT (bit 2 of SigIgn: the plugin the
        campaign registers after warming them up, just before it submits the runs); else []."""
        workers = _worker_processes(proc.pid)
        try:
            ready = len(workers) == 2 and all(_ignored_signals(pid) & sigint for pid in workers)
        except (OSError, AssertionError):  # a worker that is still starting, or restarting
            ready = False
        return workers if ready else []

    try:
        # wait for the state the test is about, however slow the machine (a bound only against
        # a hang: the test asserts what it sees, not how long it took)
        deadline = time.monotonic() + 300
        workers = quiet_workers()
        while not workers and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.5)
            workers = quiet_workers()
        # whether a worker would print its traceback otherwise depends on when the main process
        # closes it: both ignore SIGINT before it is sent
        assert len(workers) == 2, f"the 2 workers never came up ignoring SIGINT (exit {proc.poll()})"
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == EXIT_INTERRUPTED, err
    assert "interrupted before any run finished: nothing was saved" in err
    assert "Traceback" not in err and "ERROR" not in err, err


def test_a_local_campaign_compiles_its_cells_kernel_groups_ahead_once_before_its_runs(tmp_path, monkeypatch):
    from hrc_drake.campaign import engine
    from tests.conftest import record_compile_ahead

    spec = SPEC.replace("duration: 15", "duration: 1").replace("seeds: [1, 2]", "seeds: [1]").replace(
        "replays: [{variant: none, seed: 1}]\n", "").replace(
        "none: {}", "none: {}\n  pf: {tracker: !ParticleFilterTracker {particles: 50}}")
    campaign = load_campaign(_spec(tmp_path, spec))
    # the union over scenarios and variants, in the order first met
    assert campaign.kernel_groups == ["geometry", "human", "safety", "perception"]
    calls = record_compile_ahead(monkeypatch)
    real_run_task = engine.run_task

    def run_task(task):
        calls.append("run")
        return real_run_task(task)

    monkeypatch.setattr(engine, "run_task", run_task)
    assert run_campaign(campaign, tmp_path / "out", workers=0, progress=None, analyze=False).ran == 3
    assert calls == [campaign.kernel_groups, "wait", "run", "run", "run"]
    calls.clear()
    assert run_campaign(campaign, tmp_path / "out", workers=0, progress=None, analyze=False).ran == 0
    assert calls == []  # nothing left to run: nothing compiled ahead
    # the workers of a scheduler elsewhere have caches of their own
    assert engine.compile_kernels_ahead(["safety"], "tcp://elsewhere:8786").groups == []
