"""The measuring rules of `tools/bench_real.py` as deployed (issue 56): the reach onset read from
the past only, moving windows, intervals over people, and every claim judged by its rule."""


import numpy as np
import pytest

from hrc_drake.messages import L_WRIST, R_WRIST
from tests.conftest import load_tool


@pytest.fixture(scope="module")
def br():
    return load_tool("bench_real")


def _still_then_reach(frames=90, start=45, speed=0.6, rate=30.0):
    points = np.zeros((frames, 8, 3))
    frame = np.arange(frames)
    points[:, R_WRIST, 0] = np.where(frame < start, 0.0, (frame - start) * speed / rate)
    points[:, L_WRIST] = (0.0, 0.3, 0.0)
    return points


def test_the_onset_is_found_from_the_past_only(br):
    points = _still_then_reach()
    onset = br.causal_onset(points)
    assert onset is not None and 45 <= onset <= 45 + 6  # within 0.2 s of the real start
    later = points.copy()
    later[onset + 1 :] = 5.0  # whatever comes after cannot move it
    assert br.causal_onset(later) == onset
    assert br.causal_onset(np.zeros((90, 8, 3))) is None


def test_a_window_moves_when_a_wrist_does(br):
    points = _still_then_reach(speed=0.6)
    speeds = br.window_speeds(points, 9)
    assert speeds[0] == pytest.approx(0.0) and speeds[60] == pytest.approx(0.6)
    # a window [k, k + 9] moves 0.02 m per frame past frame 45: 0.09 m (0.3 m/s) from k = 41 on
    assert len(speeds) == 81 and np.flatnonzero(speeds >= br.MOVING_SPEED).tolist() == list(range(41, 81))
    gone = points.copy()
    gone[:, [L_WRIST, R_WRIST]] = np.nan
    assert np.isnan(br.window_speeds(gone, 9)).all()


def _row(tested, missed, windows=10, moving=5):
    row = {"fit_error_m": 0.01}
    for kind in ("gp_a", "gp_b", "gp_c", "worst_case"):
        row[kind] = {"tested_moving": tested, "misses_moving": [0.02] * missed, "tested_all": 2 * tested,
                     "misses_all": [0.02] * missed, "windows": windows, "windows_moving": moving}
    return row


def test_misses_are_per_person_and_their_interval_is_over_people(br):
    rows = [("p1", _row(100, 0)), ("p2", _row(100, 10)), ("p3", _row(200, 10))]
    out = br.summarise_deployed(rows)["gp_c"]
    assert out["miss_fraction_moving"] == pytest.approx((0 + 0.1 + 0.05) / 3)  # the person is the unit
    assert out["miss_fraction_moving_pooled"] == pytest.approx(20 / 400)
    assert out["idle_share"] == pytest.approx(0.5) and out["miss_fraction_all"] == pytest.approx(20 / 800)
    assert out["people"] == 3 and out["miss_fraction_moving.people"] == 3
    low, high = out["miss_fraction_moving.ci95"]
    assert low < out["miss_fraction_moving"] < high  # Student's t over the three people
    assert out["per_person"] == {"p1": 0.0, "p2": 0.1, "p3": 0.05}
    one = br.summarise_deployed([("p1", _row(100, 5)), ("p1", _row(100, 5))])["gp_c"]
    assert one["miss_fraction_moving.ci95"] is None  # one person: no interval, hence no verdict
    idle = br.summarise_deployed([("p1", _row(0, 0, moving=0)), ("p2", _row(0, 0, moving=0))])["gp_c"]
    assert idle["miss_fraction_moving"] is None and idle["idle_share"] == 1.0
    assert idle["miss_fraction_moving.ci95"] is None and idle["per_person"] == {}


def test_a_sequence_belongs_to_its_person(br):
    assert br.person_of("lego:Task3/Human2/trial2") == "lego:Human2"
    assert br.person_of("lego30:Task3/Human2/trial2") == "lego:Human2"  # another rate, the same person
    assert br.person_of("ue:ADL004FR3") == "ue:ADL004"
    assert br.person_of("kth:giver") == "kth:giver"


def test_the_figures_are_flattened_for_the_claims(br):
    flat = br.flatten({"a": {"b": {"c": 1, "c.ci95": [0, 2]}, "d": [1, 2]}})
    assert flat == {"a.b.c": 1, "a.b.c.ci95": [0, 2], "a.d": [1, 2]}


def test_points_the_source_holds_fixed_are_never_scored(br):
    """`deployed_misses` tests only the `scored` points: the fixed shoulders of a LEGO trial add
    nothing to the tested count or the misses."""
    from types import SimpleNamespace

    from hrc_drake.messages import L_SHOULDER, R_SHOULDER

    class FarCapsules:  # every future point lies outside
        def build(self, q, plus, minus):
            return np.array([[9.0, 9.0, 9.0]]), np.array([[9.0, 9.0, 9.5]]), np.array([0.01])

    predictor = SimpleNamespace(steps=3, builder=FarCapsules())
    truth = _still_then_reach(frames=40, start=0, speed=0.9)
    deltas = np.zeros((40, 2, 12))
    filtered = np.zeros((40, 12))
    every = br.deployed_misses(predictor, deltas, filtered, truth, truth, 5, br.ARM_POINTS)
    arms = [k for k in br.ARM_POINTS if k not in (L_SHOULDER, R_SHOULDER)]
    without = br.deployed_misses(predictor, deltas, filtered, truth, truth, 5, arms)
    windows = 40 - 3 - 5
    assert every["tested_all"] == windows * 4 * 6 and without["tested_all"] == windows * 4 * 4
    assert len(without["misses_all"]) == without["tested_all"]  # all outside, none of them a shoulder


def test_a_held_out_folder_is_judged_without_a_code_change(br, tmp_path, capsys):
    """`--data DIR` with another folder laid out like data/ (here a copy of one participant under
    another name): its people are every participant there, counted as test people; one person is
    too few for a verdict."""
    import json
    import shutil

    from hrc_drake.datasets import dataset_dir

    source = dataset_dir("ue_adl") / "ADL004"
    target = tmp_path / "real" / "ue_adl" / "HELD1"
    target.mkdir(parents=True)
    for path in source.glob("*.csv"):
        shutil.copy(path, target / path.name.replace("ADL004", "HELD1"))
    tape = (dataset_dir("ue_adl") / "anthropometrics.csv").read_text().splitlines()
    rows = [tape[0]] + [line.replace("ADL004", "HELD1", 1) for line in tape if line.startswith("ADL004,")]
    (target.parent / "anthropometrics.csv").write_text("\n".join(rows) + "\n")
    br.main(["--smoke", "--data", str(tmp_path), "--parts", "importer"])
    last = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert last["people"]["selection"] == "folder" and last["people"]["ue_adl"] == ["HELD1"]
    claim = last["claims"]["importer_segments"]
    assert claim["people_in_interval"] == 1 and claim["verdict"] == "inconclusive"
    assert "fewer than 5" in claim["why"]
