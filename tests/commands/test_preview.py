"""``inkarm preview FILE.gcode --out FILE.png``: the job on the emulator's planner, drawn."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from inkarm.cli import main
from inkarm.hardware.plotter.gcode_file import read_gcode_file
from inkarm.hardware.plotter.job_timeline import job_timeline
from inkarm.hardware.plotter.timing import estimate_seconds

DATA = Path(__file__).resolve().parents[1] / "data" / "gcode"
QUICK_JOB = DATA / "compass_quick.gcode"  # vpype-gcode, 183 lines
PNG = b"\x89PNG\r\n\x1a\n"


def test_preview_writes_a_png_and_reports_the_planners_total_time(tmp_path, capsys):
    out = tmp_path / "compass.png"
    assert main(["preview", str(QUICK_JOB), "--out", str(out), "--setting", "110=500",
                 "--setting", "120=10"]) == 0
    assert out.read_bytes()[:8] == PNG
    printed = capsys.readouterr().out
    job = read_gcode_file(QUICK_JOB)
    expected = estimate_seconds(job.lines, {110: 500.0, 120: 10.0})
    assert re.search(r"182 lines, estimated ([\d.]+) s", printed).group(1) == f"{expected:.1f}"
    assert [p.name for p in tmp_path.iterdir()] == ["compass.png"]  # (no partial file left)


def test_the_timeline_total_is_the_estimate_and_its_feed_moves_draw(tmp_path):
    path = tmp_path / "job.gcode"
    path.write_text("G21 G90\nG0 X50\nG1 X150 F600\nG0 X0 Y0\n")
    job = read_gcode_file(path)
    tl = job_timeline(job)
    assert tl.seconds == pytest.approx(estimate_seconds(job.lines), rel=1e-9)
    assert tl.t[-1] == pytest.approx(tl.seconds)
    # the G1 cruises at its feed (600 mm/min = 10 mm/s); the rapids at $110 = 12000 mm/min
    assert np.max(tl.speed[tl.drawing]) == pytest.approx(10.0, rel=0.03)
    assert np.max(tl.speed[~tl.drawing]) == pytest.approx(200.0, rel=0.01)
    assert set(tl.line[tl.drawing]) == {3}
    assert tl.drawing_s == pytest.approx(10.0, abs=0.2)  # 100 mm at 10 mm/s, plus ramps
    drawn = tl.xyz[tl.drawing]
    assert drawn[:, 0].min() >= 50.0 - 1e-6 and drawn[:, 0].max() <= 150.0 + 1e-6
    assert tl.travel_mm == (300.0, 300.0)


def test_the_figure_draws_on_given_axes_or_its_own(tmp_path):
    from inkarm.plots.figure import new_figure
    from inkarm.plots.gcode_preview import preview_figure

    path = tmp_path / "job.gcode"
    path.write_text("G21 G90\nG0 X5 Y5\nG1 X20 Y5 F1200\nG1 X20 Y20\nG0 X0 Y0\n")
    tl = job_timeline(read_gcode_file(path))
    args = (tl.t, tl.xyz, tl.speed, tl.drawing, tl.travel_mm, tl.seconds)
    fig = preview_figure(*args, title="job")
    assert len(fig.axes) == 3  # plan, speed, colour bar
    assert "job: " in fig._suptitle.get_text() and f"{tl.seconds:.1f} s" in \
        fig._suptitle.get_text()
    mine = new_figure((8, 4))
    axes = mine.subplots(1, 2)
    assert preview_figure(*args, ax=axes) is mine


@pytest.mark.parametrize("argv, expected", [
    (["preview", "none.gcode", "--out", "p.png"], "none.gcode: no such file"),
    (["preview", str(QUICK_JOB), "--out", "p.txt"], "expected a picture file name"),
    (["preview", str(QUICK_JOB), "--out", "p.png", "--setting", "999=1"], "$999"),
])
def test_bad_inputs_exit_2_naming_them(tmp_path, monkeypatch, capsys, argv, expected):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    assert expected in capsys.readouterr().err
    assert not (tmp_path / "p.png").exists()


def test_a_bad_line_is_named(tmp_path, capsys):
    path = tmp_path / "job.gcode"
    path.write_text("G21\nG1 X5 Y5 F100 Q3\n")
    assert main(["preview", str(path), "--out", str(tmp_path / "p.png")]) == 2
    assert f"{path}: line 2: GRBL 1.1h refuses" in capsys.readouterr().err


@pytest.mark.parametrize("setting, expected", [
    ("110", "expected N=VALUE"), ("$110=fast", "expected N=VALUE"),
    ("20=1", "$20=1.0: GRBL 1.1h refuses it (error:10"), ("110=-5", "$110=-5.0: GRBL 1.1h refuses it (error:4"),
])
def test_a_bad_setting_is_refused(tmp_path, capsys, setting, expected):
    assert main(["preview", str(QUICK_JOB), "--out", str(tmp_path / "p.png"), "--setting",
                 setting]) == 2
    assert f"--setting: {expected}" in capsys.readouterr().err
    assert not (tmp_path / "p.png").exists()
