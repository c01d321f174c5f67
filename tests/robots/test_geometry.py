"""Geometric errors of the arm and pen (inkarm.robots.geometry): each edit against its closed
form, a model and its believed twin with the same errors agree, and every refusal names its
field."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from inkarm.errors import InputError
from inkarm.robots.geometry import GeometryErrors, apply_geometry
from inkarm.sim.cell import PEN_TIP, build_model, kinematic_model, make_cell

pytestmark = pytest.mark.sim

CELL = make_cell()
NAMES = CELL.robot.joint_names
N = len(NAMES)


def _poses(model: mujoco.MjModel, q: np.ndarray) -> mujoco.MjData:
    data = mujoco.MjData(model)
    data.qpos[:N] = q
    mujoco.mj_kinematics(model, data)
    return data


def _site(model: mujoco.MjModel, name: str = PEN_TIP) -> int:
    return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name)


def _errors(rng: np.random.Generator) -> GeometryErrors:
    return GeometryErrors(link_length_mm=(0.0, *rng.uniform(-1.0, 1.0, N - 1)),
                          joint_offset_deg=tuple(rng.uniform(-0.2, 0.2, N)),
                          tip_offset_mm=tuple(rng.uniform(-2.0, 2.0, 3)))


def test_no_errors_is_zero_and_changes_nothing():
    assert GeometryErrors().is_zero
    assert GeometryErrors(link_length_mm=(0.0,) * N, joint_offset_deg=(0.0,) * N).is_zero
    assert not GeometryErrors(tip_offset_mm=(0.0, 0.0, 0.1)).is_zero
    model, nominal = build_model(CELL), build_model(CELL)
    apply_geometry(model, NAMES, GeometryErrors())
    for name in ("body_pos", "body_quat", "site_pos", "geom_pos"):
        assert np.array_equal(getattr(model, name), getattr(nominal, name)), name


def test_a_model_and_its_believed_twin_with_the_same_errors_agree_at_random_poses():
    rng = np.random.default_rng(0)
    errors = _errors(rng)
    plant, twin = build_model(CELL), build_model(CELL)
    apply_geometry(plant, NAMES, errors)
    apply_geometry(twin, NAMES, errors)
    nominal = build_model(CELL)
    for _ in range(20):
        q = rng.uniform(-1.5, 1.5, N)
        a, b, c = _poses(plant, q), _poses(twin, q), _poses(nominal, q)
        tip = _site(plant)
        assert np.abs(a.site_xpos[tip] - b.site_xpos[tip]).max() < 1e-12
        assert np.linalg.norm(a.site_xpos[tip] - c.site_xpos[tip]) > 1e-4  # the errors act


def test_the_calibrated_belief_carries_the_errors_and_the_height_map():
    from inkarm.robots.calibration import CellCalibration, HeightMap

    rng = np.random.default_rng(1)
    errors = _errors(rng)
    paper = HeightMap(x_mm=np.array([0.0, 210.0]), y_mm=np.array([0.0, 297.0]),
                      z_mm=np.array([[0.1, 0.2], [0.3, 0.4]]))
    believed = kinematic_model(CELL, CellCalibration(robot=CELL.robot.name, paper=paper,
                                                     geometry=errors))
    assert believed.paper_map is paper and kinematic_model(CELL).paper_map is None
    truth = build_model(CELL)
    apply_geometry(truth, NAMES, errors)
    q = rng.uniform(-1.0, 1.0, N)
    tip = _site(truth)
    assert np.abs(_poses(truth, q).site_xpos[tip]
                  - _poses(believed.model, q).site_xpos[tip]).max() < 1e-12


def test_a_joint_offset_puts_the_link_where_the_nominal_arm_has_it_at_q_plus_offset():
    rng = np.random.default_rng(2)
    offsets = rng.uniform(-0.2, 0.2, N)
    model, nominal = build_model(CELL), build_model(CELL)
    apply_geometry(model, NAMES, GeometryErrors(joint_offset_deg=tuple(offsets)))
    for _ in range(5):
        q = rng.uniform(-1.5, 1.5, N)
        a, b = _poses(model, q), _poses(nominal, q + np.radians(offsets))
        assert np.abs(a.xpos - b.xpos).max() < 1e-12
        assert np.abs(a.xmat - b.xmat).max() < 1e-12


def test_a_link_length_error_moves_the_next_joint_along_the_link():
    model, nominal = build_model(CELL), build_model(CELL)
    lengths = (0.0, 0.0, 0.0, 1.5, 0.0, 0.0, 0.0)
    apply_geometry(model, NAMES, GeometryErrors(link_length_mm=lengths))
    body = model.jnt_bodyid[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, NAMES[3])]
    before, after = nominal.body_pos[body], model.body_pos[body]
    assert np.linalg.norm(after) - np.linalg.norm(before) == pytest.approx(1.5e-3, abs=1e-15)
    assert np.cross(before, after) == pytest.approx(np.zeros(3), abs=1e-15)  # same direction


def test_the_tip_offset_is_in_the_flange_frame():
    offset = np.array([0.7, -1.2, 2.0])
    model, nominal = build_model(CELL), build_model(CELL)
    apply_geometry(model, NAMES, GeometryErrors(tip_offset_mm=tuple(offset)))
    rng = np.random.default_rng(3)
    flange = _site(model, "flange")
    for _ in range(5):
        q = rng.uniform(-1.5, 1.5, N)
        a, b = _poses(model, q), _poses(nominal, q)
        rot = b.site_xmat[flange].reshape(3, 3)
        expected = b.site_xpos[_site(nominal)] + rot @ offset / 1000.0
        assert np.abs(a.site_xpos[_site(model)] - expected).max() < 1e-12
        tip_geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, PEN_TIP)
        assert np.abs(a.geom_xpos[tip_geom] - b.geom_xpos[tip_geom]
                      - rot @ offset / 1000.0).max() < 1e-12


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"link_length_mm": (0.5, 0.1)}, (r"link_length_mm: expected 0 first \(no link before "
                                     r"joint 0\), got 0.5")),
    ({"tip_offset_mm": (1.0, 2.0)}, r"tip_offset_mm: expected 3 numbers"),
    ({"joint_offset_deg": (0.1, math.nan)}, r"joint_offset_deg: expected finite numbers"),
    ({"joint_offset_deg": ("a",)}, r"joint_offset_deg: expected numbers, got \('a',\)"),
])
def test_bad_errors_are_refused_naming_the_field(kwargs, message):
    with pytest.raises(InputError, match=message):
        GeometryErrors(**kwargs)


def test_apply_refuses_what_the_model_cannot_take():
    model = build_model(CELL)
    with pytest.raises(InputError, match=r"joint_offset_deg: expected 7 numbers \(one per "
                                         r"joint: joint1"):
        apply_geometry(model, NAMES, GeometryErrors(joint_offset_deg=(0.1, 0.2)))
    with pytest.raises(InputError, match=r"the model has no joint 'elbow'"):
        apply_geometry(model, ("elbow",), GeometryErrors())
    with pytest.raises(InputError, match=r"tip_site: apply_geometry: the model has no site "
                                         r"'nib'"):
        apply_geometry(model, NAMES, GeometryErrors(tip_offset_mm=(0, 0, 1)), tip_site="nib")
    with pytest.raises(InputError, match=r"joint 'pen_slide' is not a hinge"):
        apply_geometry(model, ("pen_slide",), GeometryErrors(joint_offset_deg=(0.1,)))
