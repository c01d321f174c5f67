"""Target density against curvature and the target-based power law (seed 001, sec. 5)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from inkarm.analysis.density import (
    analyse,
    analyse_drawing,
    fit_power_law,
    pointwise_curvature,
    segment_curvature,
    target_density,
    target_velocity,
    turning_angles,
)
from inkarm.cli import main
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError

RATE = 110.0  # [Hz], seed 001's VICON rate


def harmonic_ellipse(a=60.0, b=20.0, period=3.0, rate=RATE) -> Trajectory:
    """x = a cos(w t), y = b sin(w t): curvature a b / (a^2 sin^2 + b^2 cos^2)^(3/2)."""
    t = np.arange(0.0, period, 1.0 / rate)
    w = 2 * np.pi / period
    return Trajectory(t, np.column_stack([a * np.cos(w * t), b * np.sin(w * t)]))


def lemniscate(a=50.0, period=3.0, rate=RATE) -> Trajectory:
    """Lemniscate of Bernoulli traced uniformly in its parameter: curvature 3 r / a^2."""
    t = np.arange(0.0, period, 1.0 / rate)
    s, c = np.sin(2 * np.pi * t / period), np.cos(2 * np.pi * t / period)
    return Trajectory(t, np.column_stack([a * c / (1 + s * s), a * s * c / (1 + s * s)]))


@pytest.mark.parametrize("curve", [harmonic_ellipse, lemniscate])
@pytest.mark.parametrize("rho", [0.65, 0.75, 0.85])
def test_density_follows_curvature_on_smooth_curves(curve, rho):
    analysis = analyse(curve(), rho)
    assert analysis.correlation >= 0.8  # seed 001 Table 1: 0.84 - 0.90


def test_segment_curvature_matches_the_closed_form():
    traj = harmonic_ellipse(rate=2000.0)
    a, b = 60.0, 20.0
    theta = 2 * np.pi * traj.t / 3.0
    exact = a * b / (a**2 * np.sin(theta) ** 2 + b**2 * np.cos(theta) ** 2) ** 1.5
    bp = np.arange(0, traj.n, 50)
    mean_exact = []
    for i, j in itertools.pairwise(bp):
        ds = np.linalg.norm(np.diff(traj.pos[i : j + 1], axis=0), axis=1)
        mean_exact.append(np.sum(0.5 * (exact[i:j] + exact[i + 1 : j + 1]) * ds) / ds.sum())
    # The end samples of an open trajectory have no turning angle: skip the end segments.
    np.testing.assert_allclose(segment_curvature(traj.pos, bp)[1:-1], mean_exact[1:-1], rtol=2e-3)
    np.testing.assert_allclose(pointwise_curvature(traj.pos)[1:-1], exact[1:-1], rtol=2e-3)


def test_turning_angles_of_a_square_and_a_reversal_with_a_stop():
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]], float)
    np.testing.assert_allclose(turning_angles(square), [0, np.pi / 2, np.pi / 2, np.pi / 2, 0])
    # The pen stops (repeated samples) at a cusp: the reversal still counts, once.
    cusp = np.array([[0, 0], [1, 0], [2, 0], [2, 0], [2, 0], [1, 0]], float)
    np.testing.assert_allclose(turning_angles(cusp), [0, 0, np.pi, 0, 0, 0])
    # Its segment curvature is finite: the turn pi over the arc length 3.
    assert segment_curvature(cusp, [0, 5])[0] == pytest.approx(np.pi / 3)


def test_density_velocity_and_power_law_from_their_definitions():
    t = np.array([0.0, 1.0, 3.0, 4.0])
    pos = np.array([[0, 0], [3, 4], [3, 10], [3, 12]], float)
    traj = Trajectory(t, pos)
    bp = [0, 1, 2, 3]
    np.testing.assert_allclose(target_density(pos, bp), [1 / 5, 1 / 6, 1 / 2])
    np.testing.assert_allclose(target_velocity(traj, bp), [5.0, 3.0, 2.0])
    lengths = np.array([1.0, 2.0, 4.0, 8.0])
    law = fit_power_law(lengths, 3.0 * lengths**1.2)
    assert law.gamma == pytest.approx(1.2)
    assert law.gain == pytest.approx(3.0)
    assert law.r2 == pytest.approx(1.0)


def test_ellipse_power_law_is_reported():
    law = analyse(harmonic_ellipse(), 0.75).power_law
    assert 0.3 < law.gamma < 1.5  # 0.71 here; seed 001's 1.2 needs v ~ r^0.6 (test_gamma_timing)
    assert law.r2 > 0.8


def test_drawing_analysis_pools_strokes_and_skips_short_ones():
    drawing = Drawing(
        [
            harmonic_ellipse(),
            Trajectory(np.arange(4.0), np.zeros((4, 2)) + np.arange(4.0)[:, None]),
            lemniscate(),
        ]
    )
    result = analyse_drawing(drawing, 0.75)
    assert result.skipped == (1,)
    assert len(result.strokes) == 2
    density = np.concatenate([a.density for a in result.strokes])
    curvature = np.concatenate([a.curvature for a in result.strokes])
    assert result.correlation == pytest.approx(np.corrcoef(density, curvature)[0, 1])


def test_bad_analysis_inputs_are_refused():
    short = Trajectory(np.arange(6.0), np.column_stack([np.arange(6.0), np.arange(6.0) ** 2]))
    with pytest.raises(
        InputError, match=r"compression 0.75 leaves 1 segments on 6 samples; need at least 3"
    ):
        analyse(short, 0.75)
    with pytest.raises(InputError, match=r"compression rate: must lie in \(0, 1\), got 1.2"):
        analyse(harmonic_ellipse(), 1.2)
    with pytest.raises(InputError, match="power law: needs at least 3 segments"):
        fit_power_law([1.0, 2.0], [1.0, 2.0])
    with pytest.raises(
        InputError, match="no stroke has enough samples for 3 segments at compression 0.75"
    ):
        analyse_drawing(Drawing([short]), 0.75)


def test_cli_prints_correlation_and_gamma_and_writes_figures(tmp_path, capsys):
    Drawing([harmonic_ellipse()]).to_csv(tmp_path / "ellipse.csv")
    assert (
        main(
            [
                "analyse",
                str(tmp_path / "ellipse.csv"),
                "--compression",
                "0.75",
                "--out",
                str(tmp_path / "fig"),
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    correlation = float(out.split("\ncorrelation ")[1].split()[0])
    gamma = float(out.split("\ngamma ")[1].split()[0])
    expected = analyse(harmonic_ellipse(), 0.75)
    assert correlation == pytest.approx(expected.correlation, abs=1e-3)
    assert gamma == pytest.approx(expected.power_law.gamma, abs=1e-3)
    assert sorted(p.name for p in (tmp_path / "fig").iterdir()) == [
        "ellipse_stroke0_density_curvature.png",
        "ellipse_stroke0_power_law.png",
    ]


def test_cli_reports_bad_input_without_a_traceback(tmp_path, capsys):
    assert main(["analyse", str(tmp_path / "missing.csv")]) == 2
    assert "missing.csv: no such file" in capsys.readouterr().err
    Drawing([harmonic_ellipse()]).to_csv(tmp_path / "e.csv")
    assert main(["analyse", str(tmp_path / "e.csv"), "--compression", "1.5"]) == 2
    assert "must lie in (0, 1)" in capsys.readouterr().err


def test_straight_trace_has_no_density_curvature_correlation():
    t = np.linspace(0.0, 1.0, 200)
    straight = Trajectory(t=t, pos=np.column_stack([50.0 * t, 20.0 * t]))
    assert np.isnan(analyse(straight, 0.75).correlation)


def test_every_stroke_is_budgeted_before_any_is_analysed(monkeypatch):
    from inkarm.analysis import density
    from inkarm.core.budget import BudgetError

    calls = []
    monkeypatch.setattr(density, "analyse", lambda *a, **k: calls.append(a))
    big = harmonic_ellipse(rate=2000.0)  # 6000 samples: 8.6e9 exact DP steps
    with pytest.raises(BudgetError, match=r"stroke 1: exact DPPLA of 6000 samples") as info:
        analyse_drawing(Drawing([harmonic_ellipse(), big]), 0.75)
    assert info.value.variable == "INKARM_MAX_DPPLA_STEPS" and not calls
    # Strokes each within the budget but not together.
    from inkarm.analysis.dppla_budget import exact_cost

    monkeypatch.setenv("INKARM_MAX_DPPLA_STEPS", str(2.5 * exact_cost(54, 330)[0]))
    with pytest.raises(BudgetError, match=r"exact DPPLA of 3 strokes, 990 samples"):
        analyse_drawing(Drawing([harmonic_ellipse()] * 3), 0.75)
    assert not calls


def test_sample_times_too_close_for_a_finite_speed_are_refused():
    t = np.arange(40) * 5e-324
    trace = Trajectory(t, np.column_stack([np.cos(np.arange(40) / 5), np.sin(np.arange(40) / 3)]))
    with pytest.raises(InputError, match=r"target velocity: segment 0 .* too short in time"):
        analyse(trace, 0.75)
