"""The procedural cell: joints, limits, pen, paper, cameras, and forward kinematics against an
independent Denavit-Hartenberg computation of the published KUKA LBR iiwa 14 kinematics."""

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.errors import InputError
from inkarm.sim.cell import (
    JOINT_NAMES,
    CellConfig,
    build_model,
    build_spec,
    default_gains,
    joint_ranges,
    paper_rotation,
)

MODEL = build_model()


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


def test_seven_hinges_with_the_iiwa14_ranges_and_torque_limits():
    hinges = [j for j in range(MODEL.njnt) if MODEL.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    assert [MODEL.joint(j).name for j in hinges] == list(JOINT_NAMES)
    expected_deg = [170, 120, 170, 120, 170, 120, 175]
    np.testing.assert_allclose(np.rad2deg(MODEL.jnt_range[hinges, 1]), expected_deg)
    np.testing.assert_allclose(np.rad2deg(MODEL.jnt_range[hinges, 0]), -np.array(expected_deg))
    assert all(MODEL.jnt_limited[hinges])
    np.testing.assert_allclose(MODEL.actuator_ctrlrange[:, 1], [320, 320, 176, 176, 110, 40, 40])
    np.testing.assert_allclose(MODEL.actuator_ctrlrange[:, 0], -MODEL.actuator_ctrlrange[:, 1])
    assert all(MODEL.dof_armature[:7] > 0) and all(MODEL.dof_damping[:7] > 0)
    assert MODEL.nu == 7 and list(MODEL.actuator_trnid[:, 0]) == hinges


def test_pen_is_a_sprung_slide_with_a_few_mm_of_travel():
    pen = MODEL.joint("pen_slide")
    assert pen.type[0] == mujoco.mjtJoint.mjJNT_SLIDE
    assert MODEL.jnt_stiffness[pen.id] == pytest.approx(300.0)
    assert MODEL.dof_damping[MODEL.jnt_dofadr[pen.id]] > 0
    assert 0.002 <= pen.range[1] - pen.range[0] <= 0.01


def test_only_the_pen_tip_and_the_paper_can_collide():
    def can_collide(a, b):
        return bool(
            MODEL.geom_contype[a] & MODEL.geom_conaffinity[b]
            or MODEL.geom_contype[b] & MODEL.geom_conaffinity[a]
        )

    pairs = {
        tuple(sorted((MODEL.geom(a).name, MODEL.geom(b).name)))
        for a in range(MODEL.ngeom)
        for b in range(a + 1, MODEL.ngeom)
        if can_collide(a, b)
    }
    assert pairs == {("paper", "pen_tip")}


def test_names_the_rest_of_inkarm_relies_on():
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
        assert mujoco.mj_name2id(MODEL, kind, name) >= 0, name


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=7, max_size=7))
def test_forward_kinematics_matches_the_dh_table(fractions):
    q = np.array(fractions) * MODEL.jnt_range[:7, 1]
    data = mujoco.MjData(MODEL)
    data.qpos[:7] = q
    mujoco.mj_kinematics(MODEL, data)
    p, R = dh_flange(q)
    np.testing.assert_allclose(data.site("flange").xpos, p, atol=1e-12)
    np.testing.assert_allclose(data.site("flange").xmat.reshape(3, 3), R, atol=1e-12)


def test_pen_tip_lies_on_the_flange_axis():
    data = mujoco.MjData(MODEL)
    data.qpos[:7] = [0.3, 0.8, -0.4, -1.2, 0.5, 0.9, 1.1]
    mujoco.mj_kinematics(MODEL, data)
    flange = data.site("flange")
    axis = flange.xmat.reshape(3, 3)[:, 2]
    offset = data.site("pen_tip").xpos - flange.xpos
    np.testing.assert_allclose(np.cross(axis, offset), 0.0, atol=1e-12)
    assert 0.1 < axis @ offset < 0.2


def test_home_keyframe_points_the_pen_down_above_the_paper():
    data = mujoco.MjData(MODEL)
    mujoco.mj_resetDataKeyframe(MODEL, data, MODEL.key("home").id)
    mujoco.mj_kinematics(MODEL, data)
    tip = data.site("pen_tip")
    assert tip.xmat.reshape(3, 3)[:, 2] @ [0, 0, -1] > 0.99
    assert tip.xpos[2] > 0.1


def test_paper_origin_is_the_lower_left_corner_of_the_sheet():
    cfg = CellConfig(
        paper_size_mm=(148.0, 210.0), paper_centre_mm=(500.0, 50.0), paper_yaw_deg=30.0
    )
    model = build_model(cfg)
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
    model = build_model(CellConfig(timestep=0.004, contact_timeconst=0.001))
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
        ("timestep", 0.0, r"CellConfig.timestep: expected a positive number, got 0.0"),
        ("pen_stiffness_n_per_mm", -1.0, r"CellConfig.pen_stiffness_n_per_mm"),
        ("paper_size_mm", (210.0, -1.0), r"CellConfig.paper_size_mm: expected positive"),
        ("friction", float("nan"), r"CellConfig.friction: expected a number >= 0"),
        ("home_q", (0.0,) * 6, r"CellConfig.home_q: expected 7 joint angles, got 6"),
        ("contact_solimp", (0.9, 0.5, 0.001), r"CellConfig.contact_solimp: expected \(d0"),
    ],
)
def test_bad_cell_config_is_refused(field, value, message):
    with pytest.raises(InputError, match=message):
        CellConfig(**{field: value})


def test_default_gains_cover_the_seven_joints_within_the_torque_limits():
    g = default_gains()
    assert g.n == 7
    np.testing.assert_allclose(g.torque_limit, MODEL.actuator_ctrlrange[:, 1])
    assert np.all(g.integral_limit < g.torque_limit)


def test_joint_ranges_are_the_arm_rows():
    np.testing.assert_allclose(joint_ranges(MODEL), MODEL.jnt_range[:7])
    spec = build_spec()
    spec.joint("joint7").name = "spin"
    spec.actuator("motor7").target = "spin"
    with pytest.raises(InputError, match="joint_ranges: the model lacks one of the joints"):
        joint_ranges(spec.compile())
