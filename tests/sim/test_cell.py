"""The procedural cell (the built-in iiwa14 profile): joints, limits, pen, paper, cameras, and forward kinematics against an
independent Denavit-Hartenberg computation of the published KUKA LBR iiwa 14 kinematics."""

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.errors import InputError
from inkarm.robots.registry import load_robot
from inkarm.sim.cell import (
    CellConfig,
    build_model,
    build_spec,
    joint_ranges,
    make_cell,
    paper_rotation,
)

pytestmark = pytest.mark.sim

IIWA = load_robot("iiwa14")
JOINT_NAMES = IIWA.joint_names


@pytest.fixture(scope="module")
def model():
    return build_model()


def dh_flange(q):
    """Flange pose of the iiwa 14 from its standard DH table (d in m, alpha in rad, a = 0)."""
    d = [0.36, 0.0, 0.42, 0.0, 0.40, 0.0, 0.126]
    alpha = [-np.pi / 2, np.pi / 2, np.pi / 2, -np.pi / 2, -np.pi / 2, np.pi / 2, 0.0]
    T = np.eye(4)
    for qi, di, ai in zip(q, d, alpha):
        ct, st_, ca, sa = np.cos(qi), np.sin(qi), np.cos(ai), np.sin(ai)
        T = T @ np.array(
            [
                [ct, -st_ * ca, st_ * sa, 0.0],
                [st_, ct * ca, -ct * sa, 0.0],
                [0.0, sa, ca, di],
                [0.0, 0.0, 0.0, 1.0],
            ]
        )
    return T[:3, 3], T[:3, :3]


def test_seven_hinges_with_the_iiwa14_ranges_and_torque_limits(model):
    hinges = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    assert [model.joint(j).name for j in hinges] == list(JOINT_NAMES)
    expected_deg = [170, 120, 170, 120, 170, 120, 175]
    np.testing.assert_allclose(np.rad2deg(model.jnt_range[hinges, 1]), expected_deg)
    np.testing.assert_allclose(np.rad2deg(model.jnt_range[hinges, 0]), -np.array(expected_deg))
    assert all(model.jnt_limited[hinges])
    np.testing.assert_allclose(model.actuator_ctrlrange[:, 1], [320, 320, 176, 176, 110, 40, 40])
    np.testing.assert_allclose(model.actuator_ctrlrange[:, 0], -model.actuator_ctrlrange[:, 1])
    assert all(model.dof_armature[:7] > 0) and all(model.dof_damping[:7] > 0)
    assert model.nu == 7 and list(model.actuator_trnid[:, 0]) == hinges


def test_pen_is_a_sprung_slide_with_a_few_mm_of_travel(model):
    pen = model.joint("pen_slide")
    assert pen.type[0] == mujoco.mjtJoint.mjJNT_SLIDE
    assert model.jnt_stiffness[pen.id] == pytest.approx(300.0)
    assert model.dof_damping[model.jnt_dofadr[pen.id]] > 0
    assert 0.002 <= pen.range[1] - pen.range[0] <= 0.01


def test_only_the_pen_tip_and_the_paper_can_collide(model):
    def can_collide(a, b):
        return bool(
            model.geom_contype[a] & model.geom_conaffinity[b]
            or model.geom_contype[b] & model.geom_conaffinity[a]
        )

    pairs = {
        tuple(sorted((model.geom(a).name, model.geom(b).name)))
        for a in range(model.ngeom)
        for b in range(a + 1, model.ngeom)
        if can_collide(a, b)
    }
    assert pairs == {("paper", "pen_tip")}


def test_names_the_rest_of_inkarm_relies_on(model):
    for kind, name in [
        (mujoco.mjtObj.mjOBJ_SITE, "pen_tip"),
        (mujoco.mjtObj.mjOBJ_SITE, "paper_origin"),
        (mujoco.mjtObj.mjOBJ_GEOM, "pen_tip"),
        (mujoco.mjtObj.mjOBJ_GEOM, "paper"),
        (mujoco.mjtObj.mjOBJ_CAMERA, "paper_top"),
        (mujoco.mjtObj.mjOBJ_CAMERA, "overview"),
        (mujoco.mjtObj.mjOBJ_CAMERA, "pen_cam"),
        (mujoco.mjtObj.mjOBJ_KEY, "home"),
    ]:
        assert mujoco.mj_name2id(model, kind, name) >= 0, name


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=7, max_size=7))
def test_forward_kinematics_matches_the_dh_table(model, fractions):
    q = np.array(fractions) * model.jnt_range[:7, 1]
    data = mujoco.MjData(model)
    data.qpos[:7] = q
    mujoco.mj_kinematics(model, data)
    p, R = dh_flange(q)
    np.testing.assert_allclose(data.site("flange").xpos, p, atol=1e-12)
    np.testing.assert_allclose(data.site("flange").xmat.reshape(3, 3), R, atol=1e-12)


def test_pen_tip_lies_on_the_flange_axis(model):
    data = mujoco.MjData(model)
    data.qpos[:7] = [0.3, 0.8, -0.4, -1.2, 0.5, 0.9, 1.1]
    mujoco.mj_kinematics(model, data)
    flange = data.site("flange")
    axis = flange.xmat.reshape(3, 3)[:, 2]
    offset = data.site("pen_tip").xpos - flange.xpos
    np.testing.assert_allclose(np.cross(axis, offset), 0.0, atol=1e-12)
    assert 0.1 < axis @ offset < 0.2


def test_home_keyframe_points_the_pen_down_above_the_paper(model):
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_kinematics(model, data)
    tip = data.site("pen_tip")
    assert tip.xmat.reshape(3, 3)[:, 2] @ [0, 0, -1] > 0.99
    assert tip.xpos[2] > 0.1


def test_paper_origin_is_the_lower_left_corner_of_the_sheet():
    cfg = CellConfig(
        paper_size_mm=(148.0, 210.0), paper_centre_mm=(500.0, 50.0), paper_yaw_deg=30.0
    )
    model = build_model(make_cell(cfg))
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    R = paper_rotation(30.0)
    origin = data.site("paper_origin")
    np.testing.assert_allclose(origin.xmat.reshape(3, 3), R, atol=1e-12)
    centre = origin.xpos + R @ [0.074, 0.105, 0.0]
    np.testing.assert_allclose(centre[:2], [0.5, 0.05], atol=1e-12)
    assert centre[2] == pytest.approx(cfg.paper_thickness_mm / 1000.0)
    np.testing.assert_allclose(2 * model.geom("paper").size[:2], [0.148, 0.210])


def test_default_page_y_axis_points_away_from_the_robot():
    R = paper_rotation(0.0)
    np.testing.assert_allclose(R, [[0, 1, 0], [-1, 0, 0], [0, 0, 1]], atol=1e-15)


def test_contact_time_constant_is_at_least_twice_the_time_step():
    model = build_model(make_cell(CellConfig(timestep=0.004, contact_timeconst=0.001)))
    assert model.opt.timestep == 0.004
    assert model.geom("pen_tip").solref[0] == pytest.approx(0.008)
    assert model.geom("paper").solref[0] == pytest.approx(0.008)


def test_spec_is_editable_before_compiling():
    spec = build_spec()
    spec.option.timestep = 0.001
    assert spec.compile().opt.timestep == 0.001


@pytest.mark.parametrize(
    "field, value, message",
    [
        ("timestep", 0.0, r"^timestep: expected a number in \[1e-05, 0.01\] s, got 0.0"),
        ("pen_stiffness_n_per_mm", -1.0, r"^pen_stiffness_n_per_mm"),
        ("paper_size_mm", (210.0, -1.0), r"^paper_size_mm: expected numbers in \[1, 2000\] mm"),
        ("paper_size_mm", (1e5, 1e5), r"^paper_size_mm: expected numbers in \[1, 2000\] mm"),
        ("friction", float("nan"), r"^friction: expected a number in \[0, 5\], got nan"),
        ("contact_solimp", (0.9, 0.5, 0.001), r"^contact_solimp: expected \(d0"),
    ],
)
def test_bad_cell_config_is_refused(field, value, message):
    with pytest.raises(InputError, match=message):
        CellConfig(**{field: value})


def test_default_gains_cover_the_seven_joints_within_the_torque_limits(model):
    g = IIWA.gains
    assert g.n == 7
    np.testing.assert_allclose(g.torque_limit, model.actuator_ctrlrange[:, 1])
    assert np.all(g.integral_limit < g.torque_limit)


def test_joint_ranges_are_the_arm_rows(model):
    np.testing.assert_allclose(joint_ranges(model, JOINT_NAMES), model.jnt_range[:7])
    spec = build_spec()
    spec.joint("joint7").name = "spin"
    spec.actuator("motor7").target = "spin"
    with pytest.raises(InputError, match="joint_ranges: the model lacks one of the joints"):
        joint_ranges(spec.compile(), JOINT_NAMES)
