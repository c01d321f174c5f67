"""Trace -> DPPLA targets -> Gaussian motor plan -> LQT."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.analysis.dppla import segments_for_compression
from inkarm.cli import main
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError
from inkarm.plans.restyle import RestyleConfig, geometric_covariances, restyle


def figure_eight(rate=200.0) -> Trajectory:
    t = np.arange(0.0, 3.0, 1.0 / rate)
    w = 2 * np.pi / 3.0
    return Trajectory(t, np.column_stack([100 + 60 * np.cos(w * t), 100 + 20 * np.sin(2 * w * t)]))


def distance_to(points: np.ndarray, curve: np.ndarray) -> np.ndarray:
    return np.min(np.linalg.norm(points[:, None, :] - curve[None, :, :], axis=2), axis=1)


def test_geometric_covariances_are_elongated_along_the_chord():
    targets = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [10.0, 30.0]])
    covs = geometric_covariances(targets, along=0.5, across=0.1, min_std=0.01)
    # Target 1: chord from target 0 to target 2 along (1, 1)/sqrt 2; mean segment length 10.
    vals, vecs = np.linalg.eigh(covs[1])
    np.testing.assert_allclose(vals, [1.0, 25.0])
    np.testing.assert_allclose(np.abs(vecs[:, 1]), [2**-0.5, 2**-0.5])
    # Target 3 (an end): along its only segment (0, 1), of length 20.
    np.testing.assert_allclose(covs[3], np.diag([4.0, 100.0]))
    tiny = geometric_covariances(np.array([[0.0, 0.0], [1e-6, 0.0]]), 0.5, 0.1, min_std=0.2)
    np.testing.assert_allclose(tiny, [0.04 * np.eye(2)] * 2)


def test_restyled_stroke_follows_the_trace_through_its_targets():
    trace = Drawing([figure_eight()])
    out = restyle(trace, RestyleConfig(compression=0.95))
    (stroke,) = out.drawing.strokes
    (result,) = out.targets
    assert result.k == segments_for_compression(0.95, 600, 2)
    np.testing.assert_allclose(out.plan.strokes[0].means, trace.strokes[0].pos[result.breakpoints])
    assert stroke.duration == pytest.approx(trace.strokes[0].duration, abs=0.02)
    # Close to the trace everywhere (the figure is 120 x 40 mm), and passes near every target.
    assert distance_to(stroke.pos, trace.strokes[0].pos).max() < 3.0
    assert distance_to(out.plan.strokes[0].means, stroke.pos).max() < 2.0


def test_fewer_targets_at_higher_compression_and_semi_tied_style():
    trace = Drawing([figure_eight()])
    few = restyle(trace, RestyleConfig(compression=0.98))
    many = restyle(trace, RestyleConfig(compression=0.9))
    assert few.targets[0].k < many.targets[0].k
    tied = restyle(trace, RestyleConfig(style="semi-tied"))
    covs = tied.plan.strokes[0].covs
    np.testing.assert_allclose(covs, np.broadcast_to(covs[0], covs.shape))
    assert covs[0][0, 1] != 0.0  # the shear tilts every ellipse alike


def test_cli_writes_csv_svg_and_figure(tmp_path, capsys):
    Drawing([figure_eight()]).to_csv(tmp_path / "eight.csv")
    code = main(
        [
            "restyle",
            str(tmp_path / "eight.csv"),
            "--out",
            str(tmp_path / "out"),
            "--compression",
            "0.95",
            "--order",
            "3",
            "--d",
            "4",
        ]
    )
    assert code == 0
    assert "1 strokes" in capsys.readouterr().out
    back = Drawing.from_csv(tmp_path / "out" / "eight_restyled.csv")
    assert len(back.strokes) == 1 and back.strokes[0].n > 100
    assert "<polyline" in (tmp_path / "out" / "eight_restyled.svg").read_text()
    assert (tmp_path / "out" / "eight_restyle.png").stat().st_size > 1000


def test_cli_restyles_an_svg_path(tmp_path):
    (tmp_path / "s.svg").write_text(
        '<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">'
        '<path d="M10 50 C 30 10 50 90 70 50 S 90 10 95 40"/><polyline points="10,90 40,80 10,70"/></svg>'
    )
    assert main(["restyle", str(tmp_path / "s.svg"), "--out", str(tmp_path / "o")]) == 0
    assert len(Drawing.from_csv(tmp_path / "o" / "s_restyled.csv").strokes) == 2


def test_bad_restyle_inputs_are_refused(tmp_path, capsys):
    with pytest.raises(InputError, match=r"compression: must lie in \(0, 1\), got 1.0"):
        RestyleConfig(compression=1.0)
    with pytest.raises(InputError, match="style: expected one of"):
        RestyleConfig(style="gothic")
    with pytest.raises(InputError, match="across: must be positive"):
        RestyleConfig(across=0.0)
    with pytest.raises(InputError, match="no stroke with at least 3 samples"):
        restyle(Drawing([Trajectory([0.0, 1.0], [[0.0, 0.0], [1.0, 1.0]])]))
    assert main(["restyle", str(tmp_path / "none.svg"), "--out", str(tmp_path)]) == 2
    assert "none.svg: no such file" in capsys.readouterr().err
    (tmp_path / "e.svg").write_text('<svg xmlns="http://www.w3.org/2000/svg">'
                                    '<circle r="3" display="none"/></svg>')
    assert main(["restyle", str(tmp_path / "e.svg"), "--out", str(tmp_path)]) == 2
    assert "e.svg: no drawable shape (visible, of non-zero length) found; skipped 1 element: " \
        "1 hidden" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("kwargs", "key", "message"),
    [
        ({"d": 1e-300}, "d", r"must lie in \[0.001, 10000\] mm"),
        ({"d": float("inf")}, "d", "must lie in"),
        ({"dt": 0.0}, "dt", r"must lie in \[0.0001, 1\] s"),
        ({"dt": 1e300}, "dt", "must lie in"),
        ({"segment_time": 1e300}, "segment_time", "at most 10000"),
        ({"along": 1e300}, "along", "at most 100"),
        ({"min_std": float("nan")}, "min_std", "must be positive"),
        ({"shear": 1e300}, "shear", "expected a number"),
        ({"order": 8}, "order", r"expected an integer 1..7"),
        ({"order": True}, "order", r"expected an integer 1..7"),
    ],
)
def test_config_out_of_range_is_refused_with_its_key(kwargs, key, message):
    with pytest.raises(InputError, match=message) as info:
        RestyleConfig(**kwargs)
    assert info.value.key == key


def test_lqt_steps_and_dppla_are_budgeted_before_any_stroke_is_restyled(monkeypatch):
    from inkarm.core.budget import BudgetError
    from inkarm.models import lqt

    monkeypatch.setattr(lqt, "solve", lambda *a, **k: pytest.fail("solved before the check"))
    trace = Drawing([figure_eight(), figure_eight()])
    with pytest.raises(BudgetError, match=r"LQT of the restyled drawing .*about 1.2e\+06 time "
                       r"steps.*INKARM_MAX_STEPS") as info:
        restyle(trace, RestyleConfig(segment_time=300.0))
    assert info.value.key == "segment_time"
    with pytest.raises(BudgetError, match=r"LQT of the restyled drawing") as info:
        slow = figure_eight()
        restyle(Drawing([Trajectory(slow.t * 1000, slow.pos)]), RestyleConfig(dt=1e-3))
    assert info.value.key == "dt"
    monkeypatch.setenv("INKARM_MAX_DPPLA_STEPS", "1000")
    with pytest.raises(BudgetError, match=r"stroke 0: .*DPPLA of 600 samples"):
        restyle(trace, RestyleConfig(banded=False))
