"""YAML alias bombs ("billion laughs") and aliases inside their own anchor are refused in well
under a second by `validate`, `simulate` and `campaign` (as the spec and in a variant override),
counted on the composed YAML graph without expanding it; a few harmless aliases are still read.

The commands run in their own process with a timeout and a memory cap, so a regression that
expands a bomb fails the test instead of hanging it or filling the machine's memory."""

from __future__ import annotations

import resource
import subprocess
import sys
import time

import pytest

from hrc_drake.cell.scenario import MAX_EXPANDED_NODES, _raw_document, load_scenario
from hrc_drake.cli import EXIT_BAD_INPUT
from hrc_drake.errors import ScenarioError
from tests.conftest import DIAGRAMS, REPO

TIMEOUT_S = 20
MEMORY_CAP_BYTES = 3 << 30
TORCH = DIAGRAMS / "torch_clock.yaml"


def alias_bomb(indent: str = "") -> str:
    """Nine lists, each of nine aliases of the one before: 9^9 (about 4e8) values expanded,
    under 400 bytes written; as mapping lines `a: &a [...]` ... `i: &i [*h, ...]`."""
    lines = [f"{indent}a: &a [{', '.join(['lol'] * 9)}]"]
    for before, name in zip("abcdefgh", "bcdefghi", strict=True):
        lines.append(f"{indent}{name}: &{name} [{', '.join([f'*{before}'] * 9)}]")
    return "\n".join(lines) + "\n"


def _cap_memory():
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP_BYTES, MEMORY_CAP_BYTES))


def _hrc_drake(*args) -> tuple[int, str]:
    """Exit code and stderr of `hrc-drake args` in its own process."""
    try:
        proc = subprocess.run([sys.executable, "-m", "hrc_drake.cli", *map(str, args)], cwd=REPO,
                              capture_output=True, text=True, timeout=TIMEOUT_S, preexec_fn=_cap_memory)
    except subprocess.TimeoutExpired:
        pytest.fail(f"hrc-drake {' '.join(map(str, args))} still ran after {TIMEOUT_S} s")
    return proc.returncode, proc.stderr


def _assert_bomb_refused(code: int, err: str, file, field: str) -> None:
    assert code == EXIT_BAD_INPUT, err
    assert err.startswith(f"error: {file}: {field}: the aliases (*name) up to this one expand to "), err


def test_a_bomb_is_counted_without_expanding_it():
    start = time.perf_counter()
    with pytest.raises(ScenarioError) as err:
        _raw_document("bomb:\n" + alias_bomb("  "))
    assert err.value.field == "bomb.f[0]"  # the first alias past the limit
    assert err.value.reason.startswith("the aliases (*name) up to this one expand to 141,148 values")
    assert time.perf_counter() - start < 1.0


def test_aliases_may_add_values_up_to_the_limit():
    def aliased(m: int) -> str:  # list a: 100 nodes; each *a adds them once more
        return "x: &a [" + ", ".join(["1"] * 99) + "]\ny: [" + ", ".join(["*a"] * m) + "]\n"

    most = MAX_EXPANDED_NODES // 100
    assert len(_raw_document(aliased(most))["y"]) == most
    with pytest.raises(ScenarioError, match=rf"y\[{most}\]: .* expand to {100 * (most + 1):,} values"):
        _raw_document(aliased(most + 1))


@pytest.mark.parametrize("command", [["validate"], ["simulate", "--duration", "1"]])
def test_validate_and_simulate_refuse_a_bomb(command, tmp_path):
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text("seed: 1\nbomb:\n" + alias_bomb("  "))
    code, err = _hrc_drake(command[0], bomb, *command[1:])
    _assert_bomb_refused(code, err, bomb, "bomb.f[0]")


def test_validate_refuses_an_alias_inside_its_own_anchor(tmp_path):
    loop = tmp_path / "loop.yaml"
    loop.write_text("seed: 1\nlayout: &a [*a, *a]\n")
    code, err = _hrc_drake("validate", loop)
    assert code == EXIT_BAD_INPUT and err.startswith(f"error: {loop}: layout: an alias (*name) refers"), err


CAMPAIGN = f"name: bomb\nduration: 2\nseeds: [0]\nscenarios: [{TORCH}]\n"


@pytest.mark.parametrize("spec, field", [
    (CAMPAIGN + "description:\n" + alias_bomb("  "), "description.f[0]"),
    (CAMPAIGN + "variants:\n  boom:\n    operator:\n" + alias_bomb("      "), "variants.boom.operator.f[0]"),
], ids=["spec", "variant_override"])
def test_a_campaign_refuses_a_bomb(spec, field, tmp_path):
    file = tmp_path / "campaign.yaml"
    file.write_text(spec)
    code, err = _hrc_drake("campaign", file, "--out", tmp_path / "out", "--workers", "0")
    _assert_bomb_refused(code, err, file, field)
    assert not (tmp_path / "out" / "runs.parquet").exists()


def test_a_few_aliases_are_still_read(tmp_path):
    text = TORCH.read_text()
    feeder = "position: [0.30, -0.42, 0.76]}"
    assert text.count(feeder) == 1 and "&" not in text  # the shipped files use no aliases
    text = text.replace(feeder, "position: &feeder [0.30, -0.42, 0.76]}")
    text = text.replace("0.1, position: [0.40, -0.02, 0.76]}", "0.1, position: *feeder}")
    scenario_file = tmp_path / "aliased.yaml"
    scenario_file.write_text(text)
    buffers = {b.name: list(b.position) for b in load_scenario(scenario_file).layout.buffers}
    assert buffers["station_A"] == buffers["front_feeder"] == [0.30, -0.42, 0.76]
