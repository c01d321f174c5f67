"""Kinematic calibration: the dot pattern, the identification and the fit of link lengths and
joint offsets, against planted geometry errors (oracles: a planted truth recovered)."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from inkarm.control.calibration.kinematics import (
    DotReadings,
    TipModel,
    dot_pattern,
    dot_points,
    dot_readings,
    fit_kinematics,
    geometry_of,
    identification,
    parameter_names,
    parameter_scales,
    params_of,
    pen_compression_mm,
    swivel_postures,
)
from inkarm.control.ik import IKConfig, solve_ik
from inkarm.control.kinematics import ArmKinematics
from inkarm.core.log import DRAW, LIFT, DrawLog
from inkarm.errors import InputError
from inkarm.robots.geometry import GeometryErrors, apply_geometry
from inkarm.sim.cell import kinematic_model, make_cell
from inkarm.sim.imperfections import PlantTruth

N = 7


@pytest.fixture(scope="module")
def believed():
    return kinematic_model(make_cell())


@pytest.fixture(scope="module")
def postures(believed):
    """The joint readings the controller's IK gives for the default pattern from its home and
    from the two swivelled homes (3 x 30 dots), pen pressed 2.3 mm."""
    kin = ArmKinematics.of(believed)
    place = believed.placement
    out = []
    for home in (believed.home_q, *swivel_postures(believed)):
        for x, y in dot_points(dot_pattern(place.size_mm)):
            r = solve_ik(kin, place.to_robot([x, y, -2.3]), place.pen_axis, home, home,
                         IKConfig())
            assert r.converged
            out.append(r.q)
    return np.array(out)


def true_tips(believed, q: np.ndarray, truth: GeometryErrors) -> np.ndarray:
    """Page x, y [mm] of the tip of a model with ``truth`` applied directly (as the plant is)."""
    m = copy.deepcopy(believed.model)
    apply_geometry(m, believed.joint_names, truth)
    arm = ArmKinematics(m, believed.tip_site, believed.joint_names)
    return np.array([believed.placement.to_page(arm.fk(qk)[0])[:2] for qk in q])


def test_pattern_is_a_serpentine_grid_of_resting_dots():
    d = dot_pattern((210.0, 297.0), columns=3, rows=2, margin_mm=20.0, dwell_s=0.2,
                    shift_mm=(5.0, -1.0))
    pts = dot_points(d)
    assert pts.tolist() == [[25.0, 19.0], [110.0, 19.0], [195.0, 19.0],
                            [195.0, 276.0], [110.0, 276.0], [25.0, 276.0]]
    assert all(s.duration == pytest.approx(0.2) and np.ptp(s.pos, axis=0).max() == 0
               for s in d.strokes)
    assert d.page_size == (210.0, 297.0)


@pytest.mark.parametrize("kwargs, message", [
    ({"columns": 1}, "at least 2 columns and 2 rows, got 1 x 6"),
    ({"margin_mm": 120.0}, r"margin in \[0, 105\) mm, got 120.0"),
    ({"dwell_s": 0.0}, "dwell_s > 0, got 0.0"),
    ({"shift_mm": (30.0, 0.0)}, "beyond the margin 20.0 mm would leave the sheet"),
])
def test_pattern_errors(kwargs, message):
    with pytest.raises(InputError, match=message):
        dot_pattern((210.0, 297.0), **kwargs)


def test_parameters_round_trip_and_errors():
    truth = GeometryErrors(link_length_mm=(0, 1, 2, 3, 4, 5, 6),
                           joint_offset_deg=(7, 8, 9, 10, 11, 12, 13),
                           tip_offset_mm=(0.5, 0.0, 2.0))
    p = params_of(truth, N)
    assert p.tolist() == list(range(1, 14))
    assert geometry_of(p, N, truth.tip_offset_mm) == truth
    assert params_of(GeometryErrors(), N).tolist() == [0.0] * 13
    names = parameter_names([f"j{i}" for i in range(N)])
    assert names[0] == "link j1 [mm]" and names[6] == "offset j0 [deg]" and len(names) == 13
    assert parameter_scales(N).tolist() == [1.0] * 6 + [0.1] * 7
    with pytest.raises(InputError, match="expected 13 parameters for 7 joints"):
        geometry_of(np.zeros(12), N)
    with pytest.raises(InputError, match="expected 7 link lengths and joint offsets, got 3"):
        params_of(GeometryErrors(link_length_mm=(0, 1, 2)), N)


def test_tip_model_is_the_plant_geometry(believed, postures):
    """p applied through the tip model = the same errors applied to the model directly; the
    compression moves the tip along the pen (perpendicular: no page x, y)."""
    truth = PlantTruth(link_length_error_mm=1.0, joint_offset_error_deg=0.2,
                       seed=3).geometry(believed.joint_names)
    tip = TipModel(believed)
    q = postures[::9]
    assert np.allclose(tip.tips(q, params_of(truth, N)), true_tips(believed, q, truth),
                       atol=1e-9)
    pressed = tip.tips(q, np.zeros(13), np.full(len(q), 2.0))
    assert np.allclose(pressed, tip.tips(q, np.zeros(13)), atol=1e-6)
    # a base geometry and p add up
    half = geometry_of(params_of(truth, N) / 2, N)
    assert np.allclose(TipModel(believed, half).tips(q, params_of(truth, N) / 2),
                       true_tips(believed, q, truth), atol=1e-9)


def test_what_marks_of_a_perpendicular_pen_cannot_tell(believed, postures):
    """The exact symmetries of a pen held perpendicular to a flat sheet: the shoulder's height
    (link 1), the last link and the flange's roll (along and about the pen), and how a length
    splits between two links joined by a joint turning about their common axis."""
    tip = TipModel(believed)
    ident = identification(tip, postures, mark_noise_mm=1e-4)
    assert ident.rank == 8
    assert ident.singular_values[8] < 1e-3 * ident.singular_values[7]
    s = parameter_scales(N)

    def unseen(p):
        x = np.asarray(p, float) / s
        return np.linalg.norm(ident.projector() @ x) < 1e-4 * np.linalg.norm(x)

    e = np.eye(13)
    assert unseen(e[0]) and unseen(e[12])  # link joint2 (shoulder height), offset joint7
    assert unseen(e[1] - e[2]) and unseen(e[3] - e[4])  # upper arm, forearm splits
    assert not unseen(e[1] + e[2]) and not unseen(e[3] + e[4])  # ... but their sums show
    # from one home, fewer directions stand out of 0.05 mm of noise
    one = identification(tip, postures[:30], mark_noise_mm=0.02)
    assert one.rank < identification(tip, postures, mark_noise_mm=0.02).rank
    assert set(ident.identifiable_parameters()) == {6, 7, 8, 9, 10, 11}  # offsets j1..j6


def identifiable_truth(believed, postures) -> np.ndarray:
    """A planted p with offsets 0.2 deg at most and the link sums 1 mm, in the identifiable
    subspace (what marks can tell)."""
    p = np.array([0.0, 0.6, -0.1, 0.3, -0.7, 0.0, -0.15, 0.08, 0.12, -0.2, 0.05, 0.17, 0.0])
    ident = identification(TipModel(believed), postures, mark_noise_mm=1e-4)
    s = parameter_scales(N)
    return ident.projector() @ (p / s) * s


def test_noise_free_marks_give_back_the_planted_geometry(believed, postures):
    truth = identifiable_truth(believed, postures)
    marks = TipModel(believed).tips(postures, truth)
    fit = fit_kinematics(believed, postures, marks, mark_noise_mm=1e-4)
    assert np.abs(fit.params - truth).max() < 1e-6
    assert fit.residual_after_mm < 1e-6 and fit.residual_before_mm > 0.1
    assert fit.geometry == geometry_of(fit.params, N)
    text = fit.report()
    assert "90 marks" in text and "identifiable directions: 8 of 13" in text
    assert "offset joint7 [deg]" in text and "(not identifiable alone)" in text
    assert fit.identification.identifiable_sums(N - 1) == [(1, 2), (3, 4)]
    upper = f"link joint3 + joint4 [mm]    {truth[1] + truth[2]:+.4f}"
    assert upper in text and "link joint5 + joint6 [mm]" in text


def test_plant_truth_recovered_where_identifiable(believed, postures):
    """A PlantTruth's errors, all of them (identifiable or not), noise-free: the identifiable
    part comes back, and the fit predicts the true tips everywhere the postures go."""
    truth = params_of(PlantTruth(link_length_error_mm=1.0, joint_offset_error_deg=0.2,
                                 seed=1).geometry(believed.joint_names), N)
    tip = TipModel(believed)
    fit = fit_kinematics(believed, postures, tip.tips(postures, truth), mark_noise_mm=1e-4)
    s = parameter_scales(N)
    proj = fit.identification.projector()
    assert np.linalg.norm(proj @ ((fit.params - truth) / s)) < 0.01 * np.linalg.norm(
        proj @ (truth / s))
    assert fit.residual_after_mm < 1e-3


def test_noisy_marks_within_tolerance(believed, postures):
    """0.05 mm of mark noise: the identifiable part within 10 % of the truth, the offsets that
    are identifiable alone within 0.01 deg, what no mark can tell held at 0."""
    truth = identifiable_truth(believed, postures)
    rng = np.random.default_rng(7)
    marks = TipModel(believed).tips(postures, truth) + rng.normal(0.0, 0.05, (len(postures), 2))
    fit = fit_kinematics(believed, postures, marks, mark_noise_mm=0.05)
    s = parameter_scales(N)
    proj = fit.identification.projector()
    assert np.linalg.norm(proj @ ((fit.params - truth) / s)) < 0.1 * np.linalg.norm(truth / s)
    blind = fit.identification.directions[fit.identification.singular_values < 1e-6]
    assert len(blind) == 5 and np.linalg.norm(blind @ (fit.params / s)) < 0.01
    # near the noise's 0.071 mm, the weak directions shrunk by the ridge adding a little
    assert 0.05 * np.sqrt(2) * 0.8 < fit.residual_after_mm < 0.1 < fit.residual_before_mm
    for i in fit.identification.identifiable_parameters():
        assert abs(fit.params[i] - truth[i]) < 0.01


def test_fit_on_top_of_a_base_geometry(believed, postures):
    truth = identifiable_truth(believed, postures)
    base = geometry_of(truth * 0.5, N, (0.0, 0.0, 1.0))
    marks = TipModel(believed, geometry_of(np.zeros(13), N, (0.0, 0.0, 1.0))).tips(
        postures, truth)
    fit = fit_kinematics(believed, postures, marks, base=base, mark_noise_mm=1e-4)
    s = parameter_scales(N)
    assert np.abs(fit.identification.projector() @ ((fit.params - truth) / s)).max() < 1e-4
    assert np.abs(fit.params[6:] - truth[6:]).max() < 1e-5  # offsets [deg]
    assert fit.residual_after_mm < 1e-6
    assert fit.geometry.tip_offset_mm == (0.0, 0.0, 1.0)


def test_fit_errors(believed, postures):
    with pytest.raises(InputError, match=r"expected joint readings \(k, 7\) for k = 3 marks"):
        fit_kinematics(believed, postures[:2], np.zeros((3, 2)))
    with pytest.raises(InputError, match="3 marks cannot fit 13 parameters; draw at least 7"):
        fit_kinematics(believed, postures[:3], np.zeros((3, 2)))
    with pytest.raises(InputError, match="mark_noise_mm > 0"):
        identification(TipModel(believed), postures[:3], mark_noise_mm=0.0)


def test_swivel_postures_keep_the_pen_to_first_order(believed):
    homes = swivel_postures(believed, 30.0)
    assert len(homes) == 2
    kin = ArmKinematics.of(believed)
    _, _, jp, jr = kin.jacobian(believed.home_q)
    for h in homes:
        step = h - believed.home_q
        assert np.abs(step).max() == pytest.approx(np.deg2rad(30.0))
        assert np.linalg.norm(np.vstack([jp, jr]) @ step) < 1e-9
        assert np.all(h >= kin.lower) and np.all(h <= kin.upper)
    six = make_cell(robot="wx250s")
    assert swivel_postures(kinematic_model(six)) == ()


def synthetic_log(q_dots: np.ndarray, force=1.0, sensed=True) -> DrawLog:
    """A log of dots: per dot 10 draw rows (the first 5 off by 5e-4 rad), then 2 lift rows."""
    rows = []
    for k, q in enumerate(q_dots):
        for i in range(12):
            phase = DRAW if i < 10 else LIFT
            rows.append((k, phase, q + (5e-4 if i < 5 else 0.0), force))
    log = DrawLog.empty(len(rows), q_dots.shape[1])
    for r, (k, phase, q, f) in enumerate(rows):
        log.time[r] = 0.006 * r
        log.stroke[r], log.phase[r], log.q[r] = k, phase, q
        log.force[r] = f if sensed else np.nan
    return log


def test_dot_readings_rest_compression_and_mark_offset(believed, postures):
    from inkarm.ink.inks import make_ink

    q = postures[:3]
    tip = TipModel(believed)
    log = synthetic_log(q)
    r = dot_readings(log, 3, 1.0, tip, make_ink("marker"), 10.0)
    assert isinstance(r, DotReadings) and np.allclose(r.q, q)
    assert np.allclose(r.compression_mm, pen_compression_mm(1.0, believed))
    assert pen_compression_mm(1.0, believed) == pytest.approx((1.0 - 0.3) / 0.3)
    # the pen rested where it pressed last; its mark, a line from where it landed to there,
    # has its centroid half way
    landed = tip.tips(q + 5e-4, np.zeros(13), r.compression_mm)
    rest = tip.tips(q, np.zeros(13), r.compression_mm)
    assert np.linalg.norm(landed - rest, axis=1).min() > 0.3
    assert np.abs(r.offset_mm - 0.5 * (landed - rest)).max() < 0.02
    blind = dot_readings(synthetic_log(q, sensed=False), 3, 1.0, tip, make_ink("marker"))
    assert np.allclose(blind.q, q) and not blind.compression_mm.any()
    # without a force: contact where the model puts the tip below the sheet (all rows here)
    assert np.abs(blind.offset_mm - 0.5 * (landed - rest)).max() < 0.03
    assert not dot_readings(log, 3, 1.0, tip).offset_mm.any()  # no ink: no offset
    with pytest.raises(InputError, match="dot 3 of the pattern was never pressed"):
        dot_readings(log, 4, 1.0, tip)


def test_jacobian_matches_the_geometry_directly(believed, postures):
    """The identification Jacobian's column of an offset: tip motion per 0.1 deg."""
    tip = TipModel(believed)
    q = postures[:4]
    jac = tip.jacobian(q)
    moved = true_tips(believed, q, GeometryErrors(joint_offset_deg=(1e-3,) + (0.0,) * 6))
    assert np.allclose(jac[:, 6], (moved - tip.tips(q, np.zeros(13))).ravel() / 1e-2,
                       rtol=1e-3, atol=1e-3)
    # the base's yaw turns the tip about the base's vertical: |d tip| = r * 0.1 deg
    place = believed.placement
    radius = np.linalg.norm(place.to_robot(tip.tips(q, np.zeros(13)))[:, :2], axis=1) * 1000
    assert np.allclose(np.linalg.norm(jac[:, 6].reshape(-1, 2), axis=1),
                       radius * np.deg2rad(0.1), rtol=1e-3)
