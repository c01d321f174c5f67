"""The WidowX 250 6DOF built in code: servo figures, joints and limits, zero-pose kinematics
against the published product-of-exponentials, link masses against the URDF, the pen held
vertically over the whole sheet, gravity load, and the suggested gains' sampled-loop rule."""

import math

import mujoco
import numpy as np
import pytest

from inkarm.robots.arms import wx250s as wx

PEN_SHAFT_M = 0.035  # the drawing cell's pen body -> tip
PAPER_THICKNESS_M = 0.0001  # the cell's default sheet
PEN_MASS_KG = 0.12  # the cell's holder (0.1 kg) and pen cartridge (0.02 kg)
DOWN = np.array([0.0, 0.0, -1.0])
CONTROL_PERIOD_S = 0.006

# Trossen docs, specifications/wx250s.rst, "Product of Exponentials": the space-frame screw
# axes (omega, v) of the six joints at the zero pose and the home configuration M of the
# finger centre (ee_gripper_link).
PUBLISHED_SLIST = (
    ((0, 0, 1), (0.0, 0.0, 0.0)),
    ((0, 1, 0), (-0.11065, 0.0, 0.0)),
    ((0, 1, 0), (-0.36065, 0.0, 0.04975)),
    ((1, 0, 0), (0.0, 0.36065, 0.0)),
    ((0, 1, 0), (-0.36065, 0.0, 0.29975)),
    ((1, 0, 0), (0.0, 0.36065, 0.0)),
)
PUBLISHED_M_POS = (0.458325, 0.0, 0.36065)
# URDF wx250s.urdf.xacro <mass> of the moving links: shoulder, upper arm, upper forearm, lower
# forearm, wrist, gripper, gripper prop, gripper bar, left and right finger.
PUBLISHED_MOVING_MASSES_KG = (
    0.480879, 0.430811, 0.234589, 0.220991, 0.084957, 0.072885, 0.00434, 0.034199, 0.016246,
    0.016246,
)


def _spec(pen: bool) -> mujoco.MjSpec:
    spec = mujoco.MjSpec()
    spec.option.timestep = 0.002
    flange = wx.add_arm(spec)
    if pen:
        spec.worldbody.add_geom(
            name="paper", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.1485, 0.105, 0.0025],
            pos=[wx.PAPER_CENTRE_MM[0] / 1000, wx.PAPER_CENTRE_MM[1] / 1000,
                 PAPER_THICKNESS_M - 0.0025],
            contype=0, conaffinity=0,
        )
        length = wx.PEN_HOLDER_M + PEN_SHAFT_M
        flange.add_site(name="flange", size=[0.005] * 3)
        flange.add_geom(
            name="pen", type=mujoco.mjtGeom.mjGEOM_CYLINDER, fromto=[0, 0, 0, 0, 0, length],
            size=[0.008, 0, 0], mass=PEN_MASS_KG, contype=0, conaffinity=0,
        )
        flange.add_site(name="pen_tip", pos=[0.0, 0.0, length], size=[0.001] * 3)
    return spec


@pytest.fixture(scope="module")
def arm_model():
    return _spec(pen=False).compile()


@pytest.fixture(scope="module")
def pen_model():
    return _spec(pen=True).compile()


def _ids(model, kind, names):
    return [mujoco.mj_name2id(model, kind, n) for n in names]


def _pen_pose(model, data, q):
    dofs = _ids(model, mujoco.mjtObj.mjOBJ_JOINT, wx.JOINT_NAMES)
    data.qpos[[model.jnt_qposadr[j] for j in dofs]] = q
    mujoco.mj_kinematics(model, data)
    site = data.site("pen_tip")
    return site.xpos.copy(), site.xmat.reshape(3, 3)[:, 2].copy()


def _solve_pen_down(model, target, q0, iters=300):
    """Tiny damped-least-squares IK: tip on ``target`` [m], pen axis straight down (the spin
    about the pen is left free). Returns (q, tip error [m], tilt [rad])."""
    data = mujoco.MjData(model)
    sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "pen_tip")
    lo, hi = model.jnt_range[:6, 0], model.jnt_range[:6, 1]
    jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    q = np.array(q0, float)
    for _ in range(iters):
        p, axis = _pen_pose(model, data, q)
        err = np.concatenate([target - p, np.cross(axis, DOWN)])
        if np.linalg.norm(err[:3]) < 1e-7 and np.linalg.norm(err[3:]) < 1e-6:
            break
        mujoco.mj_comPos(model, data)
        mujoco.mj_jacSite(model, data, jacp, jacr, sid)
        jac = np.vstack([jacp, jacr])[:, :6]
        dq = jac.T @ np.linalg.solve(jac @ jac.T + 1e-6 * np.eye(6), err)
        q = np.clip(q + dq, lo, hi)
    p, axis = _pen_pose(model, data, q)
    return q, float(np.linalg.norm(target - p)), float(np.linalg.norm(np.cross(axis, DOWN)))


def _paper_points(z):
    cx, cy = (v / 1000 for v in wx.PAPER_CENTRE_MM)
    w, h = (v / 1000 for v in wx.PAPER_SIZE_MM)  # across (robot y), deep (robot x)
    corners = [(cx + sx * h / 2, cy + sy * w / 2, z) for sx in (-1, 1) for sy in (-1, 1)]
    return [np.array(p) for p in [(cx, cy, z), *corners]]


@pytest.fixture(scope="module")
def paper_poses(pen_model):
    """Pen-down joint angles on the paper's centre and corners, on its surface."""
    return [
        (p, *_solve_pen_down(pen_model, p, wx.HOME_Q)) for p in _paper_points(PAPER_THICKNESS_M)
    ]


def _gravity(model, q):
    data = mujoco.MjData(model)
    data.qpos[:6] = q
    data.qvel[:] = 0.0
    mujoco.mj_forward(model, data)
    return data.qfrc_bias[:6].copy()


# --- constants (no MuJoCo model) ---------------------------------------------------------------


def test_servo_figures_and_limits():
    assert wx.JOINT_NAMES == (
        "waist", "shoulder", "elbow", "forearm_roll", "wrist_angle", "wrist_rotate"
    )
    assert wx.SERVOS == ("XM430-W350",) * 5 + ("XL430-W250",)
    # ROBOTIS e-Manual, 12.0 V stall torque; shoulder and elbow have two servos each.
    assert wx.TORQUE_LIMITS_NM == pytest.approx((4.1, 8.2, 8.2, 4.1, 4.1, 1.5))
    # Interbotix Velocity_Limit 131 x 0.229 rpm = pi rad/s, below the no-load speeds
    # (46 and 61 rpm).
    assert wx.SPEED_LIMITS_RAD_S == pytest.approx((math.pi,) * 6, rel=1e-3)
    assert wx.NO_LOAD_SPEEDS_RAD_S == pytest.approx(
        (46 * math.pi / 30,) * 5 + (61 * math.pi / 30,)
    )
    assert all(s <= v for s, v in zip(wx.SPEED_LIMITS_RAD_S, wx.NO_LOAD_SPEEDS_RAD_S))
    assert wx.RANGES_DEG == (
        (-180, 180), (-108, 114), (-123, 92), (-180, 180), (-100, 123), (-180, 180)
    )
    # Reflected rotor inertia = J_rotor * ratio^2, doubled for the doubled joints.
    assert wx.ARMATURE[0] == pytest.approx(8e-8 * 353.5**2)
    assert wx.ARMATURE[1] == pytest.approx(2 * wx.ARMATURE[0])
    for name in ("kp", "ki", "kd", "integral_limit"):
        assert len(wx.SUGGESTED_GAINS[name]) == 6
        assert min(wx.SUGGESTED_GAINS[name]) > 0
    assert all(
        i < t for i, t in zip(wx.SUGGESTED_GAINS["integral_limit"], wx.TORQUE_LIMITS_NM)
    )
    assert len(wx.HOME_Q) == 6


def test_link_inertials_are_physical():
    for name in wx.LINK_NAMES:
        mass, _, inertia = wx.link_inertial(name)
        eig = np.linalg.eigvalsh(inertia)
        assert mass > 0 and eig.min() > 0
        assert eig.max() <= eig.sum() - eig.max() + 1e-12  # triangle inequality


# --- the MuJoCo model --------------------------------------------------------------------------


@pytest.mark.sim
def test_joints_ranges_motors(arm_model):
    m = arm_model
    assert m.njnt == 6 and m.nu == 6
    for i, name in enumerate(wx.JOINT_NAMES):
        joint = m.joint(name)
        assert joint.type[0] == mujoco.mjtJoint.mjJNT_HINGE
        assert m.jnt_limited[joint.id]
        assert np.rad2deg(m.jnt_range[joint.id]) == pytest.approx(wx.RANGES_DEG[i])
        act = m.actuator(f"motor_{name}")
        assert act.trntype[0] == mujoco.mjtTrn.mjTRN_JOINT and act.trnid[0] == joint.id
        assert m.actuator_ctrllimited[act.id]
        assert act.ctrlrange == pytest.approx([-wx.TORQUE_LIMITS_NM[i], wx.TORQUE_LIMITS_NM[i]])
        assert act.gear[0] == 1.0 and act.biastype[0] == mujoco.mjtBias.mjBIAS_NONE
        assert m.dof_armature[joint.dofadr[0]] == pytest.approx(wx.ARMATURE[i])
        assert m.dof_damping[joint.dofadr[0]] > 0 and m.dof_frictionloss[joint.dofadr[0]] > 0
    assert not m.geom_contype.any() and not m.geom_conaffinity.any()


@pytest.mark.sim
def test_custom_names_and_limits():
    spec = mujoco.MjSpec()
    names = [f"j{i}" for i in range(6)]
    wx.add_arm(spec, names, [1.0] * 6)
    m = spec.compile()
    assert [m.joint(i).name for i in range(6)] == names
    assert m.actuator("motor_j3").ctrlrange == pytest.approx([-1.0, 1.0])


@pytest.mark.sim
def test_zero_pose_matches_published_kinematics(pen_model):
    m = pen_model
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    for name, (omega, v) in zip(wx.JOINT_NAMES, PUBLISHED_SLIST):
        jid = m.joint(name).id
        axis, anchor = d.xaxis[jid], d.xanchor[jid]
        assert axis == pytest.approx(omega, abs=1e-9)
        # Screw axis of a revolute joint: v = -omega x q for any point q on the axis.
        assert -np.cross(axis, anchor) == pytest.approx(v, abs=1e-3)
    flange = d.site("flange")
    assert flange.xpos == pytest.approx([0.40775, 0.0, 0.36065], abs=1e-3)  # URDF ee_arm
    z = flange.xmat.reshape(3, 3)[:, 2]
    assert z == pytest.approx([1.0, 0.0, 0.0], abs=1e-9)
    # The pen body sits at the finger centre, the published M.
    assert flange.xpos + wx.PEN_HOLDER_M * z == pytest.approx(PUBLISHED_M_POS, abs=1e-3)
    assert d.site("pen_tip").xpos == pytest.approx(
        np.add(PUBLISHED_M_POS, [PEN_SHAFT_M, 0, 0]), abs=1e-3
    )


@pytest.mark.sim
def test_moving_mass_matches_published(arm_model):
    m = arm_model
    moving = m.body_subtreemass[m.body("shoulder_link").id]
    published = sum(PUBLISHED_MOVING_MASSES_KG)
    assert moving == pytest.approx(published, rel=0.10)
    # The links carry the URDF masses one by one (the gripper with its bar, horn and fingers).
    for name, mass in zip(wx.LINK_NAMES[:5], PUBLISHED_MOVING_MASSES_KG):
        assert m.body(name).mass[0] == pytest.approx(mass)


@pytest.mark.sim
def test_flange_mass_adds_to_the_last_link(arm_model, pen_model):
    """The pen holder mounted on the flange frame counts (the explicit inertial is on a welded
    child body)."""
    gripper = "gripper_link"
    assert pen_model.body_subtreemass[pen_model.body(gripper).id] == pytest.approx(
        arm_model.body_subtreemass[arm_model.body(gripper).id] + PEN_MASS_KG
    )


@pytest.mark.sim
def test_home_pen_down_above_paper_centre(pen_model):
    d = mujoco.MjData(pen_model)
    tip, axis = _pen_pose(pen_model, d, wx.HOME_Q)
    centre = np.array([*(v / 1000 for v in wx.PAPER_CENTRE_MM), PAPER_THICKNESS_M])
    assert tip == pytest.approx(centre + [0.0, 0.0, 0.04], abs=1e-3)
    assert np.linalg.norm(np.cross(axis, DOWN)) < np.deg2rad(0.5) and axis[2] < 0
    q, lo, hi = np.array(wx.HOME_Q), *np.deg2rad(np.array(wx.RANGES_DEG)).T
    assert np.all(np.minimum(q - lo, hi - q) > np.deg2rad(10.0))


@pytest.mark.sim
def test_pen_vertical_over_the_whole_sheet(paper_poses):
    margin = np.deg2rad(10.0)
    lo, hi = np.deg2rad(np.array(wx.RANGES_DEG)).T
    for point, q, pos_err, tilt in paper_poses:
        assert pos_err < 1e-5, point
        assert tilt < 1e-4, point
        clearance = np.minimum(q - lo, hi - q)
        assert np.all(clearance > margin), (point, np.rad2deg(clearance))


@pytest.mark.sim
def test_gravity_torques_within_budget(pen_model, paper_poses):
    limit = 0.6 * np.array(wx.TORQUE_LIMITS_NM)
    for q in [wx.HOME_Q, *(pose[1] for pose in paper_poses)]:
        gravity = _gravity(pen_model, q)
        assert np.all(np.abs(gravity) < limit), (q, gravity / wx.TORQUE_LIMITS_NM)


@pytest.mark.sim
def test_suggested_gains_sampled_loop_rule(pen_model, paper_poses):
    """T max eig(M^-1 K_d) < 1 at the 6 ms control period, at home and over the sheet, and
    the PD bandwidth sqrt(kp / M_ii) at home is 20 to 30 rad/s."""
    kd = np.diag(wx.SUGGESTED_GAINS["kd"])
    kp = np.array(wx.SUGGESTED_GAINS["kp"])
    d = mujoco.MjData(pen_model)
    full = np.zeros((pen_model.nv, pen_model.nv))
    for i, q in enumerate([wx.HOME_Q, *(pose[1] for pose in paper_poses)]):
        d.qpos[:6] = q
        mujoco.mj_forward(pen_model, d)
        mujoco.mj_fullM(pen_model, d, full)
        rate = np.linalg.eigvals(np.linalg.solve(full, kd)).real.max()
        assert CONTROL_PERIOD_S * rate < 1.0
        if i == 0:
            bandwidth = np.sqrt(kp / np.diag(full))
            assert np.all((bandwidth > 20.0) & (bandwidth < 30.0)), bandwidth
