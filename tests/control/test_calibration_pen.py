"""The pen's tool-centre point: the fit against planted offsets (exact, and with mark noise), the
pen poses the IK and the reference plan for its dots, and every refusal with its message."""

import dataclasses
import math

import numpy as np
import pytest

from inkarm.control.calibration.pen import (
    PenFit,
    fit_tip_offset,
    natural_spin_deg,
    pen_pattern,
    tip_poses,
)
from inkarm.control.config import LoopConfig
from inkarm.control.ik import IKConfig, PenPose, pose_task, solve_ik, task_error
from inkarm.control.kinematics import ArmKinematics
from inkarm.control.reference import pen_poses, plan_within_speed_limits
from inkarm.core.log import DRAW
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError
from inkarm.robots.geometry import GeometryErrors, apply_geometry
from inkarm.robots.kinematic import KinematicModel
from inkarm.sim.cell import kinematic_model

P_TRUE = np.array([0.8, -0.45, 2.0])  # a pen 2 mm longer, about 1 mm off its axis [mm]


def rotation_of(pose: PenPose) -> np.ndarray:
    """The site's orientation (page frame, columns x, y, z) of a pose with a set spin."""
    a, x = pose.page_axes()
    return np.column_stack([x, np.cross(a, x), a])


def pattern_rotations(tilt: float = 25.0, spins=(-120, -60, 0, 60, 120),
                      azimuths=(0, 90, 180, 270), spin0: float = -90.0) -> np.ndarray:
    poses = [PenPose(0.0, 0.0, spin0 + s) for s in spins]
    poses += [PenPose(tilt, a, spin0) for a in azimuths]
    return np.array([rotation_of(p) for p in poses])


def synthetic_marks(R, p, b=(0.0, 0.0), c=None, seed=0):
    """Believed tips t_i anywhere on a sheet and the marks the real tip t + R (p - c e_z) + b
    leaves."""
    rng = np.random.default_rng(seed)
    k = len(R)
    t = np.column_stack([rng.uniform(50, 150, k), rng.uniform(50, 250, k), rng.uniform(-1, 1, k)])
    c = np.zeros(k) if c is None else np.asarray(c)
    real = t + np.einsum("kij,kj->ki", R, p - c[:, None] * np.array([0.0, 0.0, 1.0]))
    return t, real[:, :2] + np.asarray(b), real


# --- the fit ------------------------------------------------------------------------------

def test_a_planted_offset_and_page_shift_are_recovered_exactly():
    R = pattern_rotations()
    c = np.linspace(0.0, 0.7, len(R))
    t, marks, _ = synthetic_marks(R, P_TRUE, b=(0.3, -0.2), c=c)
    fit = fit_tip_offset(R, t, marks, c)
    np.testing.assert_allclose(fit.tip_offset_mm, P_TRUE, atol=1e-9)
    np.testing.assert_allclose(fit.page_offset_mm, [0.3, -0.2], atol=1e-9)
    assert fit.residual_rms_mm < 1e-9 and fit.sheet_height_mm is None
    assert "pen tip offset (+0.800, -0.450, +2.000) mm" in fit.summary()
    assert "marks shifted (+0.300, -0.200) mm" in fit.summary()


def test_contact_heights_add_the_sheet_height():
    R = pattern_rotations()
    t, marks, real = synthetic_marks(R, P_TRUE, seed=3)
    h = 0.7  # the sheet 0.7 mm above the belief; each tip rests on it, sunk 0.1 mm
    surface = np.full(len(R), -0.1)
    t = t.copy()
    t[:, 2] += (h + surface) - real[:, 2]  # believed tips that put the real tip on the sheet
    fit = fit_tip_offset(R, t, marks, page_offset=False, surface_mm=surface, height_weight=2.0)
    np.testing.assert_allclose(fit.tip_offset_mm, P_TRUE, atol=1e-9)
    assert fit.sheet_height_mm == pytest.approx(h, abs=1e-9)
    assert "sheet at +0.700 mm" in fit.summary()


def test_with_mark_noise_the_offset_is_within_its_stated_errors():
    """0.05 mm of mark noise on the default pattern's nine orientations: the stated standard
    errors are below 0.03 mm across the pen and 0.1 mm along it, and over 200 draws the
    errors scatter as stated (RMS within 25 %, none beyond 4.5 of them)."""
    R = pattern_rotations()
    t, marks, _ = synthetic_marks(R, P_TRUE, b=(0.1, 0.2))
    rng = np.random.default_rng(7)
    errors, stds = [], []
    for _ in range(200):
        fit = fit_tip_offset(R, t, marks + rng.normal(0.0, 0.05, marks.shape))
        errors.append(fit.tip_offset_mm - P_TRUE)
        stds.append(fit.std_mm[:3])
    errors, stds = np.array(errors), np.array(stds)
    # the standard error from the known noise: 0.05 sqrt(diag((A^T A)^-1))
    A = np.concatenate([R[:, :2, :], np.broadcast_to(np.eye(2), (len(R), 2, 2))], axis=2)
    A = A.reshape(2 * len(R), 5)
    expected = 0.05 * np.sqrt(np.diag(np.linalg.inv(A.T @ A)))[:3]
    assert expected[0] < 0.03 and expected[1] < 0.03 and expected[2] < 0.1
    rms = np.sqrt(np.mean(errors**2, axis=0))
    np.testing.assert_allclose(rms, expected, rtol=0.25)
    np.testing.assert_allclose(np.median(stds, axis=0), expected, rtol=0.25)
    assert np.all(np.abs(errors) < 4.5 * expected)


def test_upright_marks_cannot_tell_the_length():
    R = pattern_rotations(azimuths=())
    t, marks, _ = synthetic_marks(R, P_TRUE)
    with pytest.raises(InputError, match="do not determine tip length .*needed: marks with the pen tilted") as e:
        fit_tip_offset(R, t, marks)
    assert e.value.key == "marks"


def test_one_spin_cannot_tell_the_offset_from_a_page_shift():
    R = pattern_rotations(spins=(0, 0))  # tilted four ways, but all at one spin
    t, marks, _ = synthetic_marks(R, P_TRUE)
    with pytest.raises(InputError, match="do not determine tip .*, page .*needed: marks with "
                       "the pen spun to at least two different spins"):
        fit_tip_offset(R, t, marks)
    fit_tip_offset(R, t, marks, page_offset=False)  # (without the shift, one spin will do)


def test_without_the_length_upright_marks_give_the_offset_across_the_pen():
    """Pressed without a force sensor the pen's compression is unknown; the upright marks do
    not depend on it (nor on the length) and give px, py exactly."""
    R = pattern_rotations(azimuths=())
    unknown = np.random.default_rng(1).uniform(0.0, 3.0, len(R))
    t, marks, _ = synthetic_marks(R, P_TRUE, b=(0.2, 0.1), c=unknown)
    fit = fit_tip_offset(R, t, marks, length=False)
    np.testing.assert_allclose(fit.tip_offset_mm, [*P_TRUE[:2], 0.0], atol=1e-9)
    np.testing.assert_allclose(fit.page_offset_mm, [0.2, 0.1], atol=1e-9)
    assert fit.std_mm[2] == 0.0 and "the length not measured (held)" in fit.summary()


def test_too_few_marks_and_bad_arrays_are_refused():
    R = pattern_rotations()
    t, marks, _ = synthetic_marks(R, P_TRUE)
    with pytest.raises(InputError, match="2 marks give 4 equations for 5 unknowns"):
        fit_tip_offset(R[:2], t[:2], marks[:2])
    with pytest.raises(InputError, match=r"expected marks_mm of shape \(9, 2\)") as e:
        fit_tip_offset(R, t, marks[:3])
    assert e.value.key == "marks_mm"
    with pytest.raises(InputError, match="expected rotations of shape"):
        fit_tip_offset(R[0], t, marks)
    bad = t.copy()
    bad[2, 0] = np.nan
    with pytest.raises(InputError, match="tips_mm has non-finite values"):
        fit_tip_offset(R, bad, marks)
    with pytest.raises(InputError, match="height_weight > 0"):
        fit_tip_offset(R, t, marks, surface_mm=np.zeros(len(R)), height_weight=0.0)


# --- pen poses: the IK and the plan ----------------------------------------------------------

def test_pen_pose_axes_follow_their_formulas():
    a, x = PenPose(30.0, 90.0).page_axes()
    np.testing.assert_allclose(a, [0.0, -0.5, -math.sqrt(3) / 2], atol=1e-15)
    assert x is None
    for pose in (PenPose(0.0, 0.0, 0.0), PenPose(25.0, 40.0, 70.0), PenPose(60.0, -120.0, 5.0)):
        a, x = pose.page_axes()
        assert abs(np.linalg.norm(x) - 1) < 1e-12 and abs(a @ x) < 1e-12
        assert math.degrees(math.acos(-a[2])) == pytest.approx(pose.tilt_deg)
    np.testing.assert_allclose(PenPose(0.0, 0.0, 90.0).page_axes()[1], [0, 1, 0], atol=1e-15)


@pytest.mark.parametrize("kw, key", [({"tilt_deg": 61.0}, "tilt_deg"),
                                     ({"tilt_deg": -1.0}, "tilt_deg"),
                                     ({"azimuth_deg": float("nan")}, "azimuth_deg"),
                                     ({"spin_deg": "north"}, "spin_deg")])
def test_bad_pen_poses_are_refused(kw, key):
    with pytest.raises(InputError) as e:
        PenPose(**kw)
    assert e.value.key == key


@pytest.fixture(scope="module")
def model() -> KinematicModel:
    return kinematic_model()


@pytest.fixture(scope="module")
def kin(model):
    return ArmKinematics.of(model)


@pytest.mark.sim
def test_ik_reaches_a_tilted_and_spun_pen(model, kin):
    placement = model.placement
    pose = PenPose(25.0, 135.0, 40.0)
    a, x = pose.page_axes()
    goal = placement.to_robot([100.0, 150.0, 0.0])
    result = solve_ik(kin, goal, placement.rotation @ a, model.home_q, model.home_q, IKConfig(),
                      spin_goal=placement.rotation @ x)
    assert result.converged
    p, R = kin.fk(result.q)
    np.testing.assert_allclose(p, goal, atol=1e-6)
    np.testing.assert_allclose(placement.rotation.T @ R, rotation_of(pose), atol=1e-4)
    e, J = pose_task(*kin.jacobian(result.q), goal, placement.rotation @ a,
                     placement.rotation @ x)
    assert J.shape == (6, 7) and max(task_error(e)) < 1e-4
    with pytest.raises(InputError, match="must not point along the pen axis"):
        solve_ik(kin, goal, a, model.home_q, spin_goal=a)


def dots(points, poses, page=(210.0, 297.0)) -> Drawing:
    strokes = [Trajectory(t=np.array([0.0, 0.2]), pos=np.array([p, p])) for p in points]
    return Drawing(strokes, page_size=page, meta={"pen_poses": tuple(poses)})


@pytest.mark.sim
def test_a_plan_with_poses_holds_each_dot_s_pose_on_its_axis_line(model, kin):
    poses = [PenPose(20.0, 0.0), None, PenPose(25.0, 250.0, 10.0), PenPose(0.0, 0.0, 100.0)]
    points = [(95.0, 140.0), (105.0, 140.0), (105.0, 152.0), (95.0, 152.0)]
    ref, _ = plan_within_speed_limits(dots(points, poses), model, LoopConfig(), model.home_q,
                                      0.002)
    placement = model.placement
    for k, (point, pose) in enumerate(zip(points, poses, strict=True)):
        a, x = (pose or PenPose()).page_axes()
        rows = np.flatnonzero((ref.stroke == k) & (ref.phase == DRAW))
        tip, R = kin.fk(ref.q[rows[len(rows) // 2]])
        page, Rp = placement.to_page(tip), placement.rotation.T @ R
        np.testing.assert_allclose(Rp[:, 2], a, atol=1e-4)
        if x is not None:
            np.testing.assert_allclose(Rp[:, 0], x, atol=1e-4)
        # pressed below the sheet along the pen's own axis through the dot
        np.testing.assert_allclose(page[:2] - point, page[2] * a[:2] / a[2], atol=1e-3)
        assert page[2] < 0


@pytest.mark.sim
def test_without_poses_the_plan_is_the_same_bit_for_bit(model):
    points = [(95.0, 140.0), (110.0, 150.0)]
    plain = Drawing(dots(points, [None, None]).strokes, page_size=(210.0, 297.0))
    upright = dots(points, [None, PenPose()])
    assert pen_poses(plain) is None and pen_poses(upright) is None
    a, _ = plan_within_speed_limits(plain, model, LoopConfig(), model.home_q, 0.002)
    b, _ = plan_within_speed_limits(upright, model, LoopConfig(), model.home_q, 0.002)
    for field in dataclasses.fields(a):
        if field.name != "settle":
            assert np.array_equal(getattr(a, field.name), getattr(b, field.name)), field.name


def test_pen_poses_must_match_the_strokes():
    drawing = dots([(100.0, 100.0), (110.0, 100.0)], [PenPose(10.0)])
    with pytest.raises(InputError, match=r"one PenPose \(or None\) per stroke \(2\), got 1"):
        pen_poses(drawing)
    with pytest.raises(InputError, match="per stroke"):
        pen_poses(dots([(100.0, 100.0)], ["tilted"]))


# --- the fit from planned poses and a planted tip --------------------------------------------

@pytest.mark.sim
def test_the_pattern_s_poses_and_a_planted_tip_give_the_tip_back(model, kin):
    """The default pattern planned on the belief; the tip a model with the planted offset
    (apply_geometry) puts at each dot's planned joints is the mark: the fit returns the offset
    to 1e-9 mm."""
    pattern = pen_pattern(model)
    assert len(pattern.strokes) == 13
    ref, _ = plan_within_speed_limits(pattern, model, LoopConfig(), model.home_q, 0.002)
    q = np.array([ref.q[np.flatnonzero((ref.stroke == k) & (ref.phase == DRAW))[0]]
                  for k in range(13)])
    real = kinematic_model()
    apply_geometry(real.model, real.joint_names, GeometryErrors(tip_offset_mm=tuple(P_TRUE)))
    real_kin = ArmKinematics.of(real)
    marks = np.array([real.placement.to_page(real_kin.fk(qi)[0])[:2] for qi in q])
    R, t = tip_poses(model, q, kin)
    fit = fit_tip_offset(R, t, marks)
    assert isinstance(fit, PenFit)
    np.testing.assert_allclose(fit.tip_offset_mm, P_TRUE, atol=1e-9)
    np.testing.assert_allclose(fit.page_offset_mm, 0.0, atol=1e-9)
    # the poses as planned: five spins 60 deg apart around the natural one, eight tilts
    spins = np.degrees(np.arctan2(R[:5, 1, 0], R[:5, 0, 0]))
    np.testing.assert_allclose(np.diff(np.unwrap(np.radians(spins))), math.radians(60),
                               atol=1e-3)
    np.testing.assert_allclose(np.degrees(np.arccos(-R[5:, 2, 2])), 25.0, atol=1e-3)


@pytest.mark.sim
def test_pattern_refusals(model):
    with pytest.raises(InputError, match="off the sheet") as e:
        pen_pattern(model, centre_mm=(5.0, 5.0))
    assert e.value.key == "centre_mm"
    with pytest.raises(InputError, match="spacing_mm > 0"):
        pen_pattern(model, spacing_mm=0.0)
    with pytest.raises(InputError, match="out of reach with the pen upright"):
        natural_spin_deg(model, (100.0, 5000.0))


def test_tip_poses_are_the_believed_forward_kinematics(model, kin):
    q = np.array([model.home_q, model.home_q + 0.05])
    R, t = tip_poses(model, q, kin)
    for i in range(2):
        p, Rr = kin.fk(q[i])
        np.testing.assert_allclose(t[i], model.placement.to_page(p), atol=1e-12)
        np.testing.assert_allclose(R[i], model.placement.rotation.T @ Rr, atol=1e-15)
