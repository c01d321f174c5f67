"""Inverse kinematics of the pen task: Jacobians against finite differences, dynamics terms
against MuJoCo's full forward pass, convergence with the pen perpendicular, path tracking."""

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.control.ik import (
    IKConfig,
    PathTracker,
    across,
    dls_update,
    pen_error,
    pose_task,
    solve_ik,
    task_error,
    track_path,
)
from inkarm.control.kinematics import ArmKinematics
from inkarm.errors import InputError, UnreachableError
from inkarm.robots.registry import load_robot
from inkarm.sim.cell import PEN_TIP, kinematic_model

pytestmark = pytest.mark.sim


def pose_error(kin, q, p_goal, axis_goal):
    """(position error [m], tilt error [rad]) at ``q`` from forward kinematics alone."""
    p, R = kin.fk(q)
    return task_error(pen_error(p, R, np.asarray(p_goal, float), axis_goal))


def limit_push(q, lower, upper, margin):
    """Joint displacement [rad] that takes ``q`` out of the margin zones near its limits: back
    into the band [lower + margin, upper - margin], zero inside it."""
    return np.minimum(np.maximum(q, lower + margin), upper - margin) - q


def null_space_motion(q, q_posture, lower, upper, cfg):
    """dq_0 = k_posture (q_posture - q) + k_limit * limit_push(q) in [rad] (ik's docstring)."""
    dq0 = cfg.posture_gain * (q_posture - q)
    dq0 += cfg.limit_gain * limit_push(q, lower, upper, cfg.limit_margin)
    return dq0


def dls_step(kin, q, p_goal, axis_goal, q_posture, cfg, null_space=True, spin_goal=None):
    """One damped-least-squares step of ik's docstring, written out plainly (pose_task, dq_0,
    dls_update): (q_next, e) with e the task error at ``q``; the oracle that PathTracker's
    loops are held to bit for bit."""
    e, J = pose_task(*kin.jacobian_views(q), p_goal, axis_goal, spin_goal)
    dq0 = null_space_motion(q, q_posture, kin.lower, kin.upper, cfg) if null_space else None
    return dls_update(q, e, J, dq0, cfg, kin.lower, kin.upper), e


HOME = np.array(load_robot("iiwa14").home_q)
Q_TEST = np.array([0.2, 0.7, -0.3, -1.4, 0.4, 0.8, 0.5])


@pytest.fixture(scope="module")
def model():
    """The controller's kinematic model of the default (iiwa14) cell."""
    return kinematic_model()


@pytest.fixture(scope="module")
def kin(model):
    return ArmKinematics.of(model)


@pytest.fixture(scope="module")
def page(model):
    return model.placement


def test_jacobian_matches_finite_differences(kin):
    _p, R, Jp, Jr = kin.jacobian(Q_TEST)
    h = 1e-6
    for j in range(kin.n):
        dq = np.zeros(kin.n)
        dq[j] = h
        p_plus, R_plus = kin.fk(Q_TEST + dq)
        p_minus, R_minus = kin.fk(Q_TEST - dq)
        np.testing.assert_allclose((p_plus - p_minus) / (2 * h), Jp[:, j], atol=1e-7)
        # Angular velocity from dR/dq R^T = [w]x
        W = (R_plus - R_minus) / (2 * h) @ R.T
        np.testing.assert_allclose([W[2, 1], W[0, 2], W[1, 0]], Jr[:, j], atol=1e-7)


def test_bias_and_mass_match_a_full_forward_pass(kin):
    model = kin.model
    data = mujoco.MjData(model)
    qd = np.linspace(-0.5, 0.5, 7)
    data.qpos[:7], data.qvel[:7] = Q_TEST, qd
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(kin.bias(Q_TEST, qd), data.qfrc_bias[:7], rtol=1e-12, atol=1e-12)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    np.testing.assert_allclose(kin.mass(Q_TEST), M[:7, :7], atol=1e-12)


def test_task_error_is_zero_on_the_goal_and_measures_tilt(kin):
    p, R, Jp, Jr = kin.jacobian(Q_TEST)
    e, J = pose_task(p, R, Jp, Jr, p, R[:, 2])
    np.testing.assert_allclose(e, 0.0, atol=1e-15)
    assert J.shape == (5, 7)
    tilted = np.cos(0.1) * R[:, 2] + np.sin(0.1) * R[:, 0]
    e, _ = pose_task(p, R, Jp, Jr, p + [0.001, 0, 0], tilted)
    np.testing.assert_allclose(e[:3], [0.001, 0, 0])
    assert np.linalg.norm(e[3:]) == pytest.approx(np.sin(0.1))


def unit(v):
    return np.asarray(v, float) / np.linalg.norm(v)


@settings(max_examples=30, deadline=None)
@given(
    st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4).filter(
        lambda v: np.linalg.norm(v) > 0.1
    ),
    st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).filter(
        lambda v: np.linalg.norm(v) > 0.1
    ),
)
def test_tilt_rows_equal_the_cross_product_definition(quaternion, axis):
    # e[3:] = (x_s . (z_s x a), y_s . (z_s x a)), computed by pen_error as (-y_s . a, x_s . a)
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, unit(quaternion))
    R = R.reshape(3, 3)
    a = unit(axis)
    w = np.cross(R[:, 2], a)
    e = pen_error(np.zeros(3), R, np.ones(3), a)
    np.testing.assert_allclose(e[3:], [R[:, 0] @ w, R[:, 1] @ w], atol=1e-15)
    np.testing.assert_allclose(e[:3], 1.0)


def test_one_solve_step_equals_the_task_plus_projected_null_space_terms(kin, page):
    p, R, Jp, Jr = kin.jacobian(Q_TEST)
    goal = p + [0.01, -0.02, 0.005]
    e, J = pose_task(p, R, Jp, Jr, goal, page.pen_axis)
    cfg = IKConfig(max_step=10.0, posture_gain=0.3)
    dq0 = null_space_motion(Q_TEST, HOME, kin.lower, kin.upper, cfg)
    # module docstring: J^T (J J^T + l^2 I)^-1 e + (I - J^+ J) dq0 with the damped J^+
    pinv = J.T @ np.linalg.inv(J @ J.T + cfg.damping**2 * np.eye(5))
    expected = Q_TEST + pinv @ e + (np.eye(7) - pinv @ J) @ dq0
    got = dls_update(Q_TEST, e, J, dq0, cfg, kin.lower - 10, kin.upper + 10)
    np.testing.assert_allclose(got, expected, atol=1e-12)
    np.testing.assert_allclose(
        dls_update(Q_TEST, e, J, None, cfg, kin.lower - 10, kin.upper + 10),
        Q_TEST + pinv @ e,
        atol=1e-12,
    )


def test_jacobian_views_are_the_jacobian_without_copies(kin):
    copies = kin.jacobian(Q_TEST)
    views = kin.jacobian_views(Q_TEST)
    for view, copy in zip(views, copies):
        np.testing.assert_array_equal(view, copy)
    kin.jacobian_views(HOME)  # the next evaluation overwrites the views
    np.testing.assert_array_equal(views[0], kin.fk(HOME)[0])
    assert not np.allclose(views[0], copies[0])


def test_plan_terms_are_the_jacobian_mass_and_bias_of_one_pass(kin):
    qd = np.linspace(-0.5, 0.5, 7)
    expected = (*kin.jacobian(Q_TEST), kin.mass(Q_TEST), kin.bias(Q_TEST, qd).copy())
    kin.jacobian_views(HOME)  # another pose first: nothing is left over from it
    for got, want in zip(kin.plan_terms(Q_TEST, qd), expected, strict=True):
        np.testing.assert_array_equal(got, want)


def documented_solve(kin, goal, axis, q0, posture, cfg, spin=None):
    """solve_ik's loop as its docstring states it, on dls_step: (q, iterations)."""
    q = np.clip(q0, kin.lower, kin.upper)
    axis = axis / np.linalg.norm(axis)
    spin = None if spin is None else across(axis, spin)
    for it in range(1, cfg.max_iter + 1):
        null_space = it <= cfg.max_iter // 2
        q_next, e = dls_step(kin, q, goal, axis, posture, cfg, null_space, spin)
        settled = not null_space or np.max(np.abs(q_next - q)) < 1e-4
        if cfg.converged(*task_error(e)) and settled:
            return q, it
        q = q_next
    return q, cfg.max_iter


@pytest.mark.parametrize("case", ["posture", "task only", "spin", "unreachable"])
def test_solve_ik_takes_the_documented_steps_bit_for_bit(kin, page, case):
    goal = page.to_robot([120.0, 160.0, -0.5])
    cfg, spin = IKConfig(), None
    if case == "task only":  # as check_reachable asks
        cfg = IKConfig(posture_gain=0.0, tol_pos=1e-5, tol_tilt=1e-4, max_iter=200)
    elif case == "spin":
        spin = np.array([1.0, 0.3, 0.2])
    elif case == "unreachable":
        goal, cfg = np.array([2.0, 0.0, 0.0]), IKConfig(max_iter=40)
    result = solve_ik(kin, goal, page.pen_axis, HOME, HOME, cfg, spin_goal=spin)
    q, iterations = documented_solve(kin, goal, page.pen_axis, HOME, HOME, cfg, spin)
    np.testing.assert_array_equal(result.q, q)
    assert result.iterations == iterations
    assert result.converged == (case != "unreachable")


def test_path_tracker_reports_the_error_it_could_not_remove(kin, page):
    q0 = solve_ik(kin, page.to_robot([105.0, 148.0, 0.0]), page.pen_axis, HOME, HOME).q
    tracker = PathTracker(kin, page.pen_axis, q0, HOME, IKConfig(), max_refine=3)
    pos_err, _ = tracker.step(np.array([3.0, 0.0, 0.0]))
    assert pos_err == pytest.approx(pose_error(kin, tracker.q, [3.0, 0.0, 0.0], page.pen_axis)[0])
    assert pos_err > 1.0


def test_spin_about_the_pen_axis_is_not_part_of_the_task(kin):
    q = Q_TEST.copy()
    p, R, _Jp, _Jr = kin.jacobian(q)
    q[6] += 0.7  # joint 7 spins the pen about its own axis
    p2, R2, Jp2, Jr2 = kin.jacobian(q)
    e, _ = pose_task(p2, R2, Jp2, Jr2, p, R[:, 2])
    np.testing.assert_allclose(e, 0.0, atol=1e-12)


@settings(max_examples=12, deadline=None)
@given(st.floats(10.0, 200.0), st.floats(10.0, 287.0), st.floats(-3.0, 20.0))
def test_ik_reaches_points_over_the_sheet_with_the_pen_perpendicular(kin, page, x, y, z):
    goal = page.to_robot([x, y, z])
    result = solve_ik(kin, goal, page.pen_axis, HOME, HOME)
    assert result.converged
    p, R = kin.fk(result.q)
    assert np.linalg.norm(p - goal) < 1e-6
    assert R[:, 2] @ page.pen_axis > 1 - 1e-9
    assert np.all(result.q >= kin.lower) and np.all(result.q <= kin.upper)


def test_ik_reports_an_unreachable_goal_without_raising(kin):
    result = solve_ik(kin, [2.0, 0.0, 0.0], [0, 0, -1], HOME, HOME, IKConfig(max_iter=60))
    assert not result.converged
    assert result.pos_error > 0.5


def test_null_space_pulls_towards_the_posture_without_moving_the_tip(kin, page):
    goal = page.to_robot([105.0, 148.0, 5.0])
    near = solve_ik(kin, goal, page.pen_axis, HOME, HOME).q
    posture = near + np.array([0.3, 0, 0.3, 0, 0.3, 0, 0.3])
    q = near.copy()
    for _ in range(30):
        q, _ = dls_step(kin, q, goal, page.pen_axis, posture, IKConfig(posture_gain=0.2))
    assert np.linalg.norm(q - posture) < np.linalg.norm(near - posture) - 0.1
    assert np.linalg.norm(kin.fk(q)[0] - goal) < 1e-5


def test_step_is_scaled_as_a_whole_vector(kin):
    goal = kin.fk(Q_TEST)[0] + [0.05, -0.03, 0.02]
    axis = kin.fk(Q_TEST)[1][:, 2]
    free, _ = dls_step(kin, Q_TEST, goal, axis, Q_TEST, IKConfig(max_step=10.0), null_space=False)
    small, _ = dls_step(kin, Q_TEST, goal, axis, Q_TEST, IKConfig(max_step=0.01), null_space=False)
    d_free, d_small = free - Q_TEST, small - Q_TEST
    assert np.max(np.abs(d_small)) == pytest.approx(0.01)
    np.testing.assert_allclose(
        d_small / np.linalg.norm(d_small), d_free / np.linalg.norm(d_free), atol=1e-12
    )


def test_limit_push_only_acts_inside_the_margin():
    lower, upper = np.array([-1.0, -1.0, -1.0]), np.array([1.0, 1.0, 1.0])
    push = limit_push(np.array([-0.95, 0.0, 0.97]), lower, upper, margin=0.1)
    np.testing.assert_allclose(push, [0.05, 0.0, -0.07])


def test_track_path_follows_a_line_smoothly(kin, page):
    line = page.to_robot(
        np.column_stack([np.linspace(60, 150, 200), np.full(200, 150.0), np.zeros(200)])
    )
    q0 = solve_ik(kin, line[0], page.pen_axis, HOME, HOME).q
    path = track_path(kin, line, page.pen_axis, q0, HOME, IKConfig(posture_gain=0.002))
    tips = np.array([kin.fk(q)[0] for q in path])
    assert np.max(np.linalg.norm(tips - line, axis=1)) < 1e-6
    step = np.max(np.abs(np.diff(path, axis=0)))
    assert step < 0.02  # no jumps between neighbouring samples


def test_track_path_names_the_first_unreachable_sample(kin, page):
    points = page.to_robot([[105.0, 148.0, 0.0], [105.0, 148.0, 0.0], [105.0, 2000.0, 0.0]])
    q0 = solve_ik(kin, points[0], page.pen_axis, HOME, HOME).q
    with pytest.raises(
        UnreachableError, match=r"^point C: out of reach with the pen perpendicular"
    ):
        track_path(kin, points, page.pen_axis, q0, HOME, label=lambda i: "point " + "ABC"[i])
    # the samples are checked after tracking: the first that fails is named, not a later one
    with pytest.raises(UnreachableError, match=r"^sample 1: out of reach .*tip error"):
        track_path(kin, points[[0, 2, 0, 2]], page.pen_axis, q0, HOME)


def test_unknown_names_are_refused(kin):
    with pytest.raises(InputError, match="no site named 'nib'"):
        ArmKinematics(kin.model, site="nib")
    with pytest.raises(InputError, match="no joint named 'elbow'"):
        ArmKinematics(kin.model, site=PEN_TIP, joint_names=["elbow"])


def test_the_kinematics_of_a_kinematic_model_name_its_joints_and_tip(model, kin):
    assert kin.joint_names == load_robot("iiwa14").joint_names == model.joint_names
    assert kin.site_id == mujoco.mj_name2id(model.model, mujoco.mjtObj.mjOBJ_SITE, PEN_TIP)
    # the default joints are every hinge: the arm's, not the pen slide
    assert ArmKinematics(model.model, site=PEN_TIP).joint_names == kin.joint_names


def test_without_tilt_rows_ik_converges_on_the_position_alone(kin, page):
    goal = page.to_robot([105.0, 148.0, 5.0])
    sideways = np.array([1.0, 0.0, 0.0])  # a pen lying flat, far from the home pose's
    free = solve_ik(kin, goal, sideways, HOME, HOME, IKConfig(tilt_weight=0.0))
    assert free.converged
    assert free.pos_error < 1e-6
    assert np.linalg.norm(kin.fk(free.q)[0] - goal) < 1e-6
    assert free.tilt_error > 0.5  # the tilt was left where it was, far from the goal axis
    held = solve_ik(kin, goal, sideways, HOME, HOME)  # with the tilt rows, it turns the pen
    assert held.converged and held.tilt_error < 1e-5
    assert np.linalg.norm(free.q - HOME) < np.linalg.norm(held.q - HOME)


def test_converged_counts_the_tilt_only_when_its_rows_count():
    assert IKConfig().converged(1e-7, 1e-6)
    assert not IKConfig().converged(1e-7, 0.1)
    assert not IKConfig().converged(1e-3, 1e-6)
    assert IKConfig(tilt_weight=0.0).converged(1e-7, 0.1)
    assert not IKConfig(tilt_weight=0.0).converged(1e-3, 0.0)


def test_weights_scale_the_task_rows(kin):
    p, R, Jp, Jr = kin.jacobian(Q_TEST)
    e, J = pose_task(p, R, Jp, Jr, p + [0.01, -0.02, 0.005], np.array([0.0, 0.0, -1.0]))
    cfg = IKConfig(max_step=10.0, position_weight=2.0, tilt_weight=0.5)
    w = np.array([2.0, 2.0, 2.0, 0.5, 0.5])
    Jw, ew = w[:, None] * J, w * e
    expected = Q_TEST + Jw.T @ np.linalg.solve(Jw @ Jw.T + cfg.damping**2 * np.eye(5), ew)
    got = dls_update(Q_TEST, e, J, None, cfg, kin.lower - 10, kin.upper + 10)
    np.testing.assert_allclose(got, expected, atol=1e-12)


def test_a_zero_position_weight_is_refused():
    with pytest.raises(InputError, match="weight must be > 0") as info:
        IKConfig(position_weight=0.0)
    assert info.value.key == "position_weight"
    assert str(info.value).startswith("position_weight: ")


@pytest.mark.parametrize(
    "kwargs, key",
    [
        ({"tilt_weight": -1.0}, "tilt_weight"),
        ({"damping": float("nan")}, "damping"),
        ({"max_step": float("inf")}, "max_step"),
    ],
)
def test_bad_ik_config_is_refused_naming_the_field(kwargs, key):
    with pytest.raises(InputError, match="expected a finite number >= 0") as info:
        IKConfig(**kwargs)
    assert info.value.key == key
