"""Trajectory and Drawing: validation, resampling, file round trips."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.analysis import kinematics
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError


def _circle(n: int = 50, r: float = 10.0) -> Trajectory:
    t = np.linspace(0.0, 1.0, n)
    return Trajectory(t=t, pos=np.column_stack([r * np.cos(2 * np.pi * t), r * np.sin(2 * np.pi * t)]))


def test_speed_of_uniform_circle_is_circumference_over_period():
    traj = _circle(2001)
    assert np.allclose(traj.speed()[1:-1], 2 * np.pi * 10.0, rtol=1e-4)
    assert traj.length == pytest.approx(2 * np.pi * 10.0, rel=1e-5)


def test_resample_keeps_end_points_and_interpolates_linearly():
    traj = Trajectory(t=[0.0, 1.0], pos=[[0.0, 0.0], [10.0, 20.0]])
    r = traj.resample(0.3)
    assert np.allclose(r.t, [0.0, 0.3, 0.6, 0.9, 1.0])
    assert np.allclose(r.pos[:, 1], 2 * r.pos[:, 0])
    assert np.allclose(r.pos[-1], [10.0, 20.0])


@given(st.floats(0.001, 0.5))
@settings(max_examples=30, deadline=None)
def test_resample_grid_is_uniform_except_last_step(dt):
    r = _circle(40).resample(dt)
    steps = np.diff(r.t)
    assert np.allclose(steps[:-1], dt)
    assert 0 < steps[-1] <= dt + 1e-12
    assert r.t[-1] == 1.0


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"t": [0, 1], "pos": [[0, 0], [np.nan, 1]]}, r"pos: non-finite value .* index \(1, 0\)"),
        ({"t": [0, 0], "pos": [[0, 0], [1, 1]]}, r"strictly increasing, but t\[1\] = 0.0"),
        ({"t": [0, 1, 2], "pos": [[0, 0], [1, 1]]}, "t has 3 samples but pos has 2 rows"),
        ({"t": [0, 1], "pos": [[0, 0, 0, 0], [1, 1, 1, 1]]}, "expected 1 to 3 columns, got 4"),
        ({"t": [], "pos": np.zeros((0, 2))}, "no samples"),
        ({"t": [0, 1], "pos": [[0, 0], [1, 1]], "pressure": [1.0]}, "pressure: shape"),
    ],
)
def test_bad_trajectories_are_refused_with_the_field_named(kwargs, match):
    with pytest.raises(InputError, match=match):
        Trajectory(**kwargs)


def test_resample_refuses_non_positive_dt():
    with pytest.raises(InputError, match="dt must be a positive number of seconds, got 0"):
        _circle().resample(0)


def test_drawing_refuses_mixed_dimensions():
    a = _circle()
    b = Trajectory(t=[0, 1], pos=[[0, 0, 0], [1, 1, 1]])
    with pytest.raises(InputError, match=r"mix dimensions \[2, 3\]"):
        Drawing([a, b])


def test_csv_round_trip_with_strokes(tmp_path):
    d = Drawing([_circle(10), _circle(7, r=3.0).shifted(dt=2.0, dpos=(50, 60))]).sequential(0.5)
    path = tmp_path / "d.csv"
    d.to_csv(path)
    assert path.read_text().splitlines()[0] == "t,x,y,stroke"
    back = Drawing.from_csv(path)
    assert len(back.strokes) == 2
    for a, b in zip(d.strokes, back.strokes):
        assert np.array_equal(a.t, b.t) and np.array_equal(a.pos, b.pos)
    assert back.strokes[1].t[0] == pytest.approx(d.strokes[0].t[-1] + 0.5)


def test_single_trajectory_csv_round_trip_3d(tmp_path):
    traj = Trajectory(t=[0.0, 0.5, 1.0], pos=[[0, 0, 1], [1, 2, 0], [3, 4, 0]])
    path = tmp_path / "t.csv"
    traj.to_csv(path)
    assert path.read_text().splitlines()[0] == "t,x,y,z"
    back = Trajectory.from_csv(path)
    assert np.array_equal(back.pos, traj.pos)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("", "empty file"),
        ("a,b,c\n1,2,3\n", "header 'a,b,c'; expected t,x,y or t,x,y,z"),
        ("t,x,y\n", "no data rows"),
        ("t,x,y\n0,1,2\n1,2\n", r":3: expected 3 fields, got 2"),
        ("t,x,y\n0,1,oops\n", r":2: non-numeric field"),
        ("t,x,y\n0,1,2\n1,nan,2\n", r":3: NaN or inf value"),
        ("t,x,y\n1,1,2\n0,1,2\n", "strictly increasing"),
    ],
)
def test_bad_csv_names_the_file_and_line(tmp_path, text, match):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=match) as e:
        Drawing.from_csv(path)
    assert "bad.csv" in str(e.value)


def test_missing_csv_is_named(tmp_path):
    with pytest.raises(InputError, match="nope.csv: no such file"):
        Drawing.from_csv(tmp_path / "nope.csv")


def test_npz_round_trip(tmp_path):
    d = Drawing([_circle(10), _circle(5).shifted(dt=3)], page_size=(100, 50))
    d.to_npz(tmp_path / "d.npz")
    back = Drawing.from_npz(tmp_path / "d.npz")
    assert back.page_size == (100.0, 50.0)
    assert [s.n for s in back.strokes] == [10, 5]


def test_svg_flips_y_into_page_frame(tmp_path):
    d = Drawing([Trajectory(t=[0, 1], pos=[[10, 20], [30, 40]])], page_size=(100, 200))
    d.to_svg(tmp_path / "d.svg")
    svg = (tmp_path / "d.svg").read_text()
    assert 'viewBox="0 0 100.0 200.0"' in svg
    assert 'points="10.000,180.000 30.000,160.000"' in svg


def test_transformed_scales_then_offsets():
    d = Drawing([Trajectory(t=[0, 1], pos=[[1, 2], [3, 4]])]).transformed(scale=2, offset=(10, 0))
    assert np.allclose(d.strokes[0].pos, [[12, 4], [16, 8]])
    lo, hi = d.bounds()
    assert np.allclose(lo, [12, 4]) and np.allclose(hi, [16, 8])


def test_csv_with_byte_order_mark_is_read(tmp_path):
    path = tmp_path / "bom.csv"
    path.write_bytes("\ufefft,x,y\n0,1,2\n1,3,4\n".encode("utf-8"))
    assert np.array_equal(Drawing.from_csv(path).strokes[0].pos, [[1, 2], [3, 4]])


def test_binary_csv_is_refused(tmp_path):
    path = tmp_path / "bin.csv"
    path.write_bytes(b"\xff\xfe\x00\x81garbage")
    with pytest.raises(InputError, match="bin.csv: not a UTF-8 text file"):
        Drawing.from_csv(path)


def test_nan_line_number_counts_blank_lines(tmp_path):
    path = tmp_path / "gaps.csv"
    path.write_text("t,x,y\n\n0,1,2\n\n1,nan,2\n")
    with pytest.raises(InputError, match=r"gaps.csv:5: NaN or inf value"):
        Drawing.from_csv(path)


def test_fractional_stroke_index_is_refused(tmp_path):
    path = tmp_path / "s.csv"
    path.write_text("t,x,y,stroke\n0,1,2,0\n1,1,2,0.5\n")
    with pytest.raises(InputError, match=r"s.csv:3: stroke must be a whole number"):
        Drawing.from_csv(path)


def test_drawing_strokes_are_a_tuple_that_cannot_grow():
    strokes = [_circle(), _circle()]
    drawing = Drawing(strokes)
    assert isinstance(drawing.strokes, tuple) and drawing.strokes[1] is strokes[1]
    strokes.append(_circle())  # the caller's list is not the drawing's
    assert len(drawing.strokes) == 2
    with pytest.raises(AttributeError):
        drawing.strokes.append(_circle())
    with pytest.raises(TypeError):
        drawing.strokes[0] = _circle()
    assert isinstance(drawing.sequential(0.1).strokes, tuple)
    assert isinstance(drawing.transformed(2.0).strokes, tuple)


@pytest.mark.parametrize(
    "t",
    [[0.0, 2.0, 1.0], [0.0, 1.0, 1.0], [0.0, np.nan, 2.0]],
    ids=["decreasing", "repeated", "NaN"],
)
def test_from_checked_refuses_times_that_do_not_increase(t):
    t = np.array(t)
    with pytest.raises(InputError, match=r"trajectory t: must be strictly increasing, but t\["):
        Trajectory.from_checked(t, np.zeros((3, 2)))
    ok = Trajectory.from_checked(np.array([0.0, 0.5, 1.0]), np.zeros((3, 2)))
    assert ok.n == 3 and ok.vel is None and ok.pressure is None


def _accelerating(n: int = 21) -> Trajectory:
    """x = t^2 (from rest), y = t^3 on a non-uniform grid: speed (2 t, 3 t^2)."""
    t = np.linspace(0.0, 1.0, n) ** 1.5
    return Trajectory(t=t, pos=np.column_stack([t**2, t**3]))


def test_speed_has_one_definition_exact_at_the_ends_of_a_quadratic():
    traj = _accelerating()
    np.testing.assert_array_equal(traj.speed(), kinematics.speed(traj))
    # Second-order differences are exact for x = t^2, also at the ends: at the start, from
    # rest, a first-order difference would give dx/dt = h (the first step) instead of 0.
    quadratic = Trajectory(t=traj.t, pos=np.column_stack([traj.t**2, 3.0 * traj.t]))
    expected = np.hypot(2.0 * traj.t, 3.0)
    np.testing.assert_allclose(quadratic.speed(), expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(kinematics.speed(quadratic), expected, rtol=1e-12, atol=1e-12)
    two = Trajectory(t=[0.0, 0.5], pos=[[0.0, 0.0], [3.0, 4.0]])
    np.testing.assert_allclose(two.speed(), [10.0, 10.0])
    np.testing.assert_array_equal(two.speed(), kinematics.speed(two))
    assert Trajectory(t=[0.0], pos=[[1.0, 2.0]]).speed().tolist() == [0.0]


# -- value equality ---------------------------------------------------------------------------


def _full(**changes) -> Trajectory:
    """A 2-D stroke with every field set; ``changes`` replaces some (fresh arrays each call)."""
    fields = {
        "t": np.array([0.0, 0.25, 1.0]),
        "pos": np.array([[0.0, 1.0], [2.0, 3.5], [4.0, -1.0]]),
        "vel": np.array([[1.0, 0.0], [2.0, 1.0], [0.0, 0.0]]),
        "pressure": np.array([0.2, 0.5, 0.1]),
    }
    fields.update(changes)
    return Trajectory(**fields)


def test_trajectories_with_equal_values_are_equal():
    a, b = _full(), _full()
    assert a.pos is not b.pos
    assert (a == b) is True and (a != b) is False
    assert _circle(9) == _circle(9)
    assert Trajectory(t=[0, 1], pos=[[0, 0], [1, 1]]) == Trajectory(
        t=np.array([0.0, 1.0]), pos=np.array([[0.0, 0.0], [1.0, 1.0]])
    )
    assert _full(pos=np.array([[0.0, 1.0], [2.0, 3.5], [4.0, -0.0]])) == _full(
        pos=np.array([[-0.0, 1.0], [2.0, 3.5], [4.0, 0.0]])
    )  # -0.0 == 0.0, as for floats


@pytest.mark.parametrize(
    "changes",
    [
        {"t": np.array([0.0, 0.25, 1.0 + 1e-15])},
        {"pos": np.array([[0.0, 1.0], [2.0, 3.5], [4.0, -1.0 + 1e-12]])},
        {"pos": np.array([[0.0, 1.0, 0.0], [2.0, 3.5, 0.0], [4.0, -1.0, 0.0]]), "vel": None},
        {"vel": None},
        {"vel": np.array([[1.0, 0.0], [2.0, 1.0], [0.0, 1e-9]])},
        {"pressure": None},
        {"pressure": np.array([0.2, 0.5, 0.2])},
        {"t": np.array([0.0, 1.0]), "pos": np.zeros((2, 2)), "vel": None, "pressure": None},
    ],
    ids=["t", "pos", "dim", "vel-None", "vel", "pressure-None", "pressure", "length"],
)
def test_trajectories_differing_in_one_field_are_unequal(changes):
    a, b = _full(), _full(**changes)
    assert (a != b) is True and (b != a) is True and (a == b) is False


def test_trajectory_and_drawing_compare_unequal_to_other_types_and_are_unhashable():
    a = _full()
    assert a != "stroke" and a != 1.0 and a != [a]
    assert Drawing([a]) != [a] and Drawing([a]) != a
    for value in (a, Drawing([a])):
        with pytest.raises(TypeError, match="unhashable"):
            hash(value)


def test_drawings_compare_strokes_page_size_and_meta():
    def make(**kw) -> Drawing:
        return Drawing([_circle(10), _full()], **kw)

    assert make() == make()
    assert make(page_size=(100, 50)) == make(page_size=(100.0, 50.0))
    assert make() != make(page_size=(297.0, 210.0))
    assert make() != Drawing([_circle(10)])
    assert make() != Drawing([_full(), _circle(10)])  # order matters
    assert make() != Drawing([_circle(10), _full(vel=None)])
    assert Drawing([]) == Drawing([]) != Drawing([_circle()])
    meta = {"style": "x", "letters": np.array([0, 1, 1])}
    assert make(meta=meta) == make(meta={"style": "x", "letters": np.array([0, 1, 1])})
    assert make(meta=meta) != make(meta={"style": "x", "letters": np.array([0, 1, 2])})
    assert make(meta=meta) != make()


def test_drawing_equals_itself_after_a_csv_and_an_npz_round_trip(tmp_path):
    d = Drawing(
        [_circle(10), _circle(7, r=3.0).shifted(dt=2.0, dpos=(50.123456789, 60.1))],
        page_size=(100.0, 50.0),
    ).sequential(0.5 + 1e-13)
    d.to_csv(tmp_path / "d.csv")
    assert Drawing.from_csv(tmp_path / "d.csv", page_size=(100.0, 50.0)) == d
    assert Drawing.from_csv(tmp_path / "d.csv") != d  # the page size is not in the file
    d.to_npz(tmp_path / "d.npz")
    assert Drawing.from_npz(tmp_path / "d.npz") == d
    with_vel = Drawing([_full()])
    with_vel.to_csv(tmp_path / "v.csv")
    assert Drawing.from_csv(tmp_path / "v.csv") != with_vel  # vel and pressure are not written
    assert Drawing.from_csv(tmp_path / "v.csv") == Drawing([_full(vel=None, pressure=None)])


def test_single_trajectory_equals_itself_after_a_csv_round_trip(tmp_path):
    traj = Trajectory(t=[0.0, 0.1 + 0.2, 1.0], pos=[[0, 0, 1], [1 / 3, 2e-17, 0], [3, 4, 0]])
    traj.to_csv(tmp_path / "t.csv")
    assert Trajectory.from_csv(tmp_path / "t.csv") == traj
