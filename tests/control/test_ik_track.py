"""PathTracker.track, the one implementation of the IK's per-goal step (inkarm/control/ik.py),
held bit for bit to that step written out plainly on test_ik's oracle ``dls_step``: one call
for all goals, one call per goal, and the solve that follows, on goals and settings that take
every branch of its loop (weighted rows, a set spin, a free tilt, the limit push, a singular
start, goals out of reach that clamp at the limits, refinements cut short)."""

import numpy as np
import pytest

from inkarm.control.ik import IKConfig, PathTracker, across, pose_task, solve_ik, task_error
from inkarm.control.kinematics import ArmKinematics
from inkarm.sim.cell import kinematic_model
from tests.control.test_ik import HOME, dls_step, limit_push

pytestmark = pytest.mark.sim

SINGULAR = np.array([0.0, 0.3, 0.0, 0.0, 0.0, 0.0, 0.0])  # elbow and wrist straight: rank 3
GAINS = {"posture_gain": 0.01, "limit_gain": 0.5}
# case: (IKConfig changes, goals, max_refine, pen axis, spin goal); goals "line": 40 points on
# the page; "singular": around the tip at SINGULAR (started there, its pen axis); "far": out of
# reach, behind the arm and beyond its stretch (the joints clamp at their limits)
CASES = {
    "plain": (GAINS, "line", 20, "page", None),
    "in the limit margins": ({**GAINS, "limit_margin": 1.2}, "line", 20, "page", None),
    "weighted rows": ({**GAINS, "position_weight": 2.0, "tilt_weight": 0.5}, "line", 20, "page",
                      None),
    "spin set, tilted pen": (GAINS, "line", 20, "tilted", [1.0, 0.3, 0.2]),
    "spin set, weighted rows": ({**GAINS, "position_weight": 2.0, "tilt_weight": 0.5}, "line",
                                20, "tilted", [1.0, 0.3, 0.2]),
    "tilt free": ({**GAINS, "tilt_weight": 0.0}, "line", 20, "tilted", None),
    "singular start": ({"damping": 1e-3}, "singular", 20, "singular", None),
    "out of reach, clamped": ({}, "far", 20, "page", None),
    "refinements cut short": ({**GAINS, "max_step": 0.0005}, "line", 1, "page", None),
    "null-space step only": ({"posture_gain": 0.3, "tol_pos": 1e-4}, "line", 0, "page", None),
}


@pytest.fixture(scope="module")
def cell():
    """(kinematics, page placement) of the default (iiwa14) cell."""
    model = kinematic_model()
    return ArmKinematics.of(model), model.placement


def documented_track(kin, goals, axis, q0, posture, cfg, refine, spin):
    """PathTracker's step as its docstring states it, on dls_step: for each goal one
    null-space step, then task-only steps until within tolerance (at most ``refine``); the
    joint angles and (tip, tilt) errors reached."""
    q, rows, errors = q0, [], []
    for goal in goals:
        q, _ = dls_step(kin, q, goal, axis, posture, cfg, True, spin)
        for k in range(refine + 1):
            error = task_error(pose_task(*kin.jacobian(q), goal, axis, spin)[0])
            if k == refine or cfg.converged(*error):
                break
            q, _ = dls_step(kin, q, goal, axis, posture, cfg, False, spin)
        rows.append(q)
        errors.append(error)
    return np.array(rows), errors


def setup(kin, page, case):
    """(axis, q0, cfg, max_refine, spin goal, goals (N, 3) [m]) of ``case``."""
    changes, goals, refine, axis, spin = CASES[case]
    line = page.to_robot(
        np.column_stack([np.linspace(60, 150, 40), np.linspace(140, 170, 40), np.zeros(40)]))
    p, R = kin.fk(SINGULAR)
    goals = {"line": line, "singular": p + np.linspace(-0.01, 0.01, 30)[:, None] * [1, -2, 0.5],
             "far": np.array([[-0.6, -0.05, 0.3], [1.5, 0.2, 0.1], [-0.6, 0.05, 0.3]])}[goals]
    axis = {"page": page.pen_axis, "tilted": page.pen_axis + [0.3, -0.2, 0.0],
            "singular": R[:, 2]}[axis]
    axis = axis / np.linalg.norm(axis)
    q0 = SINGULAR if case == "singular start" else solve_ik(kin, line[0], axis, HOME, HOME).q
    cfg = IKConfig(**changes)
    spin = None if spin is None else across(axis, spin)
    return axis, q0, cfg, refine, spin, goals


@pytest.mark.parametrize("case", CASES)
def test_track_takes_the_documented_step_bit_for_bit(cell, case):
    kin, page = cell
    axis, q0, cfg, refine, spin, goals = setup(kin, page, case)
    rows, errors = documented_track(kin, goals, axis, q0, HOME, cfg, refine, spin)
    # the case takes the branch it is named for
    reached = [cfg.converged(*error) for error in errors]
    assert all(reached) == (case not in ("out of reach, clamped", "refinements cut short",
                                         "singular start"))  # (there: the arm at full stretch)
    at_limit = np.any((rows == kin.lower) | (rows == kin.upper))
    assert at_limit == (case == "out of reach, clamped")
    pushed = np.any(limit_push(q0, kin.lower, kin.upper, cfg.limit_margin) != 0)
    assert pushed == (case == "in the limit margins")
    if case == "singular start":
        J = pose_task(*kin.jacobian(q0), goals[0], axis)[1]
        assert np.linalg.svd(J, compute_uv=False)[-1] < 1e-12

    def tracker(q):
        return PathTracker(kin, axis, q, HOME, cfg, refine, spin, unit=True)

    got_rows, got_errors = tracker(q0).track(goals.tolist())
    np.testing.assert_array_equal(got_rows, rows)  # the same numbers, bit for bit
    assert got_errors == errors
    stepping = tracker(q0)  # one goal a call: the state passed from call to call
    for goal, row, error in zip(goals, rows, errors, strict=True):
        assert stepping.step(goal) == error
        np.testing.assert_array_equal(stepping.q, row)
    # the evaluation left behind is the one at the joint angles reached: a solve from there
    # takes the steps of a solve from a fresh tracker at those angles
    after, fresh = stepping.solve(goals[0]), tracker(rows[-1]).solve(goals[0])
    np.testing.assert_array_equal(after.q, fresh.q)
    assert (after.iterations, after.pos_error, after.tilt_error) == (
        fresh.iterations, fresh.pos_error, fresh.tilt_error)


class _FreshViews(ArmKinematics):
    """Kinematics whose ``jacobian_views`` gives new arrays at every evaluation (what its
    docstring allows: valid until the next evaluation)."""

    def jacobian_views(self, q):
        return tuple(a.copy() for a in super().jacobian_views(q))


def test_track_takes_the_rotation_of_every_evaluation(cell):
    """A kinematics that gives R afresh tracks as the one that reuses its arrays, bit for bit
    (track must not hold on to the first evaluation's R)."""
    kin, placement = cell
    fresh = _FreshViews.of(kinematic_model())
    axis, q0, cfg, refine, spin, goals = setup(kin, placement, "spin set, tilted pen")
    rows, errors = PathTracker(kin, axis, q0, HOME, cfg, refine, spin, unit=True).track(
        goals.tolist())
    rows_f, errors_f = PathTracker(fresh, axis, q0, HOME, cfg, refine, spin, unit=True).track(
        goals.tolist())
    assert np.array_equal(np.array(rows_f), np.array(rows))
    assert errors_f == errors
