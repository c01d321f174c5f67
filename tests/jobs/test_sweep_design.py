"""Sweep designs: axes parsed from ``--set``, grid / zip / random designs, seeds, stable point
ids, and every point checked by the scenario's own rules before anything runs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from inkarm.errors import InputError
from inkarm.jobs.scenario import load_scenario
from inkarm.jobs.sweep.design import (
    grid_design,
    make_points,
    parse_axis,
    parse_seeds,
    point_id,
    random_design,
    validate,
    with_point,
    zip_design,
)

QUICK = Path(__file__).parents[2] / "scenarios" / "quick_stroke.toml"


def test_axes_from_set_options():
    a = parse_axis("controller.force_n=0.5:2.0:7")
    assert a.key == "controller.force_n" and a.grid_values() == tuple(np.linspace(0.5, 2.0, 7))
    assert parse_axis("source.sample=0:4:5").grid_values() == (0, 1, 2, 3, 4)
    assert all(isinstance(v, int) for v in parse_axis("x=0:4:5").grid_values())
    assert parse_axis("x=0:3:3").grid_values() == (0.0, 1.5, 3.0)  # step not an integer
    assert parse_axis("ink.model=marker,brush").grid_values() == ("marker", "brush")
    assert parse_axis("controller.go_home=true,false").grid_values() == (True, False)
    assert parse_axis("robot.gains.kp=400").grid_values() == (400,)
    assert parse_axis("x=1e3,2.5").grid_values() == (1000.0, 2.5)


@pytest.mark.parametrize(("text", "message"), [
    ("controller.force_n", "expected KEY=lo:hi:n"),
    ("=1", "expected KEY=lo:hi:n"),
    ("x=1:2:0", "count n >= 1"),
    ("x=1:2:2.5", "count n >= 1"),
    ("x=a:b:3", "a range needs numbers"),
    ("x=1:2:3:4", "expected lo:hi or lo:hi:n"),
    ("x=nan", "finite number"),
    ("x=1,,2", "empty value"),
])
def test_bad_axes_are_refused_naming_the_option(text, message):
    with pytest.raises(InputError, match=message) as e:
        parse_axis(text)
    assert e.value.key.startswith("--set")


def test_a_range_without_a_count_is_for_random_designs_only():
    axis = parse_axis("x=0.5:2")
    with pytest.raises(InputError, match="without a count"):
        grid_design([axis])
    assert len(random_design([axis], 5)) == 5


def test_grid_zip_and_their_sizes():
    a, b = parse_axis("a=1:3:3"), parse_axis("b=x,y")
    grid = grid_design([a, b])
    assert grid == [{"a": 1, "b": "x"}, {"a": 1, "b": "y"}, {"a": 2, "b": "x"},
                    {"a": 2, "b": "y"}, {"a": 3, "b": "x"}, {"a": 3, "b": "y"}]
    assert zip_design([a, parse_axis("b=x,y,z")]) == [
        {"a": 1, "b": "x"}, {"a": 2, "b": "y"}, {"a": 3, "b": "z"}]
    with pytest.raises(InputError, match="one length"):
        zip_design([a, b])


@given(n=st.integers(1, 40), seed=st.integers(0, 2**32 - 1))
def test_random_designs_stratify_every_range_and_repeat_with_their_seed(n, seed):
    axes = [parse_axis("a=0.5:2.0"), parse_axis("b=-3:7"), parse_axis("c=x,y")]
    design = random_design(axes, n, seed)
    assert design == random_design(axes, n, seed)
    a = np.array([p["a"] for p in design])
    assert np.all((a >= 0.5) & (a <= 2.0))
    # a Latin hypercube puts exactly one point in each of the n equal slices of the range
    assert sorted(np.minimum(((a - 0.5) / 1.5 * n).astype(int), n - 1)) == list(range(n))
    assert all(isinstance(p["b"], int) and -3 <= p["b"] <= 7 for p in design)
    assert {p["c"] for p in design} <= {"x", "y"}


def test_seeds():
    assert parse_seeds("0:16") == tuple(range(16))
    assert parse_seeds("3,5") == (3, 5)
    for bad in ("a:b", "5:5", "-1,2", ""):
        with pytest.raises(InputError, match="--seeds|seeds"):
            parse_seeds(bad)


def test_point_ids_depend_on_values_and_seed_not_on_position():
    design = grid_design([parse_axis("a=1:3:3")])
    points = make_points(design, (0, 1))
    assert [p.index for p in points] == list(range(6))
    assert len({p.point_id for p in points}) == 6
    again = make_points(list(reversed(design)), (1, 0))
    assert {p.point_id for p in points} == {p.point_id for p in again}
    assert points[0].point_id == point_id({"a": 1}, 0)
    assert points[0].overrides() == {"a": 1, "seed": 0}
    with pytest.raises(InputError, match="repeats a point"):
        make_points(grid_design([parse_axis("a=1,1")]), (0,))


def test_every_point_is_checked_before_anything_runs():
    scenario = load_scenario(QUICK)
    good = make_points(grid_design([parse_axis("controller.force_n=0.5:1.5:3")]), (0,))
    validate(scenario, good)
    typo = make_points(grid_design([parse_axis("controller.forse_n=1")]), (0,))
    with pytest.raises(InputError, match="point 0 .*controller.forse_n.*did you mean 'force_n'"):
        validate(scenario, typo)
    bad = make_points(grid_design([parse_axis("controller.force_n=1.0,-1.0")]), (0,))
    with pytest.raises(InputError, match=r"point 1 \(controller.force_n=-1.0, seed 0\).*force_n"):
        validate(scenario, bad)


def test_overriding_a_point_leaves_the_scenario_as_it_was():
    scenario = load_scenario(QUICK)
    changed = with_point(scenario, {"source.plan.model.d": 10.0})
    assert changed.source.plan["model"]["d"] == 10.0
    assert scenario.source.plan["model"]["d"] == 5.0


@pytest.mark.parametrize(("args", "message"), [
    (["--set", "controller.force_n=0:1:1000000", "--set", "controller.hover_mm=0:1:1000000"],
     "1000000000000 runs (1000000 x 1000000 design"),
    (["--set", "controller.force_n=0:1:1000000000000"], "1000000000000 runs"),
    (["--set", "controller.force_n=0:1", "--random", "1000000000"], "1000000000 runs (random"),
    (["--set", "controller.force_n=1", "--seeds", "0:1000000000"], "1000000000 seeds"),
    (["--set", "controller.force_n=1,2", "--seeds", "0:60000"], "120000 runs"),
    (["--set", "controller.forse_n=0:1:1000"], "did you mean 'force_n'"),
])
def test_budgets_are_refused_from_the_request_before_any_point_is_made(
        tmp_path, capsys, monkeypatch, args, message):
    """A design too big for a sweep is refused from the axes' sizes: no design, point or
    scenario copy is made (each would take minutes or all the memory)."""
    from inkarm.cli import main
    from inkarm.jobs.sweep import design

    def never(*a, **k):
        raise AssertionError("a design was made before the budget was checked")

    for name in ("grid_design", "zip_design", "random_design"):
        monkeypatch.setattr(design, name, never)
    scenario = Path(__file__).parents[2] / "scenarios" / "quick_stroke.toml"
    assert main(["sweep", str(scenario), "--out", str(tmp_path / "s"), *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not (tmp_path / "s").exists()
