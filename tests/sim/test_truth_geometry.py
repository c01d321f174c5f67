"""The plant's geometric truths (link lengths, joint offsets, pen tip, base tilt): what
PlantTruth.geometry reports is what the plant's model is, against closed forms and against the
believed model with the same errors applied."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from inkarm.errors import InputError
from inkarm.robots.geometry import GeometryErrors, apply_geometry
from inkarm.sim.cell import PEN_TIP, build_model, make_cell
from inkarm.sim.imperfections import PlantTruth
from inkarm.sim.perturb import plant_model
from tests.robots.test_geometry import _poses as _data
from tests.robots.test_geometry import _site

pytestmark = pytest.mark.sim

CELL = make_cell()
NAMES = CELL.robot.joint_names
N = len(NAMES)




def test_a_scalar_link_error_keeps_its_seeded_arithmetic_bit_for_bit():
    truth = PlantTruth(link_length_error_mm=1.0, seed=4)
    model, nominal = plant_model(CELL, truth), build_model(CELL)
    _, fractions = truth.directions(N)
    for i, name in enumerate(NAMES[1:], start=1):
        body = model.jnt_bodyid[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)]
        offset = nominal.body_pos[body]
        length = float(np.linalg.norm(offset))
        # the arithmetic of inkarm 0.x, term by term
        assert np.array_equal(model.body_pos[body],
                              offset * (1.0 + truth.link_length_error_mm / 1000.0
                                        * fractions[i] / length))
    errors = truth.geometry(NAMES)
    assert errors.link_length_mm[0] == 0.0
    assert errors.link_length_mm[1:] == pytest.approx(1.0 * fractions[1:], abs=1e-15)
    assert max(abs(v) for v in errors.link_length_mm) <= 1.0


def test_the_reported_geometry_is_the_plants_kinematics():
    truth = PlantTruth(link_length_error_mm=1.0, joint_offset_error_deg=0.2,
                       pen_length_error_mm=2.0, pen_offset_mm=1.0, pen_offset_direction_deg=30.0,
                       seed=7)
    plant = plant_model(CELL, truth)
    believed = build_model(CELL)
    apply_geometry(believed, NAMES, truth.geometry(NAMES))
    rng = np.random.default_rng(0)
    tip = _site(plant, PEN_TIP)
    for _ in range(10):
        q = rng.uniform(-1.5, 1.5, N)
        a, b = _data(plant, q), _data(believed, q)
        assert np.abs(a.site_xpos[tip] - b.site_xpos[tip]).max() < 1e-12


def test_joint_offsets_are_seeded_within_their_bound_or_given_per_joint():
    errors = PlantTruth(joint_offset_error_deg=0.2, seed=3).geometry(N)
    offsets = np.array(errors.joint_offset_deg)
    assert offsets.shape == (N,) and np.all(np.abs(offsets) <= 0.2) and offsets.std() > 0.02
    assert errors == PlantTruth(joint_offset_error_deg=0.2, seed=3).geometry(N)
    assert errors != PlantTruth(joint_offset_error_deg=0.2, seed=4).geometry(N)
    # the link lengths' seeded draws are untouched by the new field
    assert (PlantTruth(link_length_error_mm=1.0, joint_offset_error_deg=0.2, seed=3)
            .geometry(N).link_length_mm == PlantTruth(link_length_error_mm=1.0, seed=3)
            .geometry(N).link_length_mm)
    exact = tuple(0.01 * i for i in range(N))
    assert PlantTruth(joint_offset_error_deg=exact).geometry(N).joint_offset_deg == \
        pytest.approx(exact)


def test_plant_joint_offsets_put_each_link_where_the_nominal_arm_has_it_at_q_plus_offset():
    offsets = np.array([0.2, -0.1, 0.05, 0.15, -0.2, 0.1, -0.05])
    plant, nominal = plant_model(CELL, PlantTruth(joint_offset_error_deg=tuple(offsets))), \
        build_model(CELL)
    q = np.random.default_rng(1).uniform(-1.0, 1.0, N)
    a, b = _data(plant, q), _data(nominal, q + np.radians(offsets))
    arm = slice(1, int(plant.jnt_bodyid[mujoco.mj_name2id(plant, mujoco.mjtObj.mjOBJ_JOINT,
                                                           NAMES[-1])]) + 1)
    assert np.abs(a.xpos[arm] - b.xpos[arm]).max() < 1e-12
    assert np.abs(a.xmat[arm] - b.xmat[arm]).max() < 1e-12


def test_a_list_of_link_errors_is_taken_exactly():
    lengths = (0.0, 0.3, -0.4, 0.5, -0.6, 0.7, -0.8)
    plant, nominal = plant_model(CELL, PlantTruth(link_length_error_mm=lengths)), \
        build_model(CELL)
    for name, dl in zip(NAMES[1:], lengths[1:], strict=True):
        body = plant.jnt_bodyid[mujoco.mj_name2id(plant, mujoco.mjtObj.mjOBJ_JOINT, name)]
        change = np.linalg.norm(plant.body_pos[body]) - np.linalg.norm(nominal.body_pos[body])
        assert 1000.0 * change == pytest.approx(dl, abs=1e-9)
    with pytest.raises(InputError, match=r"link_length_error_mm: expected 0 first \(there is "
                                         r"no link before joint 0\), got 0.2"):
        PlantTruth(link_length_error_mm=(0.2,) * N).geometry(NAMES)
    with pytest.raises(InputError, match=r"link_length_error_mm: expected 1 or 7 numbers"):
        PlantTruth(link_length_error_mm=(0.0, 0.2)).geometry(NAMES)


def test_the_plant_tip_is_the_believed_tip_plus_the_flange_rotated_offset():
    truth = PlantTruth(pen_length_error_mm=2.0, pen_offset_mm=1.0, pen_offset_direction_deg=90.0)
    assert truth.geometry(N).tip_offset_mm == pytest.approx((0.0, 1.0, 2.0), abs=1e-15)
    plant, nominal = plant_model(CELL, truth), build_model(CELL)
    offset = np.array(truth.geometry(N).tip_offset_mm) / 1000.0
    rng = np.random.default_rng(2)
    for _ in range(5):
        q = rng.uniform(-1.5, 1.5, N)
        a, b = _data(plant, q), _data(nominal, q)
        rot = b.site_xmat[_site(nominal, "flange")].reshape(3, 3)
        assert np.abs(a.site_xpos[_site(plant, PEN_TIP)]
                      - (b.site_xpos[_site(nominal, PEN_TIP)] + rot @ offset)).max() < 1e-12


@pytest.mark.parametrize(("tilt", "axis"), [(1.0, 0.0), (-2.5, 90.0), (3.0, 45.0)])
def test_a_tilted_base_turns_gravity_by_the_angle_about_the_axis(tilt, axis):
    model = plant_model(CELL, PlantTruth(base_tilt_deg=tilt, base_tilt_axis_deg=axis))
    g = build_model(CELL).opt.gravity
    a = math.radians(axis)
    u = np.array([math.cos(a), math.sin(a), 0.0])
    assert np.linalg.norm(model.opt.gravity) == pytest.approx(np.linalg.norm(g), rel=1e-15)
    angle = math.degrees(math.acos(model.opt.gravity @ g / (g @ g)))
    assert angle == pytest.approx(abs(tilt), abs=1e-9)
    assert model.opt.gravity @ u == pytest.approx(0.0, abs=1e-12)  # turned about the axis
    expected = g * math.cos(math.radians(tilt)) + np.cross(u, g) * math.sin(math.radians(tilt))
    assert model.opt.gravity == pytest.approx(expected, abs=1e-12)  # Rodrigues, u . g = 0


def test_new_fields_at_their_defaults_leave_the_plant_the_nominal_model():
    plant, nominal = plant_model(CELL, PlantTruth()), build_model(CELL)
    for name in ("body_pos", "body_quat", "site_pos", "geom_pos", "geom_contype"):
        assert np.array_equal(getattr(plant, name), getattr(nominal, name)), name
    assert np.array_equal(plant.opt.gravity, nominal.opt.gravity)
    assert plant.ngeom == nominal.ngeom and PlantTruth().geometry(NAMES) == GeometryErrors(
        tip_offset_mm=(0.0, 0.0, 0.0))


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"joint_offset_error_deg": -0.2}, (r"joint_offset_error_deg: expected a number >= 0 \(the "
                                       r"largest error; a list gives each joint's signed")),
    ({"link_length_error_mm": -1.0}, r"link_length_error_mm: expected a number >= 0"),
    ({"joint_offset_error_deg": (0.1, 11.0)}, (r"joint_offset_error_deg: expected numbers in "
                                              r"\[-10, 10\] deg, got 11.0")),
    ({"random": {"joint_offset_error_deg": (-0.2, 0.2)}},
     r"random.joint_offset_error_deg: expected a range within \[0, 10\] deg"),
    ({"base_tilt_deg": 45.0}, r"base_tilt_deg: expected a number in \[-30, 30\] deg"),
    ({"pen_offset_mm": -1.0}, r"pen_offset_mm: expected a number in \[0, 50\] mm"),
    ({"stiction_nm": (0.1, -0.1)}, r"stiction_nm: expected numbers in \[0, 500\] N m"),
    ({"readout_jitter_ms": 2000.0}, r"readout_jitter_ms: expected a number in \[0, 1000\] ms"),
    ({"relief_wavelength_mm": 1.0}, r"relief_wavelength_mm: expected a number in \[5, 2000\]"),
    ({"relief_file": 3}, r"relief_file: expected a file name, got 3"),
])
def test_bad_new_fields_are_refused_naming_the_field(kwargs, message):
    with pytest.raises(InputError, match=message):
        PlantTruth(**kwargs)


def test_the_new_scalar_fields_can_be_drawn_at_random():
    names = ("relief_wave_mm", "relief_bump_mm", "relief_bump_x_mm", "pen_length_error_mm",
             "pen_offset_mm", "joint_offset_error_deg", "base_tilt_deg", "readout_jitter_ms",
             "stiction_nm")
    truth = PlantTruth(random={name: (0.0, 1.0) for name in names}).realised(5)
    assert all(0.0 <= getattr(truth, name) <= 1.0 for name in names)
    assert len({getattr(truth, name) for name in names}) == len(names)
    assert PlantTruth(random={"joint_offset_error_deg": (0.1, 0.2)}, seed=2).geometry(N) == \
        PlantTruth(joint_offset_error_deg=truth_draw("joint_offset_error_deg", 2), seed=2) \
        .geometry(N)


def truth_draw(name: str, seed: int) -> float:
    return getattr(PlantTruth(random={name: (0.1, 0.2)}).realised(seed), name)
