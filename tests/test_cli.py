"""The command line: bad arguments are refused before anything is built, output paths are
checked before the run, Ctrl-C writes what was simulated, an internal error is one line."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from hrc_drake.cli import EXIT_BAD_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED, main
from hrc_drake.config_common import replay_fps_within
from tests.conftest import DIAGRAMS

TORCH = str(DIAGRAMS / "torch_clock.yaml")


@pytest.mark.parametrize("option, value", [
    ("--duration", "nan"), ("--duration", "inf"), ("--duration", "-1"), ("--duration", "0"),
    ("--duration", "1e9"), ("--duration", "ten"),
    ("--replay-fps", "0"), ("--replay-fps", "-1"), ("--replay-fps", "nan"), ("--replay-fps", "1e6"),
    ("--seed", "-1"), ("--seed", "1.5"), ("--seed", str(2**32)),
    ("--realtime-rate", "-1"), ("--realtime-rate", "nan"), ("--realtime-rate", "inf"),
    ("--replay-max-frames", "0"), ("--replay-max-frames", "1e3"), ("--replay-max-frames", "10000000"),
])
def test_bad_arguments_are_refused_with_the_option_named(option, value, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["simulate", TORCH, option, value])
    assert exit_.value.code == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert option in err and "must be" in err and "Traceback" not in err


def test_the_replay_rate_is_lowered_to_the_frame_budget():
    assert replay_fps_within(10.0, 600.0) == 10.0  # the default budget: 10 min at 10 fps
    assert replay_fps_within(10.0, 7200.0) == pytest.approx(6000 / 7200)
    assert replay_fps_within(30.0, 60.0, max_frames=600) == 10.0
    with pytest.raises(ValueError):
        replay_fps_within(10.0, 0.0)


def test_a_long_replay_records_fewer_frames_and_says_so(tmp_path, capfd):
    replay = tmp_path / "replay.html"
    args = ["simulate", TORCH, "--duration", "2", "--replay", str(replay), "--replay-max-frames", "10"]
    assert main(args) == 0
    captured = capfd.readouterr()
    out = captured.out
    assert "would exceed 10 frames" in out and "recording 5 fps" in out
    assert replay.stat().st_size > 1e6
    # a replay-only run serves nothing a person could open: no Meshcat server line
    assert "listening for connections" not in out + captured.err and "http://" not in out
    html = replay.read_text()
    assert 'id="hrc-clock"' in html and 'id="hrc-legend"' in html and "torch_clock" in html


def test_an_out_path_that_is_a_file_is_refused_before_the_run(tmp_path, capsys):
    blocker = tmp_path / "taken"
    blocker.write_text("x")
    assert main(["simulate", TORCH, "--duration", "1", "--out", str(blocker)]) == EXIT_BAD_INPUT
    captured = capsys.readouterr()
    assert "--out" in captured.err and "not a folder" in captured.err
    assert "Building" not in captured.out  # refused before the cell was built


def test_a_replay_path_that_is_a_folder_is_refused_before_the_run(tmp_path, capsys):
    assert main(["simulate", TORCH, "--duration", "1", "--replay", str(tmp_path)]) == EXIT_BAD_INPUT
    captured = capsys.readouterr()
    assert "--replay" in captured.err and "folder" in captured.err and "Building" not in captured.out


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes everywhere")
def test_an_unwritable_out_folder_is_refused(tmp_path, capsys):
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    assert main(["simulate", TORCH, "--duration", "1", "--out", str(locked / "run")]) == EXIT_BAD_INPUT


def test_a_bad_scenario_seed_or_duration_is_refused_by_validate(tmp_path):
    text = (DIAGRAMS / "torch_clock.yaml").read_text()
    for bad in ("seed: -1", "duration: .nan", "duration: .inf"):
        field = bad.split(":")[0]
        lines = [bad if line.startswith(field + ":") else line for line in text.splitlines()]
        path = tmp_path / f"{field}.yaml"
        path.write_text("\n".join(lines) + "\n")
        assert main(["validate", str(path)]) == EXIT_BAD_INPUT, bad


def test_an_internal_error_is_one_line_with_the_log_of_its_traceback(monkeypatch, capsys):
    import hrc_drake.cell.scenario as scenario

    def broken(*args, **kwargs):
        raise RuntimeError("boom")

    monkeypatch.setattr(scenario, "load_scenario", broken)
    assert main(["validate", TORCH]) == EXIT_INTERNAL
    err = capsys.readouterr().err.strip()
    assert err.startswith("internal error: RuntimeError: boom") and len(err.splitlines()) == 1
    log = err.rsplit("traceback in ", 1)[1].rstrip(")")
    assert "Traceback" in open(log).read()
    os.unlink(log)


@pytest.mark.slow
def test_ctrl_c_stops_the_run_and_writes_what_it_has(tmp_path):
    """SIGINT during a long run: exit 130, a note, and the report over the time simulated."""
    out = tmp_path / "run"
    # the child takes SIGINT as a terminal would, also when this test runs in the background of
    # a shell without job control (which starts it with SIGINT ignored, and Python keeps that)
    proc = subprocess.Popen([sys.executable, "-m", "hrc_drake.cli", "simulate", TORCH, "--duration", "100000",
                             "--out", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert proc.stdout.readline().startswith("Building")
    assert proc.stdout.readline().startswith("Simulating")  # built: SIGINT lands in the run
    time.sleep(3.0)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == EXIT_INTERRUPTED, stderr
    assert "interrupted at t = " in stderr and "Traceback" not in stderr
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["interrupted"] is True and 0 < metrics["simulated_time"] < 100000
    assert (out / "events.csv").stat().st_size > 0 and (out / "gantt.png").exists()


def test_deeply_nested_or_huge_files_are_refused_cleanly(tmp_path, capsys):
    deep = tmp_path / "deep.yaml"
    deep.write_text("seed: " + "[" * 20000 + "]" * 20000 + "\n")
    huge = tmp_path / "huge.yaml"
    huge.write_text("seed: 1\n" + "#" * 3_000_000 + "\n")
    assert main(["validate", str(deep)]) == EXIT_BAD_INPUT
    assert "nested too deeply" in capsys.readouterr().err
    assert main(["validate", str(huge)]) == EXIT_BAD_INPUT
    assert "too large" in capsys.readouterr().err


@pytest.mark.parametrize("edit, field", [
    (lambda t: t.replace("name: bench,", "name: station_A,").replace(" bench,", " station_A,"),
     "layout.goals[0].name"),
    (lambda t: t.replace("program: [R1, R3, R2, R4]", "program: [R1, R3, R2]"), "flow.actions[10].agents"),
    (lambda t: t.replace("agent: yumi_left,", "agent: yumi_right,"), "robots[0].arms[1].agent"),
])
def test_name_collisions_and_actions_no_program_runs_are_refused(edit, field, tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text(edit((DIAGRAMS / "torch_clock.yaml").read_text()))
    assert main(["validate", str(path)]) == EXIT_BAD_INPUT
    assert field in capsys.readouterr().err


@pytest.mark.parametrize("edit, field", [
    (lambda t: t.replace("size: [1.1, 1.5, 0.04]", "size: [-1.1, 1.5, 0.04]"), "layout.table.size"),
    (lambda t: t.replace("height: 0.75}", "height: .nan}"), "layout.table"),
    (lambda t: t.replace("target: [0.75, 0.0, 0.8]", "target: [0.3, 0.0, 2.2]"), "layout.camera.target"),
])
def test_a_table_or_camera_drake_cannot_build_is_refused_by_validate(edit, field, tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    text = (DIAGRAMS / "pcb_ic.yaml").read_text()
    assert edit(text) != text
    path.write_text(edit(text))
    assert main(["validate", str(path)]) == EXIT_BAD_INPUT
    assert field in capsys.readouterr().err


def _with_recorded(tmp_path, csv_bytes: bytes) -> str:
    from hrc_drake.cell.scenario import _raw_document, dump_raw  # tag-aware (the cells' !Hybrid)

    (tmp_path / "skeleton.csv").write_bytes(csv_bytes)
    raw = _raw_document((DIAGRAMS / "torch_clock.yaml").read_text())
    raw["operator"]["recorded"] = "skeleton.csv"
    path = tmp_path / "cell.yaml"
    path.write_text(dump_raw(raw))
    return str(path)


def _good_csv(tmp_path) -> bytes:
    import numpy as np

    from hrc_drake.human.recorded import save_skeleton_csv

    points = np.tile(np.linspace(0.1, 0.8, 24).reshape(8, 3), (5, 1, 1))
    save_skeleton_csv(tmp_path / "good.csv", np.arange(5) / 30.0, points)
    return (tmp_path / "good.csv").read_bytes()


@pytest.mark.parametrize("damage, reason", [
    (lambda b: b.replace(b"time,", b"tme,", 1), "bad header"),
    (lambda b: b.rsplit(b"\n", 2)[0] + b"\n0.01" + b",0.5" * 24 + b",1" * 8 + b"\n", "does not increase"),
    (lambda b: b.replace(b",1,1,1,1,1,1,1,1\r\n", b",1,1,1,1,1,1,1,2\r\n", 1), "must be 0 or 1"),
    (lambda b: b.replace(b"0.1,", b"x,", 1), "is not a number"),
    (lambda b: b.replace(b"0.1,", b"inf,", 1), "tracked but has a NaN or inf"),
    (lambda b: b.split(b"\n")[0] + b"\n", "no data rows"),
    (lambda b: b"\xff\xfe" + b.decode().encode("utf-16-le"), "not UTF-8"),
    (lambda b: b.replace(b"0.1,", b"0.1\x00,", 1), "is not a number"),
])
def test_validate_opens_the_recorded_skeleton_and_names_what_is_wrong(damage, reason, tmp_path, capsys):
    good = _good_csv(tmp_path)
    assert main(["validate", _with_recorded(tmp_path, good)]) == 0
    capsys.readouterr()
    assert main(["validate", _with_recorded(tmp_path, damage(good))]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "operator.recorded" in err and "skeleton.csv" in err and reason in err, err


@pytest.mark.parametrize("damage, reason", [
    (lambda d: "[1, 2]", "top level must be an object"),
    (lambda d: d.replace('"gmm2d"', '"gmm2"'), "'gmm2d' must be an object"),
    (lambda d: d[: len(d) // 2], "not valid JSON"),
    (lambda d: d.replace('"window": 8', '"window": -3'), "window must be in"),
    (lambda d: d.replace('"evidence_weight": 0.18', '"evidence_weight": 7'), "evidence_weight"),
    (lambda d: d.replace('"weights": [', '"weights": [-5, ', 1), "GaussianMixtureDensity"),
])
def test_validate_opens_the_intention_model_and_names_what_is_wrong(damage, reason, tmp_path, capsys):
    from hrc_drake.intention.likelihood import DEFAULT_MODEL_PATH

    text = DEFAULT_MODEL_PATH.read_text()
    assert damage(text) != text
    (tmp_path / "model.json").write_text(damage(text))
    scenario = (DIAGRAMS / "box_usb.yaml").read_text().replace(
        "intention: !GmmBayesIntention {", "intention: !GmmBayesIntention {model: model.json, ")
    (tmp_path / "cell.yaml").write_text(scenario)
    assert main(["validate", str(tmp_path / "cell.yaml")]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "intention.model" in err and reason in err, err


@pytest.mark.parametrize("where, value, field", [
    (("operator", "actions", 0, "duration", "mean"), 1e12, "operator.actions[0].duration.mean"),
    (("operator", "segments"), {"upper_arm": 100.0}, "operator.segments.upper_arm"),
    (("layout", "camera", "noise_std"), 1e6, "layout.camera.noise_std"),
    (("layout", "goals", 0, "center", 0), 1e12, "layout.goals[0].center[0]"),
    (("layout", "goals", 0, "radius"), 50.0, "layout.goals[0].radius"),
    (("layout", "buffers", 0, "capacity"), 10**12, "layout.buffers[0].capacity"),
    (("robots", 0, "mode"), "dynamic", None),  # with the next edit: a time step that runs forever
    (("robots", 0, "base", "rpy"), [0.0, 0.0, 1e6], "robots[0].base.rpy[2]"),
    (("robots", 0, "actions", 0, "dwell"), 1e5, "robots[0].actions[0].dwell"),
    (("flow", "actions", 0, "duration"), {"kind": "fixed", "mean": 1e12}, "flow.actions[0].duration.mean"),
    (("safety_distance",), -0.1, "safety_distance"),
    (("metrics",), {"warmup_products": -1}, "metrics.warmup_products"),
])
def test_implausible_physical_quantities_are_refused_with_their_range(where, value, field, tmp_path, capsys):
    from tests.cell.fuzz import mutant_text

    path = tmp_path / "bad.yaml"
    path.write_text(mutant_text(DIAGRAMS / "torch_clock.yaml", where, value))
    if field is None:  # a dynamic plant is fine at its time step, not at 1e-7 s
        assert main(["validate", str(path)]) == 0
        path.write_text(mutant_text(path, ("robots", 0, "time_step"), 1e-7))
        field = "robots[0].time_step"
    capsys.readouterr()
    assert main(["validate", str(path)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert field in err and ("implausible" in err or "must be in" in err), err


@pytest.mark.parametrize("fields, field", [
    ({"collaboration": "H1"}, "scheduler.collaboration"),  # the human's alone: no robot to commit
    ({"collaboration": "no_such_action"}, "scheduler.collaboration"),
    ({"collaboration": "H1", "human_action": "H2"}, "scheduler.feed_action"),  # case 1 needs both
])
def test_a_best_scenario_scheduler_must_name_a_collaboration(fields, field, tmp_path, capsys):
    from hrc_drake.cell.scenario import Tagged
    from tests.cell.fuzz import mutant_text

    path = tmp_path / "bad.yaml"
    path.write_text(mutant_text(DIAGRAMS / "torch_clock.yaml", ("scheduler",), Tagged("BestScenarioScheduler",
                                                                                     fields)))
    assert main(["validate", str(path)]) == EXIT_BAD_INPUT
    assert field in capsys.readouterr().err


VERDICT_WORDS = ("SAFE:", "UNSAFE:", "NO SAFETY SYSTEM:", "NON-CONFORMING:")


def test_the_summary_states_the_verdict_first_and_the_closest_approach(tmp_path, capsys):
    """pcb_collab's collaboration brings the human and the arms together: the summary opens with the
    judge's verdict (before the run's figures) and gives the closest true approach; the time under
    the scenario's safety distance stays in metrics.json, no longer on the console."""
    out_dir = tmp_path / "out"
    assert main(["simulate", str(DIAGRAMS / "pcb_collab.yaml"), "--duration", "40", "--out",
                 str(out_dir)]) == 0
    lines = capsys.readouterr().out.splitlines()
    metrics = json.loads((out_dir / "metrics.json").read_text())
    safety = metrics["safety"]
    # the verdict, then the throughput (issue 54: throughput first), later the simulated time
    figures = next(i for i, ln in enumerate(lines) if ln.startswith("products per hour"))
    assert lines[figures - 1] == safety["verdict"] == metrics["verdict"]
    assert figures < next(i for i, ln in enumerate(lines) if ln.startswith("simulated time"))
    assert safety["verdict"].startswith(VERDICT_WORDS)
    # pcb_collab's PFL mode is conforming: the verdict is the standard judge's count
    total = safety["violations_total"]
    assert total == sum(safety["violations"].values())
    assert safety["verdict_code"] == ("unsafe" if total else "safe")
    assert safety["verdict"].startswith("UNSAFE:" if total else "SAFE:")
    assert (f"{total} violation" if total else "0 violations") in safety["verdict"]
    line = next(ln for ln in lines if ln.startswith("closest approach"))
    assert f"{metrics['min_human_robot_distance']:.3f} m" in line
    assert not any("safety distance" in ln for ln in lines)
    assert safety["below"] and 0 < safety["time_below_s"] < 40


def test_version_prints_the_package_version(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.startswith("hrc_drake 0.")


def test_the_bare_command_prints_its_help_not_an_error(capsys):
    assert main([]) == EXIT_BAD_INPUT  # a usage error, as argparse's, but with the whole help
    captured = capsys.readouterr()
    assert "usage: hrc-drake" in captured.out and "error" not in captured.out + captured.err
    for command in ("simulate", "validate", "campaign", "import", "compare", "--version"):
        assert command in captured.out


def test_every_argument_of_every_command_has_help():
    import argparse

    from hrc_drake.cli import build_parser

    parser = build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    missing = []
    for name, command in [("hrc-drake", parser), *commands.choices.items()]:
        for action in command._actions:
            if not isinstance(action, argparse._SubParsersAction) and not action.help:
                missing.append(f"{name} {action.dest}")
    assert not missing, missing
    assert {c.dest for c in commands._choices_actions} == set(commands.choices)  # each command has help
    assert all(c.help for c in commands._choices_actions)


@pytest.mark.parametrize("command", ["simulate", "validate"])
def test_a_campaign_spec_given_for_a_scenario_gets_a_hint_naming_campaign(command, capsys):
    spec = str(DIAGRAMS / "campaigns" / "trackers.yaml")
    assert main([command, spec]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.splitlines()
    assert "unknown key 'name'" in err[0]
    assert len(err) == 2 and err[1].startswith("hint:") and f"hrc-drake campaign {spec} --out" in err[1]


@pytest.mark.parametrize("command", ["simulate", "validate"])
def test_a_search_spec_given_for_a_scenario_gets_a_hint_naming_search(command, capsys):
    spec = str(DIAGRAMS / "searches" / "optimise_pcb_ic.yaml")
    assert main([command, spec]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2 and err[1].startswith("hint:") and f"hrc-drake search {spec} --out" in err[1]


def test_a_scenario_given_to_campaign_gets_a_hint_naming_simulate(tmp_path, capsys):
    assert main(["campaign", TORCH, "--out", str(tmp_path / "out")]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2 and err[1].startswith("hint:") and f"hrc-drake simulate {TORCH}" in err[1]
    assert not (tmp_path / "out").exists()


def test_a_real_unknown_key_gets_no_hint(tmp_path, capsys):
    path = tmp_path / "typo.yaml"
    path.write_text((DIAGRAMS / "torch_clock.yaml").read_text().replace("seed:", "sead:", 1))
    assert main(["validate", str(path)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "unknown key 'sead'" in err and "hint" not in err


def test_a_shipped_example_is_found_by_its_bare_name(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # not the repository: the name is not a path here
    assert main(["validate", "torch_clock"]) == 0
    out = capsys.readouterr().out
    assert "torch_clock.yaml: OK" in out
    assert main(["validate", "no_such_cell"]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "no_such_cell: no such file" in err and "torch_clock" in err and "pcb_collab" in err
    # a path is a path: no example is looked up for something that names a file
    assert main(["validate", "torch_clock.yaml"]) == EXIT_BAD_INPUT
    assert "no such file" in capsys.readouterr().err
    (tmp_path / "torch_clock").write_text("seed: 1\nsead: 2\n")  # a file of that name wins
    assert main(["validate", "torch_clock"]) == EXIT_BAD_INPUT
    assert "unknown key 'sead'" in capsys.readouterr().err


def test_simulate_lists_the_files_it_wrote(tmp_path, capsys):
    out_dir = tmp_path / "out"
    assert main(["simulate", TORCH, "--duration", "2", "--out", str(out_dir)]) == 0
    lines = capsys.readouterr().out.splitlines()
    at = lines.index("files written (4):")
    listed = [line.strip() for line in lines[at + 1:]]
    names = ("metrics.json", "events.csv", "gantt.png", "safety.png")
    assert listed == [str(out_dir / name) for name in names]
    assert all((out_dir / name).is_file() for name in names)


def test_campaign_limit_runs_a_few_and_a_later_run_resumes_the_rest(tmp_path, capsys):
    import pandas as pd

    spec = tmp_path / "spec.yaml"
    spec.write_text(f"name: few\nduration: 2\nseeds: [1, 2, 3]\nscenarios: [{TORCH}]\n"
                    "variants: {base: {}}\nmetrics: [mean_speed_override]\n")
    out = tmp_path / "out"
    assert main(["campaign", str(spec), "--out", str(out), "--workers", "0", "--limit", "2"]) == 0
    text = capsys.readouterr().out
    assert "--limit 2: at most 2" in text and "1 run(s) of 3 not run yet" in text
    assert sorted(pd.read_parquet(out / "runs.parquet")["seed"]) == [1, 2]
    assert f"  {out / 'runs.parquet'}" in text.splitlines() and "files written" in text
    assert main(["campaign", str(spec), "--out", str(out), "--workers", "0"]) == 0
    text = capsys.readouterr().out
    assert "1 run(s) now (0 failed), 2 done before" in text and "not run yet" not in text
    assert sorted(pd.read_parquet(out / "runs.parquet")["seed"]) == [1, 2, 3]


def test_campaign_limit_gives_each_variant_two_seeds_and_leaves_no_lock(tmp_path, capsys):
    """Issue 54, item 6: `--limit` takes two seeds of each scenario x variant at a time (a test
    needs two of each side); a limit too small for that says why tests were skipped and how to
    get them; the folder keeps no campaign.lock, and the lock is never listed as a result."""
    import pandas as pd

    spec = tmp_path / "spec.yaml"
    spec.write_text(f"name: pairs\nduration: 1\nseeds: [1, 2, 3]\nscenarios: [{TORCH}]\n"
                    "variants: {base: {}, kalman: {tracker: !KalmanTracker {}}}\n"
                    "metrics: [mean_speed_override, agents.human.busy_time]\n")
    out = tmp_path / "out"
    assert main(["campaign", str(spec), "--out", str(out), "--workers", "0", "--limit", "3"]) == 0
    text = capsys.readouterr().out
    runs = pd.read_parquet(out / "runs.parquet")
    made = sorted(zip(runs["variant"], runs["seed"], strict=True))
    assert made == [("base", 1), ("base", 2), ("kalman", 1)]
    assert "--limit 4 gives every one two seeds" in text
    assert "skipped for want of seeds" in text and "--limit 4 gives every scenario x variant two" in text
    assert not (out / "campaign.lock").exists() and "campaign.lock" not in text
    assert main(["campaign", str(spec), "--out", str(out), "--workers", "0", "--limit", "1"]) == 0
    text = capsys.readouterr().out
    runs = pd.read_parquet(out / "runs.parquet")
    assert sorted(runs.loc[runs["variant"] == "kalman", "seed"]) == [1, 2]
    tests = pd.read_csv(out / "tests.csv")
    assert not tests["note"].fillna("").str.contains("one sample").any()
    assert "skipped for want of seeds" not in text and not (out / "campaign.lock").exists()


def test_the_limit_order_takes_two_seeds_of_each_configuration_at_a_time(tmp_path):
    from hrc_drake.campaign.spec import load_campaign

    spec = tmp_path / "spec.yaml"
    spec.write_text(f"name: order\nduration: 1\nseeds: [5, 6, 7]\nscenarios: [{TORCH}]\n"
                    "variants: {a: {}, b: {tracker: !KalmanTracker {}}}\nmetrics: [mean_speed_override]\n")
    campaign = load_campaign(spec)
    pairs = [(t.variant, t.seed) for t in campaign.iter_tasks_in_pairs()]
    assert pairs == [("a", 5), ("a", 6), ("b", 5), ("b", 6), ("a", 7), ("b", 7)]
    assert sorted(pairs) == sorted((t.variant, t.seed) for t in campaign.iter_tasks())


def test_simulate_compiles_the_cell_s_kernel_groups_ahead_and_waits_before_the_run(monkeypatch, capsys):
    from hrc_drake.cell import run
    from tests.conftest import record_compile_ahead

    calls = record_compile_ahead(monkeypatch)
    real_simulate = run.simulate

    def simulate(*args, **kwargs):
        calls.append("simulate")
        return real_simulate(*args, **kwargs)

    monkeypatch.setattr(run, "simulate", simulate)
    assert main(["simulate", TORCH, "--duration", "1"]) == 0
    assert calls == [["geometry", "human", "safety"], "wait", "simulate"]
