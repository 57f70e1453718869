"""Fuzz cases of untrusted input (issue 55): `import` with hostile file names, special files,
degenerate recordings and option values; scenario names with formulas, markup, mathtext, line
breaks and path separators. Each case builds its inputs in a folder of its own and says which
files are inputs (they must come out byte for byte the same)."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from hrc_drake.cell.scenario import _raw_document, dump_raw
from hrc_drake.datasets import dataset_dir
from tests.conftest import DIAGRAMS

TRIAL = dataset_dir("lego_assembly_arm") / "Task2" / "Human1" / "trial1.txt"
CELL = DIAGRAMS / "box_pcb_coexistence.yaml"

#: file names a recording may arrive with
HOSTILE_NAMES = ("rec\rsafety: !NoSafety {}\r#.txt", "rec\nsafety: x.txt", "rec\x85x.txt", "rec\u2028x.txt",
                 "rec\u2029x.txt", "rec\x1b[2Jx.txt", "rec\tx.txt", "-rec.txt", "=rec.txt", "rec .txt",
                 "é€.txt", "rec'\"{}[]#&*!|>%@`.txt", "x" * 200 + ".txt")
#: names a scenario may give its operator or its actions
HOSTILE_TEXT = ('=HYPERLINK("http://x","y")', "-2+3+cmd|' /C calc'!A0", "@SUM(A1)", "+1", "$\\frac{a}$",
                "$x$ and $y", "a/b", "../../x", "<script>alert(1)</script>", "name\nsafety: !NoSafety {}",
                "\x1b[2J", "a\\b", "  padded  ", "é€", "x" * 300, "\ttab")

#: (label, setup): setup(folder) -> (import arguments, input files)
ImportCase = tuple[str, Callable[[Path], tuple[list[str], list[Path]]]]


def _recording(folder: Path, name: str = "rec.txt", lines: int = 90) -> Path:
    path = folder / name
    path.write_text("\n".join(TRIAL.read_text().splitlines()[:lines]) + "\n")
    return path


def _rows(folder: Path, rows: list[str], name: str = "t.txt") -> Path:
    path = folder / name
    path.write_text("\n".join(rows) + "\n")
    return path


def _lego(source_of, *options, cell: bool = False):
    def setup(folder: Path):
        source = source_of(folder)
        args = ["lego", str(source), "--rate", "15", "--out", str(folder / "out" / "rec.csv"), *options]
        if cell:
            args += ["--cell", str(CELL)]
        return args, [source]
    return setup


def _with_out(out_of, cell: bool = False):
    """A lego import whose --out (given the folder and the source) may land on an input."""
    def setup(folder: Path):
        source = _recording(folder)
        args = ["lego", str(source), "--rate", "15", "--out", str(out_of(folder, source))]
        if cell:
            args += ["--cell", str(CELL)]
        return args, [source]
    return setup


def _fifo(folder: Path) -> Path:
    path = folder / "pipe.txt"
    os.mkfifo(path)
    return path


def _sparse(folder: Path, size: int = 40 * 2**20) -> Path:
    path = folder / "huge.txt"
    with path.open("wb") as handle:
        handle.truncate(size)
    return path


def _loop(folder: Path) -> Path:
    (folder / "a.txt").symlink_to(folder / "b.txt")
    (folder / "b.txt").symlink_to(folder / "a.txt")
    return folder / "a.txt"


def _folder(folder: Path) -> Path:
    (folder / "dir.txt").mkdir()
    return folder / "dir.txt"


def _garbage(folder: Path) -> Path:
    path = folder / "garbage.txt"
    path.write_bytes(bytes(range(256)) * 64)
    return path


def _table_case(rows_of, *options):
    def setup(folder: Path):
        source = rows_of(folder)
        columns = folder / "map.yaml"
        columns.write_text("left_shoulder: [0, 1, 2]\nleft_elbow: [3, 4, 5]\nleft_wrist: [6, 7, 8]\n"
                           "right_shoulder: [9, 10, 11]\n")
        args = ["table", str(source), "--rate", "15", "--columns", str(columns),
                "--out", str(folder / "t.csv"), *options]
        return args, [source, columns]
    return setup


def _arm_rows(scale: float = 1.0, width: float = 0.38, frames: int = 40) -> Callable[[Path], Path]:
    row = " ".join(repr(scale * v) for v in (0, 0, 1.4, 0, 0.05, 1.1, 0.25, 0.05, 1.05, width, 0, 1.4))
    return lambda folder: _rows(folder, [row] * frames)


def import_cases() -> list[ImportCase]:
    """Every import fuzz case."""
    cases: list[ImportCase] = []
    for name in HOSTILE_NAMES:
        cases.append((f"name {name!r}", _lego(lambda f, n=name: _recording(f, n), cell=True)))
    cases += [
        ("special /dev/zero", _lego(lambda f: Path("/dev/zero"))),
        ("special fifo", _lego(_fifo)),
        ("special folder", _lego(_folder)),
        ("special symlink loop", _lego(_loop)),
        ("special missing", _lego(lambda f: f / "missing.txt")),
        ("huge sparse 40 MiB", _lego(_sparse)),
        ("degenerate empty", _lego(lambda f: _rows(f, [""]))),
        ("degenerate one line", _lego(lambda f: _recording(f, lines=1))),
        ("degenerate garbage bytes", _lego(_garbage)),
        ("degenerate text", _lego(lambda f: _rows(f, ["hello world"] * 50))),
        ("degenerate zeros", _table_case(lambda f: _rows(f, [" ".join(["0"] * 12)] * 40))),
        ("degenerate coincident shoulders", _table_case(_arm_rows(width=0.0))),
        ("degenerate 1e308", _table_case(_arm_rows(scale=1e300))),
        ("degenerate nan", _table_case(lambda f: _rows(f, [" ".join(["nan"] * 12)] * 40))),
        ("units m on cm data", _table_case(_arm_rows(scale=100.0))),
        ("units mm on m data", _table_case(_arm_rows(), "--units", "mm")),
        ("good table", _table_case(_arm_rows())),
    ]
    for option, value in (("--rate", "0"), ("--rate", "-1"), ("--rate", "nan"), ("--rate", "1e9"),
                          ("--rate", "0.1"), ("--camera-rate", "1e9"), ("--operator-x", "nan"),
                          ("--operator-y", "inf"), ("--operator-x", "1e6"), ("--facing", "nan"),
                          ("--table-height", "1e308"), ("--table-height", "0"), ("--up", "0,0,1e-320"),
                          ("--header-rows", "-1"), ("--delimiter", "")):
        def setup(folder: Path, option=option, value=value):
            source = _recording(folder)
            args = ["lego", str(source), "--rate", "15", "--out", str(folder / "o.csv"), f"{option}={value}"]
            return args, [source]
        cases.append((f"option {option}={value}", setup))
    cases.append(("option --rate 0.1 --camera-rate 120", _lego(lambda f: _recording(f, lines=900),
                                                                  "--camera-rate", "120")))
    cases += [
        ("out is the source", _with_out(lambda f, s: s)),
        ("out is .json", _with_out(lambda f, s: f / "o" / "same.json")),
        ("out is a folder", _with_out(lambda f, s: f)),
        ("out is /", _with_out(lambda f, s: Path("/"))),
        ("out in /proc", _with_out(lambda f, s: Path("/proc/x.csv"))),
        ("out's yaml is the cell", _cell_collision),
        ("out's yaml is the column map", _columns_collision),
        ("good with cell", _lego(_recording, cell=True)),
    ]
    return cases


def _cell_collision(folder: Path):
    source = _recording(folder)
    cell = folder / "cellcopy.yaml"
    cell.write_text(f"extends: {CELL}\n")
    args = ["lego", str(source), "--rate", "15", "--out", str(folder / "cellcopy.csv"), "--cell", str(cell)]
    return args, [source, cell]


def _columns_collision(folder: Path):
    args, inputs = _table_case(_arm_rows())(folder)
    args[args.index("--out") + 1] = str(folder / "map.csv")
    return args + ["--cell", str(CELL)], inputs


def text_cases(scenario: Path = DIAGRAMS / "box_usb.yaml") -> list[tuple[str, str]]:
    """(label, scenario text): the operator's name, an operator action's name and the description
    replaced by each hostile text (every occurrence of the name, so the scenario stays whole)."""
    raw = _raw_document(scenario.read_text())
    cases = []
    for text in HOSTILE_TEXT:
        for field, old in (("operator name", raw["operator"]["name"]),
                           ("action name", raw["operator"]["actions"][0]["name"])):
            cases.append((f"{field} {text!r}", dump_raw(_renamed(raw, old, text))))
        cases.append((f"description {text!r}", dump_raw({**raw, "description": text})))
    return cases


def _renamed(node, old: str, new: str):
    """`node` with every string equal to `old` (a name) replaced by `new`."""
    if isinstance(node, dict):
        out = {key: _renamed(value, old, new) for key, value in node.items()}
        if hasattr(node, "tag"):
            out = type(node)(node.tag, out)
        return out
    if isinstance(node, list):
        return [_renamed(value, old, new) for value in node]
    return new if node == old else node
