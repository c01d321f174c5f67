"""Inverse kinematics of the pen task: Jacobians against finite differences, dynamics terms
against MuJoCo's full forward pass, convergence with the pen perpendicular, path tracking."""

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.control.ik import (
    ArmKinematics,
    IKConfig,
    PathTracker,
    dls_step,
    dls_update,
    limit_push,
    null_space_motion,
    pen_error,
    pen_task,
    pose_error,
    solve_ik,
    track_path,
)
from inkarm.core.frames import PagePlacement
from inkarm.errors import InputError, UnreachableError
from inkarm.sim.cell import HOME_Q, build_model

KIN = ArmKinematics(build_model())
PAGE = PagePlacement.from_model(KIN.model)
HOME = np.array(HOME_Q)
Q_TEST = np.array([0.2, 0.7, -0.3, -1.4, 0.4, 0.8, 0.5])


def test_jacobian_matches_finite_differences():
    _p, R, Jp, Jr = KIN.jacobian(Q_TEST)
    h = 1e-6
    for j in range(KIN.n):
        dq = np.zeros(KIN.n)
        dq[j] = h
        p_plus, R_plus = KIN.fk(Q_TEST + dq)
        p_minus, R_minus = KIN.fk(Q_TEST - dq)
        np.testing.assert_allclose((p_plus - p_minus) / (2 * h), Jp[:, j], atol=1e-7)
        # Angular velocity from dR/dq R^T = [w]x
        W = (R_plus - R_minus) / (2 * h) @ R.T
        np.testing.assert_allclose([W[2, 1], W[0, 2], W[1, 0]], Jr[:, j], atol=1e-7)


def test_bias_and_mass_match_a_full_forward_pass():
    model = build_model()
    data = mujoco.MjData(model)
    qd = np.linspace(-0.5, 0.5, 7)
    data.qpos[:7], data.qvel[:7] = Q_TEST, qd
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(KIN.bias(Q_TEST, qd), data.qfrc_bias[:7], rtol=1e-12, atol=1e-12)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    np.testing.assert_allclose(KIN.mass(Q_TEST), M[:7, :7], atol=1e-12)


def test_task_error_is_zero_on_the_goal_and_measures_tilt():
    p, R, Jp, Jr = KIN.jacobian(Q_TEST)
    e, J = pen_task(p, R, Jp, Jr, p, R[:, 2])
    np.testing.assert_allclose(e, 0.0, atol=1e-15)
    assert J.shape == (5, 7)
    tilted = np.cos(0.1) * R[:, 2] + np.sin(0.1) * R[:, 0]
    e, _ = pen_task(p, R, Jp, Jr, p + [0.001, 0, 0], tilted)
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


def test_one_solve_step_equals_the_task_plus_projected_null_space_terms():
    p, R, Jp, Jr = KIN.jacobian(Q_TEST)
    goal = p + [0.01, -0.02, 0.005]
    e, J = pen_task(p, R, Jp, Jr, goal, PAGE.pen_axis)
    cfg = IKConfig(max_step=10.0, posture_gain=0.3)
    dq0 = null_space_motion(Q_TEST, HOME, KIN.lower, KIN.upper, cfg)
    # module docstring: J^T (J J^T + l^2 I)^-1 e + (I - J^+ J) dq0 with the damped J^+
    pinv = J.T @ np.linalg.inv(J @ J.T + cfg.damping**2 * np.eye(5))
    expected = Q_TEST + pinv @ e + (np.eye(7) - pinv @ J) @ dq0
    got = dls_update(Q_TEST, e, J, dq0, cfg, KIN.lower - 10, KIN.upper + 10)
    np.testing.assert_allclose(got, expected, atol=1e-12)
    np.testing.assert_allclose(
        dls_update(Q_TEST, e, J, None, cfg, KIN.lower - 10, KIN.upper + 10),
        Q_TEST + pinv @ e,
        atol=1e-12,
    )


def test_jacobian_views_are_the_jacobian_without_copies():
    copies = KIN.jacobian(Q_TEST)
    views = KIN.jacobian_views(Q_TEST)
    for view, copy in zip(views, copies):
        np.testing.assert_array_equal(view, copy)
    KIN.jacobian_views(HOME)  # the next evaluation overwrites the views
    np.testing.assert_array_equal(views[0], KIN.fk(HOME)[0])
    assert not np.allclose(views[0], copies[0])


def test_path_tracker_steps_as_the_per_sample_scheme_it_documents():
    line = PAGE.to_robot(
        np.column_stack([np.linspace(60, 150, 40), np.linspace(140, 170, 40), np.zeros(40)])
    )
    q0 = solve_ik(KIN, line[0], PAGE.pen_axis, HOME, HOME).q
    cfg = IKConfig(posture_gain=0.01, limit_gain=0.5)
    tracker = PathTracker(KIN, PAGE.pen_axis, q0, HOME, cfg)
    q = q0.copy()
    for goal in line:
        # reference: one null-space step, then task-only steps until within tolerance
        q, _ = dls_step(KIN, q, goal, PAGE.pen_axis, HOME, cfg, null_space=True)
        for _ in range(20):
            pos_err, tilt_err = pose_error(KIN, q, goal, PAGE.pen_axis)
            if pos_err < cfg.tol_pos and tilt_err < cfg.tol_tilt:
                break
            q, _ = dls_step(KIN, q, goal, PAGE.pen_axis, HOME, cfg, null_space=False)
        errors = tracker.step(goal)
        np.testing.assert_allclose(tracker.q, q, atol=1e-12)
        np.testing.assert_allclose(errors, pose_error(KIN, q, goal, PAGE.pen_axis), atol=1e-12)
        assert errors[0] < cfg.tol_pos and errors[1] < cfg.tol_tilt


def test_path_tracker_reports_the_error_it_could_not_remove():
    q0 = solve_ik(KIN, PAGE.to_robot([105.0, 148.0, 0.0]), PAGE.pen_axis, HOME, HOME).q
    tracker = PathTracker(KIN, PAGE.pen_axis, q0, HOME, IKConfig(), max_refine=3)
    pos_err, _ = tracker.step(np.array([3.0, 0.0, 0.0]))
    assert pos_err == pytest.approx(pose_error(KIN, tracker.q, [3.0, 0.0, 0.0], PAGE.pen_axis)[0])
    assert pos_err > 1.0


def test_spin_about_the_pen_axis_is_not_part_of_the_task():
    q = Q_TEST.copy()
    p, R, _Jp, _Jr = KIN.jacobian(q)
    q[6] += 0.7  # joint 7 spins the pen about its own axis
    p2, R2, Jp2, Jr2 = KIN.jacobian(q)
    e, _ = pen_task(p2, R2, Jp2, Jr2, p, R[:, 2])
    np.testing.assert_allclose(e, 0.0, atol=1e-12)


@settings(max_examples=12, deadline=None)
@given(st.floats(10.0, 200.0), st.floats(10.0, 287.0), st.floats(-3.0, 20.0))
def test_ik_reaches_points_over_the_sheet_with_the_pen_perpendicular(x, y, z):
    goal = PAGE.to_robot([x, y, z])
    result = solve_ik(KIN, goal, PAGE.pen_axis, HOME, HOME)
    assert result.converged
    p, R = KIN.fk(result.q)
    assert np.linalg.norm(p - goal) < 1e-6
    assert R[:, 2] @ PAGE.pen_axis > 1 - 1e-9
    assert np.all(result.q >= KIN.lower) and np.all(result.q <= KIN.upper)


def test_ik_reports_an_unreachable_goal_without_raising():
    result = solve_ik(KIN, [2.0, 0.0, 0.0], [0, 0, -1], HOME, HOME, IKConfig(max_iter=60))
    assert not result.converged
    assert result.pos_error > 0.5


def test_null_space_pulls_towards_the_posture_without_moving_the_tip():
    goal = PAGE.to_robot([105.0, 148.0, 5.0])
    near = solve_ik(KIN, goal, PAGE.pen_axis, HOME, HOME).q
    posture = near + np.array([0.3, 0, 0.3, 0, 0.3, 0, 0.3])
    q = near.copy()
    for _ in range(30):
        q, _ = dls_step(KIN, q, goal, PAGE.pen_axis, posture, IKConfig(posture_gain=0.2))
    assert np.linalg.norm(q - posture) < np.linalg.norm(near - posture) - 0.1
    assert np.linalg.norm(KIN.fk(q)[0] - goal) < 1e-5


def test_step_is_scaled_as_a_whole_vector():
    goal = KIN.fk(Q_TEST)[0] + [0.05, -0.03, 0.02]
    axis = KIN.fk(Q_TEST)[1][:, 2]
    free, _ = dls_step(KIN, Q_TEST, goal, axis, Q_TEST, IKConfig(max_step=10.0), null_space=False)
    small, _ = dls_step(KIN, Q_TEST, goal, axis, Q_TEST, IKConfig(max_step=0.01), null_space=False)
    d_free, d_small = free - Q_TEST, small - Q_TEST
    assert np.max(np.abs(d_small)) == pytest.approx(0.01)
    np.testing.assert_allclose(
        d_small / np.linalg.norm(d_small), d_free / np.linalg.norm(d_free), atol=1e-12
    )


def test_limit_push_only_acts_inside_the_margin():
    lower, upper = np.array([-1.0, -1.0, -1.0]), np.array([1.0, 1.0, 1.0])
    push = limit_push(np.array([-0.95, 0.0, 0.97]), lower, upper, margin=0.1)
    np.testing.assert_allclose(push, [0.05, 0.0, -0.07])


def test_track_path_follows_a_line_smoothly():
    line = PAGE.to_robot(
        np.column_stack([np.linspace(60, 150, 200), np.full(200, 150.0), np.zeros(200)])
    )
    q0 = solve_ik(KIN, line[0], PAGE.pen_axis, HOME, HOME).q
    path = track_path(KIN, line, PAGE.pen_axis, q0, HOME, IKConfig(posture_gain=0.002))
    tips = np.array([KIN.fk(q)[0] for q in path])
    assert np.max(np.linalg.norm(tips - line, axis=1)) < 1e-6
    step = np.max(np.abs(np.diff(path, axis=0)))
    assert step < 0.02  # no jumps between neighbouring samples


def test_track_path_names_the_first_unreachable_sample():
    points = PAGE.to_robot([[105.0, 148.0, 0.0], [105.0, 148.0, 0.0], [105.0, 2000.0, 0.0]])
    q0 = solve_ik(KIN, points[0], PAGE.pen_axis, HOME, HOME).q
    with pytest.raises(
        UnreachableError, match=r"^point C: out of reach with the pen perpendicular"
    ):
        track_path(KIN, points, PAGE.pen_axis, q0, HOME, label=lambda i: "point " + "ABC"[i])


def test_unknown_names_are_refused():
    with pytest.raises(InputError, match="no site named 'nib'"):
        ArmKinematics(build_model(), site="nib")
    with pytest.raises(InputError, match="no joint named 'elbow'"):
        ArmKinematics(build_model(), joint_names=["elbow"])
