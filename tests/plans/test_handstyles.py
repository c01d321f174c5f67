"""Handstyles: presets, semi-tied covariances (seed 000 eq. 22), user styles, realisation."""

from __future__ import annotations

from dataclasses import fields, replace

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
    basis = handstyle_from_mapping({"basis": [[1, 0.5], [0, 1]]}).basis
    assert np.allclose(basis, [[1, 0.5], [0, 1]])  # H written row by row, as in a plan file
    assert np.allclose(basis[:, 1], [0.5, 1.0])  # its columns are the basis vectors


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
        ({"basis": [[1, 0]]}, r"basis must be H as a finite 2 x 2 matrix, written row by row"),
        ({"basis": [[1, 0], [0, 1]], "slant": 10.0}, "either basis or slant"),
        ({"base": "nope"}, "unknown handstyle 'nope'"),
        ({"max_spacing": 0.0}, "max_spacing must be a positive number"),
        ({"eyelet": -0.1}, r"eyelet must be in \[0, 1\]"),
        ({"eyelet": 2.0}, r"eyelet must be in \[0, 1\] \(a fraction of the letter height\)"),
        ({"eyelet": "big"}, "eyelet must be a number"),
    ],
)
def test_user_style_errors_name_the_key(table, message):
    with pytest.raises(ScenarioError, match=message):
        handstyle_from_mapping(table, where="styles.mine")


def test_user_style_error_names_where_it_came_from():
    with pytest.raises(ScenarioError, match=r"^styles\.mine: unknown key 'colour'") as info:
        handstyle_from_mapping({"colour": "red"}, where="styles.mine")
    assert info.value.key == "styles.mine" and info.value.value == "colour"
    assert "slant" in info.value.choices


def test_style_file_errors_carry_the_file_key_and_value(tmp_path):
    path = tmp_path / "styles.toml"
    path.write_text('[styles.a]\nh = -2.0\n')
    message = r"styles\.toml: styles\.a: h must be a positive"
    with pytest.raises(ScenarioError, match=message) as info:
        load_handstyles(path)
    assert (info.value.file, info.value.key, info.value.value) == (str(path), "styles.a", -2.0)


def test_presets_are_read_from_the_data_file_like_a_user_file():
    from inkarm.plans.handstyles import PRESETS_FILE, _read_styles

    assert PRESETS_FILE.name == "handstyles.toml" and PRESETS_FILE.parent.name == "data"
    again = _read_styles(PRESETS_FILE, {}, default_base=None)
    assert list(again) == list(PRESETS) == [
        "faithful", "cursive", "loose", "italic", "hurried", "graffiti"
    ]
    for name, style in again.items():
        assert style.name == name and style.description
        assert np.array_equal(style.basis, PRESETS[name].basis)
        for f in fields(style):
            if f.name != "basis":
                assert getattr(style, f.name) == getattr(PRESETS[name], f.name), (name, f.name)
    assert np.allclose(PRESETS["cursive"].basis, slanted_basis(20.0, 1.5))
    assert PRESETS["cursive"].max_spacing is None  # presets start from the Handstyle defaults
    with pytest.raises(TypeError):
        PRESETS["mine"] = PRESETS["faithful"]  # read-only


def test_a_style_file_may_base_a_style_on_one_above_it(tmp_path):
    path = tmp_path / "styles.toml"
    path.write_text('[styles.a]\nbase = "loose"\nh = 3.0\n[styles.b]\nbase = "a"\nd = 0.2\n')
    styles = load_handstyles(path)
    assert styles["b"].h == 3.0 and styles["b"].order == PRESETS["loose"].order


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


@pytest.mark.parametrize(
    "H", [[[1.0, 0.6], [0.0, 1.0]], [[1.6, 0.3], [0.0, 0.6]], [[2.0, 0.0], [1.0, 1.0]]]
)
def test_the_same_H_in_a_plan_file_and_a_style_file_gives_the_same_covariances(H):
    import tomllib

    from inkarm.io.planfile import parse_plan

    rows = ", ".join(f"[{a}, {b}]" for a, b in H)
    plan = parse_plan(tomllib.loads(f"""
[semi_tied]
H = [{rows}]
h = 4.0
[[strokes]]
targets = [{{ mean = [0.0, 0.0] }}, {{ mean = [5.0, 5.0] }}, {{ mean = [9.0, 0.0] }}]
"""))
    style = handstyle_from_mapping({"basis": H, "h": 4.0, "rho": 0.0})
    covs = style.covariances(3, np.random.default_rng(0))
    np.testing.assert_allclose(covs, plan.strokes[0].plan.covs)
    np.testing.assert_allclose(covs[0], 4.0 * np.array(H) @ np.array(H).T)  # Sigma = h H H^T


def test_eyelet_is_a_style_setting_and_0_selects_the_papers_drop_rule():
    assert all(style.eyelet == 0.1 for style in PRESETS.values())
    mine = handstyle_from_mapping({"base": "cursive", "eyelet": 0.0}, name="dropper")
    assert mine.eyelet == 0.0 and mine.ligature_angle == PRESETS["cursive"].ligature_angle
