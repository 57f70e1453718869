"""`hrc-drake import` treats its inputs as untrusted (issue 55, items 1 and 2): a recording's file
name cannot inject YAML into the scenario it writes, nothing it reads is overwritten, its outputs
never overwrite one another, and a refusal leaves no file behind."""

from __future__ import annotations

import pytest
import yaml

from hrc_drake.cell.scenario import load_scenario
from hrc_drake.cli import EXIT_BAD_INPUT, main
from hrc_drake.datasets import dataset_dir
from tests.conftest import DIAGRAMS

TRIAL = dataset_dir("lego_assembly_arm") / "Task2" / "Human1" / "trial1.txt"
CELL = DIAGRAMS / "box_pcb_coexistence.yaml"


def _recording(folder, name="rec.txt", lines=90):
    path = folder / name
    path.write_text("\n".join(TRIAL.read_text().splitlines()[:lines]) + "\n")
    return path


def _files(folder):
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*"))


# every line break YAML knows (1.1: NEL, LS and PS too), and CR alone, which the old comment let through
@pytest.mark.parametrize("line_break", ["\r", "\n", "\r\n", "\x85", "\u2028", "\u2029"])
def test_a_recording_s_file_name_cannot_inject_yaml_into_the_scenario(tmp_path, capsys, line_break):
    name = f"rec{line_break}safety: !NoSafety {{}}{line_break}duration: 1{line_break}#.txt"
    source = _recording(tmp_path, name)
    out = tmp_path / "out" / "rec.csv"
    assert main(["import", "lego", str(source), "--rate", "15", "--out", str(out), "--cell", str(CELL)]) == 0
    written = out.with_suffix(".yaml")
    scenario, cell = load_scenario(written), load_scenario(CELL)
    assert type(scenario.safety) is type(cell.safety) and scenario.safety == cell.safety
    assert scenario.duration > 1.0
    document = yaml.safe_load(written.read_text(encoding="utf-8"))
    assert set(document) == {"extends", "description", "duration", "operator"}
    # the name is still there for a reader, its breaks shown as escapes
    assert "safety: !NoSafety {}" in written.read_text(encoding="utf-8")


def test_free_text_in_the_written_scenario_goes_through_the_yaml_emitter(tmp_path, capsys):
    source = _recording(tmp_path)
    out = tmp_path / "weird: {a: !NoSafety x}'\"#.csv"
    assert main(["import", "lego", str(source), "--rate", "15", "--out", str(out), "--cell", str(CELL)]) == 0
    scenario = load_scenario(out.with_suffix(".yaml"))
    assert scenario.operator.recorded.endswith("weird: {a: !NoSafety x}'\"#.csv")
    assert scenario.description == ("Recorded operator (weird: {a: !NoSafety x}'\"#.csv) in "
                                    "box_pcb_coexistence")


def _refused(capsys, args, reason):
    assert main(["import", *args]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert reason in err, err


def test_the_skeleton_and_its_provenance_are_never_one_file(tmp_path, capsys):
    source = _recording(tmp_path)
    before = _files(tmp_path)
    _refused(capsys, ["lego", str(source), "--rate", "15", "--out", str(tmp_path / "o" / "same.json")],
             "same.json")
    assert _files(tmp_path) == before


def test_the_source_is_never_overwritten(tmp_path, capsys):
    source = _recording(tmp_path, "rec.csv")
    text = source.read_bytes()
    _refused(capsys, ["lego", str(source), "--rate", "15", "--out", str(source)], "the recording")
    assert source.read_bytes() == text and _files(tmp_path) == ["rec.csv"]
    # nor through another name for the same file
    link = tmp_path / "link.csv"
    link.symlink_to(source)
    _refused(capsys, ["lego", str(source), "--rate", "15", "--out", str(link)], "the recording")
    assert source.read_bytes() == text


def test_the_column_map_and_the_cell_are_never_overwritten(tmp_path, capsys):
    source = _recording(tmp_path)
    columns = tmp_path / "map3.yaml"
    columns.write_text("left_wrist: [0, 1, 2]\nright_wrist: [3, 4, 5]\n")
    column_text = columns.read_bytes()
    cell = tmp_path / "cellcopy.yaml"
    cell.write_text(f"extends: {CELL}\n")
    cell_text = cell.read_bytes()
    before = _files(tmp_path)
    _refused(capsys, ["table", str(source), "--rate", "15", "--columns", str(columns),
                      "--out", str(tmp_path / "map3.csv"), "--cell", str(cell)], "--columns")
    _refused(capsys, ["lego", str(source), "--rate", "15", "--out", str(tmp_path / "cellcopy.csv"),
                      "--cell", str(cell)], "--cell")
    _refused(capsys, ["lego", str(source), "--rate", "15", "--out", str(tmp_path / "r.csv"),
                      "--cell", str(cell), "--replay", str(cell)], "--replay")
    assert columns.read_bytes() == column_text and cell.read_bytes() == cell_text
    assert _files(tmp_path) == before


def test_a_refused_cell_leaves_nothing_behind(tmp_path, capsys):
    source = _recording(tmp_path)
    out = tmp_path / "new" / "deeper" / "rec.csv"
    # pcb_ic perceives the operator's actions: a recording, which has none, cannot drive it
    assert main(["import", "lego", str(source), "--rate", "15", "--out", str(out),
                 "--cell", str(DIAGRAMS / "pcb_ic.yaml")]) == EXIT_BAD_INPUT
    assert "no true actions" in capsys.readouterr().err
    assert _files(tmp_path) == [source.name]


# issue "One way to name things", item 4: --cell takes a shipped name; the scenario is checked
# before anything is written; every file written is listed
def test_a_cell_a_recording_cannot_drive_is_refused_before_any_file_is_written(tmp_path, capsys, monkeypatch):
    from hrc_drake import staged_files

    staged = []
    real_path_for = staged_files.StagedFiles.path_for
    monkeypatch.setattr(staged_files.StagedFiles, "path_for",
                        lambda self, final: staged.append(final) or real_path_for(self, final))
    monkeypatch.chdir(tmp_path)
    source = _recording(tmp_path)
    out = tmp_path / "new" / "rec.csv"
    # pcb_ic (by its shipped name) perceives the operator's actions, which a recording has not
    assert main(["import", "lego", str(source), "--rate", "15", "--out", str(out), "--cell", "pcb_ic"]) \
        == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "--cell" in err and "pcb_ic.yaml" in err and "action_detector" in err and "no true actions" in err
    assert "nothing was written" in err and "Traceback" not in err
    assert staged == [] and _files(tmp_path) == [source.name]  # not even a temporary file


def test_a_broken_cell_is_named_in_its_own_file_and_nothing_is_written(tmp_path, capsys):
    source = _recording(tmp_path)
    cell = tmp_path / "cell.yaml"
    cell.write_text(f"extends: {CELL}\nduration: -1\n")
    _refused(capsys, ["lego", str(source), "--rate", "15", "--out", str(tmp_path / "o" / "r.csv"),
                      "--cell", str(cell)], f"{cell}:2:11: duration")  # its line and column too
    assert _files(tmp_path) == sorted([source.name, cell.name])


def _listed(out: str) -> list[str]:
    lines = out.splitlines()
    assert sum(line.startswith("files written") for line in lines) == 1, out  # one list, at the end
    at = next(k for k, line in enumerate(lines) if line.startswith("files written"))
    assert lines[at] == f"files written ({len(lines) - at - 1}):"
    return [line.strip() for line in lines[at + 1:]]


def test_import_by_a_shipped_cell_name_lists_every_file_it_wrote(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)  # not the repository: the name is no path here
    source = _recording(tmp_path)
    out = tmp_path / "o" / "rec.csv"
    assert main(["import", "lego", str(source), "--rate", "15", "--out", str(out)]) == 0
    assert _listed(capsys.readouterr().out) == [str(out), str(out.with_suffix(".json"))]
    assert main(["import", "lego", str(source), "--rate", "15", "--out", str(out),
                 "--cell", "box_pcb_coexistence"]) == 0
    written = [out, out.with_suffix(".json"), out.with_suffix(".yaml")]
    assert _listed(capsys.readouterr().out) == [str(p) for p in written]
    scenario = load_scenario(out.with_suffix(".yaml"))
    assert scenario.source_path == out.with_suffix(".yaml")
    assert scenario.safety == load_scenario("box_pcb_coexistence").safety
    assert sorted(p.name for p in out.parent.iterdir()) == sorted(p.name for p in written)


def test_an_import_with_a_replay_lists_its_four_files(tmp_path, capsys):
    source = _recording(tmp_path, lines=30)  # 2 s at 15 Hz: a short replay
    out, replay = tmp_path / "o" / "rec.csv", tmp_path / "o" / "rec.html"
    assert main(["import", "lego", str(source), "--rate", "15", "--out", str(out), "--cell", str(CELL),
                 "--replay", str(replay)]) == 0
    written = [out, out.with_suffix(".json"), out.with_suffix(".yaml"), replay]
    assert _listed(capsys.readouterr().out) == [str(p) for p in written]
    assert all(p.is_file() for p in written)


def test_the_summary_shows_a_control_character_as_its_escape(tmp_path, capsys):
    source = _recording(tmp_path, "rec\x1b[2Jx.txt")
    assert main(["import", "lego", str(source), "--rate", "15", "--out", str(tmp_path / "r.csv")]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "rec\\x1b[2Jx.txt" in out


# item 3: bounded reads, each refused before the file is read
def test_a_device_or_a_fifo_is_refused_unread(tmp_path, capsys):
    import os

    _refused(capsys, ["lego", "/dev/zero", "--rate", "15", "--out", str(tmp_path / "z.csv")], "a device")
    fifo = tmp_path / "pipe.txt"
    os.mkfifo(fifo)
    _refused(capsys, ["lego", str(fifo), "--rate", "15", "--out", str(tmp_path / "f.csv")], "a FIFO")
    assert _files(tmp_path) == ["pipe.txt"]


def test_a_recording_larger_than_the_bound_is_refused_unread(tmp_path, capsys):
    from hrc_drake.human.importers import MAX_RECORDING_BYTES

    huge = tmp_path / "huge.txt"
    with huge.open("wb") as handle:  # sparse: no disk used, no byte read
        handle.truncate(MAX_RECORDING_BYTES + 1)
    _refused(capsys, ["lego", str(huge), "--rate", "15", "--out", str(tmp_path / "h.csv")],
             f"recordings up to {MAX_RECORDING_BYTES // 2**20} MiB")
    edge = tmp_path / "edge.txt"
    with edge.open("wb") as handle:  # exactly the bound: read (and refused for its content, not size)
        handle.truncate(MAX_RECORDING_BYTES)
    args = ["import", "lego", str(edge), "--rate", "15", "--out", str(tmp_path / "e.csv")]
    assert main(args) == EXIT_BAD_INPUT
    assert "MiB" not in capsys.readouterr().err


def test_a_rate_that_would_explode_the_resampled_array_is_refused(tmp_path, capsys):
    from hrc_drake.human.importers import MAX_RESAMPLED_FRAMES

    source = _recording(tmp_path, lines=900)
    _refused(capsys, ["lego", str(source), "--rate", "0.1", "--camera-rate", "120",
                      "--out", str(tmp_path / "r.csv")], f"at most {MAX_RESAMPLED_FRAMES:,} are written")
    assert _files(tmp_path) == [source.name]


@pytest.mark.parametrize("option, value, reason", [
    ("--delimiter", "", "the delimiter must be one printable character"),
    ("--delimiter", "ab", "the delimiter must be one printable character"),
    ("--delimiter", '"', "the delimiter must be one printable character"),
    ("--header-rows", "-1", "header rows must be a whole number >= 0"),
])
def test_table_options_out_of_their_range_are_refused(tmp_path, capsys, option, value, reason):
    source = _recording(tmp_path)
    columns = tmp_path / "map.yaml"
    columns.write_text("left_wrist: [0, 1, 2]\nright_wrist: [3, 4, 5]\n")
    _refused(capsys, ["table", str(source), "--rate", "15", "--columns", str(columns), f"{option}={value}",
                      "--out", str(tmp_path / "t.csv")], reason)


# item 4: garbage that used to be written as "tracked" frames
def _table(folder, rows, name="t.txt"):
    path = folder / name
    path.write_text("\n".join(" ".join(repr(float(v)) for v in row) for row in rows) + "\n")
    columns = folder / "map.yaml"
    columns.write_text("left_shoulder: [0, 1, 2]\nleft_elbow: [3, 4, 5]\nleft_wrist: [6, 7, 8]\n"
                       "right_shoulder: [9, 10, 11]\n")
    return path, columns


def _arm(scale=1.0, shoulder_width=0.38):
    shoulder, elbow, wrist = (0.0, 0.0, 1.4), (0.0, 0.05, 1.1), (0.25, 0.05, 1.05)
    right = (shoulder_width, 0.0, 1.4)
    return [[scale * v for p in (shoulder, elbow, wrist, right) for v in p]] * 40


@pytest.mark.parametrize("rows, units, reason", [
    ([[0.0] * 12] * 40, "m", "left shoulder at the origin in all 40 frames: untracked"),
    (_arm(shoulder_width=0.0), "m", "the shoulder width"),
    (_arm(scale=1e300), "m", "upper arm"),
    (_arm(scale=100.0), "m", "(in cm? it would be 0.304 m: --units cm)"),
    (_arm(), "mm", "(in m? it would be 0.304 m: --units m)"),
])
def test_a_recording_no_person_could_make_is_refused(tmp_path, capsys, rows, units, reason):
    source, columns = _table(tmp_path, rows)
    _refused(capsys, ["table", str(source), "--rate", "15", "--columns", str(columns), "--units", units,
                      "--out", str(tmp_path / "t.csv")], reason)
    assert not (tmp_path / "t.csv").exists()


def test_the_edge_of_the_segment_range_is_accepted(tmp_path, capsys):
    from hrc_drake.human.importers import SEGMENT_RANGES_M

    low = SEGMENT_RANGES_M["shoulder width"][0]
    source, columns = _table(tmp_path, _arm(shoulder_width=low + 1e-9))
    assert main(["import", "table", str(source), "--rate", "15", "--columns", str(columns),
                 "--out", str(tmp_path / "t.csv")]) == 0


@pytest.mark.parametrize("option, value", [
    ("--up", "0,0,1e-320"), ("--operator-x", "nan"), ("--operator-y", "inf"), ("--operator-x", "1e6"),
    ("--facing", "nan"), ("--table-height", "1e308"), ("--table-height", "0"),
])
def test_placement_options_out_of_the_cell_are_refused(tmp_path, capsys, option, value):
    source, columns = _table(tmp_path, _arm())
    _refused(capsys, ["table", str(source), "--rate", "15", "--columns", str(columns), f"{option}={value}",
                      "--out", str(tmp_path / "t.csv")], option)
    assert not (tmp_path / "t.csv").exists()


# item 4: an operator faster than a person
def _box_usb_with_fill(tmp_path, duration: str):
    text = (DIAGRAMS / "box_usb.yaml").read_text()
    old = "duration: {kind: normal, mean: 4.0, std: 0.6, low: 2.0}}"
    assert text.count(old) == 1  # the operator's fill (the flow's has no low)
    path = tmp_path / "fast.yaml"
    path.write_text(text.replace(old, f"duration: {duration}}}", 1))
    return path


def test_an_operator_action_too_short_for_a_person_is_refused(tmp_path):
    from hrc_drake.cell.scenario import ScenarioError

    with pytest.raises(ScenarioError, match=r"operator.actions\[0\].duration.*peaks at .* m/s"):
        load_scenario(_box_usb_with_fill(tmp_path, "{kind: fixed, mean: 0.001}"))


def test_the_wrist_speed_limit_by_hand(tmp_path):
    """fill's goals g5_boxes [0.80, 0.36, 0.82] and g1_home [0.80, 0.00, 0.90]; the pattern ends with
    tape, whose last goal is g1_home: the first reach is 0.369 m, the second as long. With 2 goals a
    phase is D / 2, its reach 0.75 (D / 2 - 0.3) for D >= 3 s: peak 1.875 x 0.369 / reach = 4 m/s
    at D = 2 (1.875 x 0.369 / (4 x 0.75) + 0.3) = 1.0612 s (below 3 s the head lead is 0.2 phase:
    reach = 0.75 x 0.8 x D / 2 = 0.3 D, D = 1.875 x 0.369 / 1.2 = 0.5766 s)."""
    import math

    from hrc_drake.cell.scenario import ScenarioError

    distance = math.hypot(0.36, 0.08)
    edge = 1.875 * distance / (4.0 * 0.3)
    load_scenario(_box_usb_with_fill(tmp_path, f"{{kind: fixed, mean: {edge * 1.001}}}"))
    with pytest.raises(ScenarioError, match="peaks at 4 m/s"):
        load_scenario(_box_usb_with_fill(tmp_path, f"{{kind: fixed, mean: {edge * 0.999}}}"))
    # a normal's shortest likely duration is mean - 3 std (or its low, when larger)
    load_scenario(_box_usb_with_fill(tmp_path, f"{{kind: normal, mean: {edge + 0.31}, std: 0.1}}"))
    with pytest.raises(ScenarioError, match="peaks at"):
        load_scenario(_box_usb_with_fill(tmp_path, f"{{kind: normal, mean: {edge + 0.29}, std: 0.1}}"))


# item 5: an --out that cannot be written is a clear error, not a traceback
@pytest.mark.parametrize("out_of", [lambda f: f, lambda f: "/", lambda f: "/proc/x.csv",
                                    lambda f: f / "file.txt" / "below.csv"])
def test_an_out_that_cannot_be_written_is_refused(tmp_path, capsys, out_of):
    source = _recording(tmp_path)
    (tmp_path / "file.txt").write_text("a file, not a folder\n")
    before = _files(tmp_path)
    _refused(capsys, ["lego", str(source), "--rate", "15", "--out", str(out_of(tmp_path))], "--out")
    assert _files(tmp_path) == before


def test_the_readme_tour_imports_the_kth_folder_into_a_cell_with_its_replay(tmp_path, capsys):
    """The tour's last command, as a newcomer types it: the KTH hand-over set is a folder."""
    kth = dataset_dir("kth_handover")
    out = tmp_path / "out" / "kth.csv"
    replay = tmp_path / "out" / "kth.html"
    assert main(["import", "kth", str(kth), "--out", str(out), "--cell", "box_pcb_coexistence",
                 "--replay", str(replay)]) == 0
    assert _files(tmp_path / "out") == ["kth.csv", "kth.html", "kth.json", "kth.yaml"]
    assert load_scenario(out.with_suffix(".yaml")).operator.recorded


def test_a_folder_recording_and_a_file_recording_are_told_apart(tmp_path, capsys):
    kth = dataset_dir("kth_handover")
    _refused(capsys, ["kth", str(kth / "baton_pose_saved.csv"), "--out", str(tmp_path / "k.csv")],
             "is a file, not a folder: give the KTH hand-over recording's folder")
    _refused(capsys, ["lego", str(kth), "--rate", "15", "--out", str(tmp_path / "l.csv")],
             "is a folder, not a recording file")
    assert not list(tmp_path.iterdir())
