"""Recorded skeleton CSV: round trip and errors with line numbers."""

import numpy as np
import pytest

from hrc_drake.human.recorded import HEADER, frame_at, load_skeleton_csv, save_skeleton_csv


def sample(T=5, seed=0):
    """A standing person's skeleton (the body model at rest) with 1 cm noise, some points untracked."""
    from hrc_drake.human.body import BodyModel

    rng = np.random.default_rng(seed)
    times = np.cumsum(rng.uniform(0.02, 0.05, T))
    body = BodyModel()
    points = body.points(body.rest_q((1.0, 0.0), np.pi))[None] + rng.normal(0, 0.01, (T, 8, 3))
    tracked = rng.uniform(size=(T, 8)) > 0.3
    points[~tracked] = np.nan
    return times, points, tracked


def test_header():
    assert HEADER[:4] == ("time", "thorax_x", "thorax_y", "thorax_z")
    assert HEADER[-1] == "right_wrist_tracked" and len(HEADER) == 33


def test_round_trip(tmp_path):
    times, points, tracked = sample()
    path = tmp_path / "skel.csv"
    save_skeleton_csv(path, times, points, tracked)
    t2, p2, k2 = load_skeleton_csv(path)
    np.testing.assert_array_equal(t2, times)
    np.testing.assert_array_equal(k2, tracked)
    np.testing.assert_array_equal(p2[tracked], points[tracked])
    assert np.all(np.isnan(p2[~tracked]))
    assert p2.shape == (5, 8, 3) and k2.dtype == bool


def test_untracked_values_are_dropped(tmp_path):
    times, points, tracked = sample()
    points = np.nan_to_num(points, nan=7.0)  # untracked rows hold numbers: they are ignored
    path = tmp_path / "s.csv"
    save_skeleton_csv(path, times, points, tracked)
    assert np.all(np.isnan(load_skeleton_csv(path)[1][~tracked]))


def write_rows(tmp_path, rows):
    path = tmp_path / "bad.csv"
    path.write_text(",".join(HEADER) + "\n" + "\n".join(rows) + "\n")
    return path


def _person() -> list[str]:
    """The 24 coordinates of a standing person (the body model at rest), as CSV cells."""
    from hrc_drake.human.body import BodyModel

    body = BodyModel()
    return [repr(float(v)) for v in body.points(body.rest_q((1.0, 0.0), np.pi)).reshape(-1)]


def good_row(t=0.0):
    return ",".join([str(t)] + _person() + ["1"] * 8)


@pytest.mark.parametrize(
    "row, message",
    [
        (",".join(["0.1"] + ["0.5"] * 24 + ["1"] * 7), r":3: expected 33 values, got 32"),
        (",".join(["0.1", "abc"] + ["0.5"] * 23 + ["1"] * 8),
         r":3: column 'thorax_x': 'abc' is not a number"),
        (",".join(["0.1"] + ["nan"] * 3 + ["0.5"] * 21 + ["1"] * 8), r":3: point 'thorax' is tracked"),
        (",".join(["0.1"] + ["0.5"] * 24 + ["1"] * 7 + ["2"]),
         r":3: column 'right_wrist_tracked' must be 0 or 1"),
        (",".join(["0.0"] + ["0.5"] * 24 + ["1"] * 8), r":3: time 0.0 does not increase"),
    ],
)
def test_bad_rows(tmp_path, row, message):
    path = write_rows(tmp_path, [good_row(0.0), row])
    with pytest.raises(ValueError, match=message):
        load_skeleton_csv(path)


def test_nan_allowed_when_untracked(tmp_path):
    row = ",".join(["0.1"] + ["nan"] * 3 + _person()[3:] + ["0"] + ["1"] * 7)
    times, points, tracked = load_skeleton_csv(write_rows(tmp_path, [good_row(0.0), row]))
    assert not tracked[1, 0] and tracked[1, 1:].all()


def test_bad_header_and_empty(tmp_path):
    path = tmp_path / "h.csv"
    path.write_text("t,a,b\n1,2,3\n")
    with pytest.raises(ValueError, match=":1: bad header"):
        load_skeleton_csv(path)
    path.write_text("")
    with pytest.raises(ValueError, match="empty"):
        load_skeleton_csv(path)
    path.write_text(",".join(HEADER) + "\n")
    with pytest.raises(ValueError, match="no data rows"):
        load_skeleton_csv(path)


def test_save_errors(tmp_path):
    times, points, tracked = sample()
    tracked[2, 3] = True
    points[2, 3] = np.nan
    with pytest.raises(ValueError, match="row 2 point 'right_shoulder'"):
        save_skeleton_csv(tmp_path / "x.csv", times, points, tracked)
    with pytest.raises(ValueError, match="increasing"):
        save_skeleton_csv(tmp_path / "x.csv", times[::-1], np.zeros((5, 8, 3)))


def test_frame_at():
    times = np.array([0.0, 0.1, 0.2])
    assert [frame_at(times, t) for t in (-1.0, 0.0, 0.05, 0.1, 0.25)] == [0, 0, 0, 1, 2]


@pytest.mark.parametrize("scale, reason", [
    (1e300, "from the cell's origin"), (100.0, "from the cell's origin"), (0.01, "outside an adult's")])
def test_a_skeleton_no_person_could_make_is_refused(tmp_path, scale, reason):
    times, points, tracked = sample()
    tracked[:] = True
    with np.errstate(over="ignore"):
        points = np.where(np.isfinite(points), points, 1.0) * scale
    path = tmp_path / "scaled.csv"
    save_skeleton_csv(path, times, points, tracked)
    with pytest.raises(ValueError, match=reason):
        load_skeleton_csv(path)
