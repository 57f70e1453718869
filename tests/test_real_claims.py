"""The pre-registered claims of the real-recording bench (`hrc_drake.real_claims`,
docs/real_claims.yaml): the shipped file, the rules' verdicts at their edges, and files the bench
must refuse."""

import numpy as np
import pytest

from hrc_drake.real_claims import Claim, ClaimsError, evaluate, load_claims, verdict


def test_the_shipped_file_splits_people_and_states_each_claim():
    claims = load_claims()
    assert claims.people_of("ue_adl", "tuning") == ("ADL001", "ADL002")
    assert len(claims.people_of("ue_adl", "test")) == 7
    assert set(claims.people_of("ue_adl", "all")) == {"ADL001", "ADL002", *claims.people_of("ue_adl", "test")}
    ids = [c.id for c in claims.claims]
    assert len(ids) == len(set(ids)) >= 8
    with pytest.raises(ClaimsError, match="split must be one of"):
        claims.people_of("ue_adl", "everyone")
    with pytest.raises(ClaimsError, match="splits no people of 'lego'"):
        claims.people_of("lego", "test")


def _claim(**rule):
    return Claim("c", "t", "k", "d", "2026-12-08", "test", **rule)


@pytest.mark.parametrize("ci95, expected", [
    ((0.01, 0.049), "holds"),
    ((0.01, 0.05), "inconclusive"),  # the interval reaches the bound
    ((0.05, 0.08), "does not hold"),
    ((0.049, 0.051), "inconclusive"),
    (None, "not measured"),
    ((float("nan"), 0.01), "not measured"),
])
def test_a_below_rule_at_its_edges(ci95, expected):
    assert verdict(_claim(below=0.05), ci95) == expected


@pytest.mark.parametrize("ci95, expected", [
    ((-0.04, 0.1), "holds"), ((-0.05, 0.1), "inconclusive"), ((-0.2, -0.05), "does not hold"),
])
def test_an_above_rule_at_its_edges(ci95, expected):
    assert verdict(_claim(above=-0.05), ci95) == expected


def test_evaluate_reports_every_claim_and_never_invents_one():
    claims = load_claims()
    key = "importer.segment_error_mm.mean"
    figures = {key: 18.6, f"{key}.ci95": [12.0, 24.0], f"{key}.people": 7}
    out = evaluate(claims, figures, "test")
    assert set(out) == {c.id for c in claims.claims}
    assert out["importer_segments"]["verdict"] == "holds" and out["importer_segments"]["rule"] == "< 30"
    assert all(v["verdict"] == "not measured" for k, v in out.items() if k != "importer_segments")


def test_a_claim_is_judged_only_on_its_people_and_on_enough_of_them():
    claims = load_claims()
    key = "importer.segment_error_mm.mean"
    figures = {key: 18.6, f"{key}.ci95": [12.0, 24.0], f"{key}.people": 7}
    tuning = evaluate(claims, figures, "tuning")["importer_segments"]
    assert tuning["verdict"] == "not measured" and "the test people" in tuning["why"]
    held_out = evaluate(claims, figures, "folder")["importer_segments"]
    assert held_out["verdict"] == "holds"  # another folder's (held-out) people are test people
    few = evaluate(claims, {**figures, f"{key}.people": 4}, "test")["importer_segments"]
    assert few["verdict"] == "inconclusive" and "fewer than 5" in few["why"]
    unknown = evaluate(claims, {key: 18.6, f"{key}.ci95": [12.0, 24.0]}, "test")["importer_segments"]
    assert unknown["verdict"] == "inconclusive"  # no count of people: no verdict either


def test_the_interval_over_people_is_students_t_widened_to_the_exact_one():
    from scipy import stats

    from hrc_drake.real_claims import people_interval

    values = [-0.068, 0.002, -0.001, 0.012, -0.034, -0.048, -0.063]
    mean, (low, high), n = people_interval(values)
    half = stats.t.ppf(0.975, 6) * np.std(values, ddof=1) / np.sqrt(7)
    assert n == 7 and mean == pytest.approx(np.mean(values)) and high - low == pytest.approx(2 * half)
    assert high > 0  # 3 of 7 people do not gain: the interval says so
    # everyone at 0 of 100: the exact interval of 0 / 700 keeps it from width 0
    zero_mean, (zero_low, zero_high), _ = people_interval([0.0] * 7, (0, 700))
    assert zero_mean == 0.0 and zero_low == 0.0 and 0.004 < zero_high < 0.006
    assert people_interval([0.0, 0.0, 0.0, 0.0, 0.3], (3, 500))[1][0] == 0.0  # a proportion stays >= 0
    assert people_interval([10.0, 12.0, float("nan")])[1] is None  # a person without a figure
    assert people_interval([3.0])[1] is None


GOOD = """registered: "2026-12-08"
people:
  ue_adl: {tuning: [A1], test: [B1, B2]}
claims:
  - {id: one, thesis: t, key: a.b, data: d, people: test, below: 0.05, registered: "2026-12-08"}
"""


@pytest.mark.parametrize("text, message", [
    (GOOD.replace("below: 0.05", "below: .nan"), "must be a finite number"),
    (GOOD.replace("below: 0.05", "below: 0.05, above: 0.01"), "exactly one rule"),
    (GOOD.replace("below: 0.05", "below: true"), "must be a finite number"),
    (GOOD.replace("test: [B1, B2]", "test: [B1, A1]"), "none also tuning"),
    (GOOD.replace("test: [B1, B2]", "test: []"), "not empty"),
    (GOOD.replace("test: [B1, B2]", "test: [B1, B1]"), "listed once"),
    (GOOD.replace("test: [B1, B2]", "test: [B1, ../x]"), "list of participant names"),
    (GOOD.replace("key: a.b", "key: a..b"), "is not a bench key"),
    (GOOD.replace("id: one", "id: one, colour: red"), "unknown fields"),
    (GOOD.replace('registered: "2026-12-08"}', 'registered: "yesterday"}'), "not a date"),
    (GOOD.replace("thesis: t", 'thesis: "a\\x1b[31m"'), "control characters"),
    (GOOD + '  - {id: one, thesis: t, key: a.c, data: d, people: test, below: 1, registered: "2026-12-09"}\n',
     "unique"),
    (GOOD.replace("people: test, ", ""), "must say whose figures"),
    (GOOD.replace("below: 0.05,", "below: 0.05, below: 0.5,"), "duplicate key"),
    (GOOD.replace("ue_adl: {tuning: [A1], test: [B1, B2]}",
                  "ue_adl: {tuning: [A1], test: [B1, B2]}\n  ue_adl: {tuning: [B1], test: [B2]}"),
     "duplicate key"),
    (GOOD + '  - {id: two, thesis: t, key: a.c, data: d, people: test, below: 1, '
            'registered: "2026-12-09", replaces: one}\n', "with a `why`"),
    (GOOD + '  - {id: two, thesis: t, key: a.c, data: d, people: test, below: 1, registered: "2026-12-01", '
            'replaces: one, why: w}\n', "cannot predate"),
    (GOOD + "extra: 1\n", "exactly the keys"),
    ("- 1\n", "exactly the keys"),
    ("registered: [\n", "not UTF-8 YAML"),
    (GOOD.replace("ue_adl: {tuning: [A1], test: [B1, B2]}", "ue_adl: {tuning: [A1]}"),
     "exactly tuning and test"),
])
def test_bad_claims_files_are_refused_naming_the_field(tmp_path, text, message):
    path = tmp_path / "claims.yaml"
    path.write_text(text)
    with pytest.raises(ClaimsError, match=message):
        load_claims(path)


def test_a_replacement_keeps_the_claim_it_replaces(tmp_path):
    path = tmp_path / "claims.yaml"
    path.write_text(GOOD + '  - {id: two, thesis: t, key: a.c, data: d, people: test, below: 1, '
                           'registered: "2026-12-09", replaces: one, '
                           'why: "the metric named the wrong windows"}\n')
    claims = load_claims(path)
    assert [c.id for c in claims.claims] == ["one", "two"]
    assert evaluate(claims, {}, "test")["two"]["replaces"] == "one"


def test_an_oversized_or_binary_file_is_refused(tmp_path):
    big = tmp_path / "big.yaml"
    big.write_text("# x\n" * 60_000)
    with pytest.raises(ClaimsError, match="more than a claims file"):
        load_claims(big)
    binary = tmp_path / "bin.yaml"
    binary.write_bytes(b"\xff\xfe\x00")
    with pytest.raises(ClaimsError, match="not UTF-8 YAML"):
        load_claims(binary)
    with pytest.raises(ClaimsError, match="cannot be read"):
        load_claims(tmp_path / "missing.yaml")


def test_people_are_chosen_by_the_claims_file_or_by_the_folder(tmp_path):
    from hrc_drake.datasets import dataset_dir
    from hrc_drake.real_claims import select_people

    shipped = dataset_dir("ue_adl")
    assert select_people(shipped, "tuning") == ("ADL001", "ADL002")
    assert select_people(shipped, "test") == load_claims().people_of("ue_adl", "test")
    assert len(select_people(shipped, "folder")) == 9
    # another folder's people (held out): every participant folder there, oddly named ones skipped
    for name in ("ADL011", "ADL016", "bad name", "x\x1by"):
        (tmp_path / name).mkdir()
    (tmp_path / "ADL099.csv").write_text("")
    assert select_people(tmp_path, "folder") == ("ADL011", "ADL016")
    with pytest.raises(ClaimsError, match=r"the test people \['ADL004'.* are not there"):
        select_people(tmp_path, "test")
    with pytest.raises(ClaimsError, match="people must be one of"):
        select_people(tmp_path, "everyone")
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "x y").mkdir()
    with pytest.raises(ClaimsError, match="holds no participant folders"):
        select_people(empty, "folder")
