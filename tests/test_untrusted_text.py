"""Names from a user's files written where they could act (issue 55, items 5 and 6): a CSV cell a
spreadsheet would run, a plot label matplotlib would parse as mathtext, a file name with a path
separator in it."""

from __future__ import annotations

import csv
import re

import pandas as pd
import pytest

from hrc_drake.cell.metrics import MetricsLog, plot_gantt, write_events_csv
from hrc_drake.messages import RobotEvent
from hrc_drake.untrusted import csv_cell, file_name_part, one_line

FORMULAS = ['=HYPERLINK("http://x","y")', "-2+3+cmd|' /C calc'!A0", "+1", "@SUM(A1)", "\t=1", "\r=1"]


@pytest.mark.parametrize("name", FORMULAS)
def test_a_formula_is_quoted(name):
    assert csv_cell(name) == "'" + name


@pytest.mark.parametrize("value", ["R_pick", "a-b", "x=1", "", 3.5, -2, None])
def test_other_cells_are_unchanged(value):
    assert csv_cell(value) == value


def test_events_csv_never_starts_a_name_cell_with_a_formula(tmp_path):
    events = []
    for k, name in enumerate(FORMULAS):
        events += [RobotEvent(k, name, name, "begin", 2 * k + 1),
                   RobotEvent(k + 0.5, name, name, "end", 2 * k + 2)]
    path = tmp_path / "events.csv"
    write_events_csv(path, events)
    with path.open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 2 * len(FORMULAS)
    for row in rows:
        for column in ("agent", "action", "kind", "detail"):
            assert not row[column].startswith(("=", "+", "-", "@", "\t", "\r")), row
    assert {row["agent"] for row in rows} == {"'" + name for name in FORMULAS}


def test_a_campaign_summary_never_starts_a_text_cell_with_a_formula():
    from hrc_drake.campaign.analysis import _formula_free

    table = pd.DataFrame({"variant": ["=1+1", "plain"], "metric": ["-cmd", "cycle"], "n": [-3, 4]})
    safe = _formula_free(table)
    assert safe["variant"].tolist() == ["'=1+1", "plain"] and safe["metric"].tolist() == ["'-cmd", "cycle"]
    assert safe["n"].tolist() == [-3, 4]  # numbers keep their sign


def test_a_name_with_mathtext_or_a_slash_draws_as_written(tmp_path):
    names = [r"$\frac{a}$", "a/b", "$x$"]
    log = MetricsLog(events=[e for k, name in enumerate(names)
                             for e in (RobotEvent(k, name, name, "begin", 2 * k + 1),
                                       RobotEvent(k + 0.5, name, name, "end", 2 * k + 2))])
    path = tmp_path / "gantt.png"
    plot_gantt(path, log, 4.0, names, title=r"$\frac{a}$ cell", action_names=names)
    assert path.stat().st_size > 0


@pytest.mark.parametrize("text", ["busy_a/b", "../../etc/passwd", ".hidden", "x" * 300, "a\nb", "é"])
def test_a_file_name_part_stays_in_its_folder(tmp_path, text):
    part = file_name_part(text)
    assert "/" not in part and "\n" not in part and not part.startswith(".") and len(part) <= 89
    (tmp_path / f"box_{part}.png").write_bytes(b"")
    assert file_name_part(text) == part  # the same name gives the same file
    assert file_name_part("busy_a_b") != file_name_part("busy_a/b")  # and two names two files


def test_one_line_escapes_every_line_break():
    for brk in ("\n", "\r", "\x85", "\u2028", "\u2029", "\x0b", "\x0c", "\x1c"):
        assert "\\" in one_line(f"a{brk}b") and brk not in one_line(f"a{brk}b")


SECRET = "topsecret:*:20228:0:99999:7:::\ndaemon:*:20228:0:99999:7:::\nsecret: [unclosed\n"


def test_an_error_never_echoes_a_foreign_file_s_content(tmp_path, capsys):
    """`extends:`, `--columns` and `--cell` naming a file that is not ours (/etc/shadow) printed
    its first line in the error (issue 55, item 9)."""
    from hrc_drake.cli import EXIT_BAD_INPUT, main
    from hrc_drake.datasets import dataset_dir

    secret = tmp_path / "shadow"
    secret.write_text(SECRET)
    scenario = tmp_path / "cell.yaml"
    scenario.write_text(f"extends: {secret}\n")
    trial = tmp_path / "rec.txt"
    trial.write_text("\n".join((dataset_dir("lego_assembly_arm") / "Task2" / "Human1" / "trial1.txt")
                               .read_text().splitlines()[:60]) + "\n")
    for args in (["validate", str(scenario)],
                 ["import", "table", str(trial), "--rate", "15", "--columns", str(secret),
                  "--out", str(tmp_path / "a.csv")],
                 ["import", "lego", str(trial), "--rate", "15", "--cell", str(secret),
                  "--out", str(tmp_path / "b.csv")]):
        assert main(args) == EXIT_BAD_INPUT
        err = capsys.readouterr().err
        assert "20228" not in err and "topsecret" not in err and "unclosed" not in err, (args, err)
        # still says where (file:line:column, issue 54) or what
        assert re.search(r"shadow:\d+:\d+: ", err) or "mapping" in err, err


def test_a_limits_table_that_is_not_text_is_a_clear_error(tmp_path):
    from hrc_drake.errors import ConfigError
    from hrc_drake.safety.limits import load_limits

    binary = tmp_path / "ls"
    binary.write_bytes(b"\x7fELF\x02\x01\x01\x00" + bytes(range(256)))
    with pytest.raises(ConfigError, match="not UTF-8 text"):
        load_limits(binary)


def test_messages_say_what_was_wrong(tmp_path, capsys):
    """issue 55, item 10: `import --rate` said "(0: as fast as possible)", the realtime rate's
    words; `duration: 1.0e12` (a string to YAML 1.1) was "expected a number"."""
    from hrc_drake.cli import EXIT_BAD_INPUT, main
    from tests.conftest import DIAGRAMS

    with pytest.raises(SystemExit):
        main(["import", "lego", "x.txt", "--rate", "0", "--out", str(tmp_path / "x.csv")])
    err = capsys.readouterr().err
    assert "frame rate must be in [0.1, 10000] Hz" in err and "as fast as possible" not in err
    scenario = tmp_path / "long.yaml"
    scenario.write_text(f"extends: {DIAGRAMS / 'torch_clock.yaml'}\nduration: 1.0e12\n")
    assert main(["validate", str(scenario)]) == EXIT_BAD_INPUT
    assert "1.0e+12" in capsys.readouterr().err
    scenario.write_text(f"extends: {DIAGRAMS / 'torch_clock.yaml'}\nduration: nan text\n")
    assert main(["validate", str(scenario)]) == EXIT_BAD_INPUT
    assert "1.0e+12" not in capsys.readouterr().err  # the hint only where it applies
