"""The ``sensorimotor`` law (seed 001, sec. 4-5): its DPPLA targets, its learnt inverse against
the analytic Jacobian, its settings, and the default letter drawn with it."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.control.laws import LAWS, LawContext, make_law
from inkarm.control.laws.sensorimotor import Sensorimotor, dppla_targets, stroke_rows
from inkarm.core.log import DESCEND, DRAW, LIFT, TRAVEL
from inkarm.errors import InputError

# -- targets --------------------------------------------------------------------------------------

def _two_strokes():
    """A plan of two drawn strokes (an L, then a line) with pen-up rows around them."""
    corner = np.r_[np.linspace(0.0, 10.0, 21)]
    first = np.vstack([np.column_stack([np.zeros(21), corner]),            # up
                       np.column_stack([corner[1:], np.full(20, 10.0)])])  # then right
    second = np.column_stack([np.linspace(20.0, 30.0, 15), np.zeros(15)])
    page = np.vstack([np.zeros((3, 2)), first, np.zeros((4, 2)), second, np.zeros((2, 2))])
    phase = np.array([DESCEND] * 3 + [DRAW] * len(first) + [LIFT, TRAVEL, TRAVEL, DESCEND]
                     + [DRAW] * len(second) + [LIFT] * 2)
    stroke = np.array([0] * (3 + len(first)) + [1] * (4 + len(second)) + [1] * 2)
    return np.column_stack([page, np.full(len(page), -2.0)]), phase, stroke


def test_targets_are_each_strokes_dppla_points_with_their_rows():
    page, phase, stroke = _two_strokes()
    runs = stroke_rows(phase, stroke)
    assert [(r[0], r[-1]) for r in runs] == [(3, 43), (48, 62)]
    targets = dppla_targets(page, phase, stroke, compression=0.9)
    first = targets.row[targets.stroke == 0]
    # every stroke's targets start and end with it; the L's corner (row 3 + 20) is one of them
    assert first[0] == 3 and first[-1] == 43 and 23 in first
    assert list(targets.row[targets.stroke == 1][[0, -1]]) == [48, 62]
    np.testing.assert_array_equal(targets.xy, page[targets.row, :2])
    # heading for the first target whose row is after the current one; -1 off the strokes
    assert (targets.active[:3] == -1).all() and (targets.active[44:48] == -1).all()
    for c in range(3, 43):
        j = targets.active[c]
        assert targets.row[j] > c >= targets.row[j - 1]
    assert targets.active[43] == len(first) - 1  # the stroke's last row: its last target
    assert targets.active[62] == len(targets) - 1


def test_fewer_targets_as_the_compression_rises():
    page, phase, stroke = _two_strokes()
    counts = [len(dppla_targets(page, phase, stroke, rho)) for rho in (0.5, 0.8, 0.95)]
    assert counts[0] > counts[1] > counts[2] >= 4  # at least both ends of both strokes


# -- settings -------------------------------------------------------------------------------------

@pytest.mark.parametrize(("setting", "value", "words"), [
    ("inverse", "lwrr", "did you mean 'lwr'"),
    ("compression", 1.5, "compression rate in (0, 1)"),
    ("compression", True, "compression rate in (0, 1)"),
    ("gain_per_s", -1.0, "(0, 10000] 1/s"),
    ("gain_per_s", float("nan"), "(0, 10000] 1/s"),
    ("babbling_samples", 2.5, "an integer in [20, 1e+06]"),
    ("babbling_samples", 5, "an integer in [20, 1e+06]"),
    ("babbling_rad", 0.0, "(0, 0.1] rad"),
    ("bandwidth_rad", "wide", "(0, 2] rad"),
    ("release_s", -0.1, "[0, 10] s"),
    ("friction_compensation", "yes", "true or false"),
    ("seed", -3, "an integer"),
])
def test_a_bad_setting_is_refused_naming_it(setting, value, words):
    with pytest.raises(InputError) as caught:
        make_law("sensorimotor", {setting: value})
    assert caught.value.key == f"controller.sensorimotor.{setting}"
    assert words in caught.value.message


def test_an_unknown_setting_is_refused_with_the_closest_one():
    with pytest.raises(InputError) as caught:
        make_law("sensorimotor", {"gain": 10.0})
    assert caught.value.key == "controller.sensorimotor.gain"
    assert "gain_per_s" in caught.value.message


def test_registered_and_sends_torques():
    assert LAWS.get("sensorimotor") is Sensorimotor
    assert Sensorimotor.commands == frozenset({"torque"})
    law = make_law("sensorimotor", {"inverse": "jacobian", "gain_per_s": 20})
    assert (law.inverse, law.gain_per_s, law.compression) == ("jacobian", 20.0, 0.85)


@pytest.mark.sim
def test_a_scenario_with_a_bad_setting_names_its_file_and_key():
    from inkarm.jobs.scenario import load_scenario

    with pytest.raises(InputError) as caught:
        load_scenario().with_overrides({"controller.law": "sensorimotor",
                                        "controller.sensorimotor.bandwidth_rad": 0.0})
    assert caught.value.key == "controller.sensorimotor.bandwidth_rad"
    assert caught.value.file is not None


# -- the learnt inverse against the analytic Jacobian ---------------------------------------------

@pytest.fixture(scope="module")
def letter():
    """The default letter's plan, started law and kinematics (no simulation)."""
    from inkarm.control.config import LoopConfig
    from inkarm.control.executor import plan_within_speed_limits
    from inkarm.control.kinematics import ArmKinematics
    from inkarm.jobs.preflight import placed_within_budget
    from inkarm.jobs.scenario import load_scenario
    from inkarm.sim.cell import Cell, kinematic_model

    scenario = load_scenario()
    cell = Cell(scenario.cell, scenario.robot)
    model = kinematic_model(cell)
    kin = ArmKinematics.of(model)
    dt = scenario.robot.control_period_s
    plan, _ = plan_within_speed_limits(placed_within_budget(scenario, cell), model,
                                       LoopConfig(), model.home_q, dt, kin)
    law = make_law("sensorimotor")
    law.start(LawContext(plan, kin, model, scenario.robot.gains, LoopConfig(), dt,
                         frozenset({"force", "tip"})))
    return plan, law, kin, model


@pytest.mark.sim
def test_lwr_on_isotropic_babbling_converges_to_the_jacobian_pseudo_inverse(letter):
    """The oracle (lwr.py, why (W) is J^+): babbling at one pose, dq isotropic, the regression
    of dq on dx is J^T (J J^T)^-1 up to sampling error, ~sqrt(n / N)."""
    from inkarm.control.lwr import LocalInverse, babble, pseudo_inverse_step, task_jacobian

    plan, _, kin, model = letter
    q = plan.q[np.flatnonzero(plan.phase == DRAW)[100]]
    data = babble(kin, q[None], model.placement.pen_axis, samples=20000, motion_rad=0.002,
                  spread_rad=0.0, seed=3)
    B = LocalInverse(data, bandwidth_rad=1.0).fit(q)
    J = task_jacobian(kin, q)
    J_pinv = np.column_stack([pseudo_inverse_step(J, e, damping=0.0) for e in np.eye(5)])
    # the pen does what it is asked (J B = I) ...
    np.testing.assert_allclose(J @ B, np.eye(5), atol=0.01)
    # ... and B is the pseudo-inverse: 1 mm along the page's x, 1 mm along its y
    for axis in (0, 1):
        dx = np.r_[model.placement.rotation[:, axis] * 1e-3, 0.0, 0.0]
        dq_lwr, dq_jac = B @ dx, J_pinv @ dx
        assert np.linalg.norm(dq_lwr - dq_jac) < 0.03 * np.linalg.norm(dq_jac)
        assert np.linalg.norm(dq_jac) == pytest.approx(np.linalg.norm(dq_lwr), rel=0.03)


@pytest.mark.sim
def test_the_laws_learnt_inverse_matches_the_jacobian_along_the_letter(letter):
    """The law's own babbling (2000 motions around the plan's drawing poses, bandwidth 0.03 rad):
    at poses along the letter, a commanded 1 mm in the page's plane moves the pen by 1 mm within
    4 % (through the true kinematics), and dq is within 20 % of J^+ dx (12 % on average); the
    difference is motion in J's null space, which the pen does not see."""
    from inkarm.control.lwr import pseudo_inverse_step, task_jacobian, task_output

    plan, law, kin, model = letter
    axis, rotation = model.placement.pen_axis, model.placement.rotation
    rng = np.random.default_rng(7)
    dq_errors, pen_errors = [], []
    for row in np.flatnonzero(plan.phase == DRAW)[::20]:
        q = plan.q[row]
        direction = rng.standard_normal(2)
        dx = np.r_[rotation[:, :2] @ (direction / np.linalg.norm(direction)) * 1e-3, 0.0, 0.0]
        dq_lwr = law.model.fit(q) @ dx
        dq_jac = pseudo_inverse_step(task_jacobian(kin, q), dx)
        dq_errors.append(np.linalg.norm(dq_lwr - dq_jac) / np.linalg.norm(dq_jac))
        moved = task_output(kin, q + dq_lwr, axis) - task_output(kin, q, axis)
        pen_errors.append(np.linalg.norm(moved - dx) / np.linalg.norm(dx))
    assert len(dq_errors) >= 10
    assert max(pen_errors) < 0.04
    assert max(dq_errors) < 0.20 and np.mean(dq_errors) < 0.12
    assert law.model.effective_samples(plan.q[np.flatnonzero(plan.phase == DRAW)[0]]) > 200


@pytest.mark.sim
def test_babbling_is_deterministic_and_stays_on_the_model(letter):
    from inkarm.control.lwr import babble

    plan, law, kin, model = letter
    centres = plan.q[np.flatnonzero(plan.phase == DRAW)[::50]]
    a = babble(kin, centres, model.placement.pen_axis, 200, 0.005, 0.015, seed=5)
    b = babble(kin, centres, model.placement.pen_axis, 200, 0.005, 0.015, seed=5)
    np.testing.assert_array_equal(a.dx, b.dx)
    assert (a.q >= kin.lower).all() and (a.q <= kin.upper).all()
    # tip motions of millimetres, tilts of milliradians
    assert 1e-4 < np.median(np.abs(a.dx[:, :3])) < 1e-2
    assert len(law.targets) == 30 and law.targets.row[0] == np.flatnonzero(plan.phase == DRAW)[0]


# -- the default letter ---------------------------------------------------------------------------

@pytest.mark.sim
@pytest.mark.slow
def test_the_default_letter_is_drawn_with_the_overshoot_at_high_curvature():
    """Seed 001 Fig. 3's property: the path emerges from the loop through the targets, with
    overshoot where the curvature is high."""
    from inkarm.jobs.compare_laws import compare_laws
    from inkarm.jobs.scenario import load_scenario

    comparison = compare_laws(load_scenario(), laws=(
        ("sensorimotor", "learnt inverse"),
        ("sensorimotor", "analytic Jacobian", {"inverse": "jacobian"})))
    learnt, analytic = comparison.results
    for result in (learnt, analytic):
        assert result.status != "failed", result.run.reason
        assert result.path_rms_mm < 1.5 and result.path_max_mm < 4.0
    sharp = comparison.curvature >= 0.5  # radius < 2 mm: the N's corners
    straight = comparison.curvature < 0.05  # radius > 20 mm
    assert sharp.sum() >= 4 and straight.sum() >= 10
    overshoot = learnt.overshoot_mm
    assert overshoot[sharp].mean() > 2.0 * overshoot[straight].mean()
    assert overshoot[sharp].max() > 1.0  # millimetres past a corner
    # the pen passes by every target (within 2.6 mm where it loops round the N's lower corner)
    tips = np.concatenate(learnt.tip)
    misses = [np.min(np.linalg.norm(tips - x, axis=1)) for x in comparison.targets.xy]
    assert max(misses) < 3.0 and np.median(misses) < 1.0
    # the learnt inverse draws as the analytic one does
    assert abs(learnt.path_rms_mm - analytic.path_rms_mm) < 0.1
