"""Handstyles: presets, semi-tied covariances (seed 000 eq. 22), user styles, realisation."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.core.plan import MotorPlan
from inkarm.errors import ScenarioError
from inkarm.plans.handstyles import (
    PRESETS,
    Handstyle,
    get_handstyle,
    handstyle_from_mapping,
    load_handstyles,
    slanted_basis,
)


def test_presets_include_a_most_faithful_script_style_and_expressive_ones():
    faithful = PRESETS["faithful"]
    smoothing = {name: np.sqrt(s.h) / s.d for name, s in PRESETS.items()}
    assert min(smoothing, key=smoothing.get) == "faithful"
    assert faithful.thin_angle == 0.0 and faithful.max_spacing is not None
    others = [s for s in PRESETS.values() if s.name != "faithful"]
    assert any(s.order == 5 for s in others)
    assert any(abs(s.basis[0, 1]) > 0.1 for s in others)  # a slanted basis
    assert any(s.rho > 0 for s in others)
    assert all(s.h > faithful.h for s in others)


@given(slant=st.floats(-60, 60), stretch=st.floats(0.2, 5.0))
@settings(max_examples=30, deadline=None)
def test_slanted_basis_second_axis_leans_by_the_slant(slant, stretch):
    H = slanted_basis(slant, stretch)
    assert np.allclose(H[:, 0], [1.0, 0.0])
    v = H[:, 1]
    assert np.linalg.norm(v) == pytest.approx(stretch)
    assert np.degrees(np.arctan2(v[0], v[1])) == pytest.approx(slant, abs=1e-9)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_covariances_without_rho_are_h_H_Ht(name):
    style = replace(PRESETS[name], rho=0.0)
    covs = style.covariances(4, np.random.default_rng(0))
    expected = style.h * style.basis @ style.basis.T  # seed 000 eq. 22 with D_i = h I
    assert np.allclose(covs, expected[None])


def test_covariances_with_rho_are_semi_tied_and_seeded():
    style = Handstyle("t", basis=slanted_basis(30, 2.0), h=1.0, rho=0.2)
    a = style.covariances(50, np.random.default_rng(7))
    b = style.covariances(50, np.random.default_rng(7))
    assert np.array_equal(a, b)
    shared = style.basis @ style.basis.T
    scale = a[:, 0, 0] / shared[0, 0]
    assert np.allclose(a, scale[:, None, None] * shared[None])  # one shared shape, h_i varies
    assert scale.std() > 0.1 and np.all(scale > 0)


def test_stroke_plan_carries_timing_and_meta():
    style = PRESETS["cursive"]
    plan = style.stroke_plan(np.array([[0.0, 0.0], [5.0, 1.0]]), np.random.default_rng(0), {"k": 1})
    assert plan.segment_time == style.segment_time
    assert plan.meta == {"k": 1}
    assert np.allclose(plan.means, [[0, 0], [5, 1]])


def test_realise_times_strokes_one_after_another():
    style = PRESETS["faithful"]
    rng = np.random.default_rng(0)
    strokes = (
        style.stroke_plan(np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 3.0]]), rng),
        style.stroke_plan(np.array([[10.0, 0.0], [12.0, 2.0]]), rng),
    )
    drawing = style.realise(MotorPlan(strokes), pen_up_time=0.3, page_size=(100.0, 50.0))
    assert drawing.page_size == (100.0, 50.0)
    first, second = drawing.strokes
    assert first.t[0] == 0.0
    assert second.t[0] == pytest.approx(first.t[-1] + 0.3)
    assert np.allclose(first.pos[0], [0, 0]) and np.allclose(second.pos[0], [10, 0])
    assert drawing.meta["style"] == "faithful"


def test_user_style_from_mapping_starts_from_a_base_preset():
    style = handstyle_from_mapping({"base": "loose", "h": 0.5, "slant": 20.0}, name="mine")
    assert style.name == "mine" and style.h == 0.5
    assert style.order == PRESETS["loose"].order
    assert np.allclose(style.basis, slanted_basis(20.0))
    basis = handstyle_from_mapping({"basis": [[1, 0], [0.5, 1]]}).basis
    assert np.allclose(basis[:, 1], [0.5, 1.0])  # basis vectors are the columns of H


@pytest.mark.parametrize(
    "table, message",
    [
        ({"hh": 1.0}, "unknown key 'hh'"),
        ({"h": -1.0}, "h must be a positive number"),
        ({"h": "big"}, "h must be a number"),
        ({"order": 9}, "order must be an integer in 1..7"),
        ({"order": 4.5}, "order must be an integer"),
        ({"rho": -0.1}, "rho must be >= 0"),
        ({"thin_angle": 200.0}, r"thin_angle must be in \[0, 180\]"),
        ({"basis": [[1, 0], [2, 0]]}, "parallel"),
        ({"basis": [[1, 0]]}, "basis must be two finite 2-D vectors"),
        ({"basis": [[1, 0], [0, 1]], "slant": 10.0}, "either basis or slant"),
        ({"base": "nope"}, "unknown handstyle 'nope'"),
        ({"max_spacing": 0.0}, "max_spacing must be a positive number"),
    ],
)
def test_user_style_errors_name_the_key(table, message):
    with pytest.raises(ScenarioError, match=message):
        handstyle_from_mapping(table, where="styles.mine")


def test_user_style_error_names_where_it_came_from():
    with pytest.raises(ScenarioError, match=r"^styles\.mine: unknown key 'colour'"):
        handstyle_from_mapping({"colour": "red"}, where="styles.mine")


def test_load_handstyles_from_toml(tmp_path):
    path = tmp_path / "styles.toml"
    path.write_text(
        '[styles.wide]\nbase = "cursive"\nh = 2.0\norder = 5\n\n[styles.tight]\nd = 0.1\n'
    )
    styles = load_handstyles(path)
    assert set(styles) == {"wide", "tight"}
    assert styles["wide"].h == 2.0 and styles["wide"].order == 5
    assert get_handstyle("wide", styles) is styles["wide"]


@pytest.mark.parametrize(
    "content, message",
    [
        ("[styles.a]\nbogus = 1\n", r"styles\.toml: styles\.a: unknown key 'bogus'"),
        ("[style.a]\nh = 1\n", "unknown key 'style'"),
        ("[styles\nh = 1", "not valid TOML"),
        ("styles = 3\n", "styles must be a table"),
    ],
)
def test_load_handstyles_errors(tmp_path, content, message):
    path = tmp_path / "styles.toml"
    path.write_text(content)
    with pytest.raises(ScenarioError, match=message):
        load_handstyles(path)


def test_load_handstyles_missing_file(tmp_path):
    with pytest.raises(ScenarioError, match="none.toml: no such handstyle file"):
        load_handstyles(tmp_path / "none.toml")


def test_unknown_style_lists_the_available_ones():
    with pytest.raises(
        ScenarioError, match="unknown handstyle 'fancy'; available: .*cursive.*faithful"
    ):
        get_handstyle("fancy")
