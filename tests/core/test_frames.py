"""The page-to-robot transform."""

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.core.frames import PagePlacement
from inkarm.errors import InputError
from inkarm.sim.cell import CellConfig, build_model, make_cell, page_placement, paper_rotation

PAGE = PagePlacement(np.array([0.4, 0.1, 0.02]), paper_rotation(25.0), (210.0, 297.0))


def test_origin_and_axes_map_as_defined():
    np.testing.assert_allclose(PAGE.to_robot([0.0, 0.0]), [0.4, 0.1, 0.02])
    R = paper_rotation(25.0)
    np.testing.assert_allclose(PAGE.to_robot([1000.0, 0.0, 0.0]) - PAGE.origin_m, R[:, 0])
    np.testing.assert_allclose(PAGE.to_robot([0.0, 0.0, 10.0]) - PAGE.origin_m, [0, 0, 0.01])
    np.testing.assert_allclose(PAGE.pen_axis, [0, 0, -1])
    np.testing.assert_allclose(PAGE.normal, [0, 0, 1])


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(-500, 500), min_size=3, max_size=3))
def test_round_trip_and_distances_are_preserved(p):
    p = np.array(p)
    r = PAGE.to_robot(p)
    np.testing.assert_allclose(PAGE.to_page(r), p, atol=1e-9)
    assert np.linalg.norm(r - PAGE.origin_m) * 1000.0 == pytest.approx(np.linalg.norm(p), abs=1e-9)


def test_arrays_of_points_and_two_column_input():
    pts = np.array([[0.0, 0.0], [10.0, 20.0]])
    out = PAGE.to_robot(pts)
    assert out.shape == (2, 3)
    np.testing.assert_allclose(out[1], PAGE.to_robot([10.0, 20.0, 0.0]))


@pytest.mark.sim
def test_page_placement_reads_the_sheet_from_a_cell_model():
    config = CellConfig(paper_size_mm=(148.0, 210.0), paper_centre_mm=(520.0, -30.0))
    model = build_model(make_cell(config))
    page = page_placement(model)
    assert page.size_mm == pytest.approx((148.0, 210.0))
    centre = page.to_robot([74.0, 105.0])
    np.testing.assert_allclose(centre[:2], [0.52, -0.03], atol=1e-12)


def test_contains_checks_the_sheet_with_a_margin():
    inside = PAGE.contains([[1.0, 1.0], [209.0, 296.0], [-0.1, 5.0], [5.0, 297.5]])
    assert inside.tolist() == [True, True, False, False]
    assert PAGE.contains([[1.0, 1.0]], margin_mm=2.0).tolist() == [False]


def test_bad_placements_are_refused():
    with pytest.raises(InputError, match="rotation: expected a"):
        PagePlacement(np.zeros(3), np.diag([1.0, 1.0, -1.0]), (210.0, 297.0))
    with pytest.raises(InputError, match="origin_m: expected 3 finite numbers"):
        PagePlacement(np.array([0.0, np.nan, 0.0]), np.eye(3), (210.0, 297.0))
    with pytest.raises(InputError, match="size_mm: expected positive"):
        PagePlacement(np.zeros(3), np.eye(3), (0.0, 297.0))
    with pytest.raises(InputError, match="no site 'paper_origin' or geom 'paper'"):
        page_placement(mujoco.MjModel.from_xml_string("<mujoco/>"))
    assert not hasattr(PagePlacement, "from_model")  # the cell reads placements, not frames


@pytest.mark.sim
def test_the_sheet_defaults_to_the_robot_profiles():
    cell = make_cell(CellConfig())
    page = page_placement(build_model(cell))
    assert page.size_mm == pytest.approx(cell.robot.paper_size_mm)
    w, h = cell.robot.paper_size_mm
    centre = page.to_robot([w / 2, h / 2])
    np.testing.assert_allclose(centre[:2], np.array(cell.robot.paper_centre_mm) / 1000.0,
                               atol=1e-12)
