"""``inkarm calibrate pen|kinematics|paper --drawn FILE.npz``, then ``--read FILE.npz --scan
SHEET.png``: a real arm's two steps, end to end in simulation. The pattern is drawn on the sim
backend through the CLI; the runs' canvases (recorded on the way: a drawn file keeps no ink) are
written as the "scan"; the fit read back from it equals the one-step fit of the canvases."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

from inkarm.cli import main
from inkarm.robots.calibration import read_calibration

DEFAULT = Path(__file__).parents[2] / "inkarm" / "data" / "default.toml"
KINEMATIC_ERRORS = ("[sim.plant]\nlink_length_error_mm = 1.0\njoint_offset_error_deg = 0.2\n"
                    "seed = 0\n")
PEN_ERRORS = "[sim.plant]\npen_length_error_mm = 2.0\npen_offset_mm = 1.0\n"
PAPER_ERRORS = "[sim.plant]\npaper_height_mm = 1.5\n"


def _main(capsys, *argv) -> tuple[int, str, str]:
    """``inkarm ARGV``: its status, stdout and stderr (``capsys`` None: caught here, for a
    module fixture)."""
    if capsys is None:
        import contextlib
        import io

        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            status = main([str(a) for a in argv])
        return status, out.getvalue(), err.getvalue()
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


def _scenario(folder: Path, plant: str) -> Path:
    """The embedded letter N with the plant's ``[sim.plant]`` table."""
    path = folder / "scenario.toml"
    path.write_text(DEFAULT.read_text(encoding="utf-8") + "\n" + plant, encoding="utf-8")
    return path


def _light(runs) -> np.ndarray:
    """One sheet with every run's ink: lightness 1 - darkness, multiplied (row 0 at the top)."""
    light = np.ones(runs[0].canvas.shape)
    for run in runs:
        light *= 1.0 - np.asarray(run.canvas.image, dtype=float)
    return light


def _png(light: np.ndarray, path: Path) -> Path:
    from PIL import Image

    Image.fromarray(np.round(255 * np.clip(light, 0, 1)).astype(np.uint8), mode="L").save(path)
    return path


def _drawn(capsys, folder: Path, what: str, plant: str, *extra):
    """``calibrate WHAT SCENARIO --drawn`` on the sim backend; returns (the file, the runs)."""
    from inkarm.jobs import backends

    runs = []
    real = backends.run_backend

    def recording(*args, **kwargs):
        run = real(*args, **kwargs)
        runs.append(run)
        return run

    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("INKARM_CONFIG_DIR", str(folder / "config"))
        mp.setattr(backends, "run_backend", recording)
        status, out, err = _main(capsys, "calibrate", what, _scenario(folder, plant), "--drawn",
                                 folder / f"{what}.npz", "--quiet", *extra)
    assert status == 0, err
    assert f"wrote {folder / what}.npz" in out and f"calibrate {what} --read" in out
    return folder / f"{what}.npz", runs


@pytest.fixture(autouse=True)
def config_dir(monkeypatch, tmp_path):
    monkeypatch.setenv("INKARM_CONFIG_DIR", str(tmp_path / "config"))
    return tmp_path / "config"


@pytest.fixture(scope="module")
def kinematics(tmp_path_factory):
    """The kinematic pattern drawn once (3 postures) and its sheet as a PNG."""
    folder = tmp_path_factory.mktemp("kinematics")
    drawn, runs = _drawn(None, folder, "kinematics", KINEMATIC_ERRORS)
    return drawn, runs, _png(_light(runs), folder / "sheet.png")


def _params(geometry, n: int) -> np.ndarray:
    from inkarm.control.calibration.kinematics import parameter_scales, params_of

    return params_of(geometry, n) / parameter_scales(n)


def _canvas_fit(drawn: Path, runs):
    """The one-step fit: the same pattern's marks on the runs' canvases."""
    from inkarm.jobs.calibration_kinematics import fit_pattern, load_pattern

    pattern, _ = load_pattern(drawn)
    return pattern, fit_pattern(dataclasses.replace(pattern, runs=tuple(runs)))


@pytest.mark.slow
def test_kinematics_read_from_the_scan_equal_the_one_step_fit(kinematics, capsys, tmp_path):
    drawn, runs, sheet = kinematics
    assert len(runs) == 3
    out_file = tmp_path / "cal.toml"
    status, out, err = _main(capsys, "calibrate", "kinematics", "--read", drawn, "--scan", sheet,
                             "--out", out_file)
    assert status == 0, err
    assert out.startswith("kinematics: 90 marks: residual RMS ")
    assert f"wrote {out_file}" in out
    cal = read_calibration(out_file)
    pattern, one_step = _canvas_fit(drawn, runs)
    n = len(pattern.model.joint_names)
    assert one_step.residual_before_mm > 1.0 and one_step.residual_after_mm < 0.05
    assert np.abs(_params(cal.geometry, n) - _params(one_step.geometry, n)).max() < 0.005
    assert cal.geometry.tip_offset_mm == (0.0, 0.0, 0.0)
    assert any("scan sheet.png of kinematics.npz" in note for note in cal.notes)


@pytest.mark.slow
def test_a_photographed_sheet_warped_in_perspective_reads_through_its_corners(kinematics,
                                                                             capsys, tmp_path):
    """The sheet seen at a slant on a larger, grey desk: its corners given in pixels."""
    from scipy.ndimage import map_coordinates

    from inkarm.control.calibration.marks import apply_homography, homography, read_darkness

    drawn, runs, sheet = kinematics
    light = 1.0 - read_darkness(sheet)
    rows, cols = light.shape
    corners = np.array([[60.0, rows + 150.0], [cols + 110.0, rows + 90.0],
                        [cols - 40.0, 30.0], [140.0, 80.0]])  # (u, v) of LL, LR, UR, UL
    own = np.array([[0.0, rows], [cols, rows], [cols, 0.0], [0.0, 0.0]])
    h = homography(corners, own)  # photo pixel -> scan pixel (pixel edges)
    v, u = np.mgrid[0:rows + 200, 0:cols + 200]
    src = apply_homography(h, np.column_stack([u.ravel() + 0.5, v.ravel() + 0.5])) - 0.5
    photo = map_coordinates(light, [src[:, 1], src[:, 0]], order=1, cval=0.8)
    photo = _png(photo.reshape(u.shape), tmp_path / "photo.png")
    text = " ".join(f"{a:g},{b:g}" for a, b in corners)
    out_file = tmp_path / "cal.toml"
    status, _out, err = _main(capsys, "calibrate", "kinematics", "--read", drawn, "--scan", photo,
                             "--corners", text, "--out", out_file)
    assert status == 0, err
    pattern, one_step = _canvas_fit(drawn, runs)
    n = len(pattern.model.joint_names)
    fitted = read_calibration(out_file).geometry
    assert np.abs(_params(fitted, n) - _params(one_step.geometry, n)).max() < 0.03


@pytest.mark.slow
def test_the_pen_read_from_the_scan_equals_the_one_step_fit(capsys, tmp_path):
    from inkarm.jobs.calibration_pen import fit_pen, load_pen

    drawn, runs = _drawn(capsys, tmp_path, "pen", PEN_ERRORS)
    assert len(runs) == 1
    sheet = _png(_light(runs), tmp_path / "sheet.png")
    status, out, err = _main(capsys, "calibrate", "pen", "--read", drawn, "--scan", sheet)
    assert status == 0, err
    assert out.startswith("pen: tip offset (")
    cal = read_calibration(tmp_path / "config" / "calibration" / "iiwa14.toml")
    loaded, _ = load_pen(drawn)
    one_step = fit_pen(dataclasses.replace(loaded, run=runs[0]))
    tip, expected = np.array(cal.geometry.tip_offset_mm), np.array(one_step.geometry.tip_offset_mm)
    assert np.linalg.norm(expected) > 1.0  # (the plant's pen: 2 mm longer, 1 mm off its axis)
    np.testing.assert_allclose(tip, expected, atol=0.005)


@pytest.mark.slow
def test_the_paper_read_from_the_scan_equals_the_one_step_fit(capsys, tmp_path):
    from inkarm.jobs.calibration import load_dashes, read_dashes

    drawn, runs = _drawn(capsys, tmp_path, "paper", PAPER_ERRORS)
    sheet = _png(_light(runs), tmp_path / "sheet.png")
    status, out, err = _main(capsys, "calibrate", "paper", "--read", drawn, "--scan", sheet)
    assert status == 0, err
    assert out.startswith("paper: ") and " dashes" not in out.splitlines()[0][:8]
    paper = read_calibration(tmp_path / "config" / "calibration" / "iiwa14.toml").paper
    loaded, _ = load_dashes(drawn)
    one_step = read_dashes(dataclasses.replace(loaded, canvas=runs[0].canvas))
    xy = one_step.points_mm[:, :2]
    z = one_step.points_mm[:, 2]
    assert abs(z.mean() - 1.5) < 0.25  # (the planted sheet: 1.5 mm above the model's)
    np.testing.assert_allclose(paper.height(xy[:, 0], xy[:, 1]),
                               one_step.map.height(xy[:, 0], xy[:, 1]), atol=0.12)


# -- refusals, each naming its option ------------------------------------------------------


@pytest.fixture(scope="module")
def small_drawn(tmp_path_factory):
    """A kinematics drawn file of two dots (no run: the refusals come before any fit)."""
    from inkarm.control.calibration.kinematics import DotReadings
    from inkarm.jobs.calibration_kinematics import DrawnPattern, save_pattern
    from inkarm.jobs.scenario import load_scenario
    from inkarm.robots.geometry import GeometryErrors

    scenario = load_scenario()
    q = np.tile(np.array([j.home for j in scenario.robot.joints]), (2, 1))
    pattern = DrawnPattern((np.array([[50.0, 50.0], [80.0, 50.0]]),),
                           (DotReadings(q, np.zeros(2), np.zeros((2, 2))),), (), None,
                           GeometryErrors(), None)
    folder = tmp_path_factory.mktemp("small")
    path = save_pattern(pattern, scenario, folder / "k")
    assert path == folder / "k.npz"
    return path


def _page_png(path: Path, size_px: tuple[int, int], dots: bool = True) -> Path:
    light = np.ones(size_px)
    if dots:
        light[100:104, 100:104] = 0.0
    return _png(light, path)


def test_a_drawn_file_keeps_the_pattern_and_its_scenario(small_drawn):
    from inkarm.jobs.calibration_kinematics import load_pattern

    pattern, scenario = load_pattern(small_drawn)
    assert scenario.robot.name == "iiwa14" and scenario.title.startswith("Default")
    assert pattern.runs == () and pattern.calibration is None
    np.testing.assert_array_equal(pattern.points_mm[0], [[50.0, 50.0], [80.0, 50.0]])
    assert pattern.readings[0].q.shape == (2, scenario.robot.n)


@pytest.mark.parametrize(("argv", "match"), [
    (("--scan", "{png}"), r"--scan: --scan and --corners go with --read"),
    (("--read", "{drawn}"), r"--scan: --read .* needs the scan of its sheet: --scan SHEET.png"),
    (("--read", "{drawn}", "--drawn", "x.npz", "--scan", "{png}"),
     r"--read: --drawn draws a pattern and --read fits a drawn one"),
    (("--read", "{drawn}", "--scan", "{png}", "--corners", "1,2 3,4 5,6"),
     r"--corners: expected the sheet's 4 corners as \"u,v u,v u,v u,v\" pixels"),
    (("--read", "{drawn}", "--scan", "{png}", "--corners", "1,2 3,4 5,6 a,b"),
     r"--corners: expected the sheet's 4 corners"),
    (("--read", "{drawn}", "--scan", "{wide}"),
     (r"--scan: .*wide.png: 400x300 px has an aspect of 1.333, the drawn page .* a scan of "
     r"another page size")),
    (("--read", "{drawn}", "--scan", "{blank}"), r"--scan: no marks found in .*blank.png"),
    (("--read", "{drawn}", "--scan", "{png}", "--robot", "wx250s"),
     r"--robot: .*k.npz was drawn by robot 'iiwa14', not 'wx250s'"),
    (("--read", "{drawn}", "--scan", "{png}", "--robot", "{wx250s_file}"),
     r"--robot: .*k.npz was drawn by robot 'iiwa14', not 'wx250s'"),
    (("--read", "{missing}", "--scan", "{png}"), r"--read: no such drawn file: .*nothing.npz"),
])
def test_the_scan_step_refuses_naming_the_option(capsys, tmp_path, small_drawn, argv, match):
    from inkarm.jobs.scenario import load_scenario
    from inkarm.sim.cell_config import Cell

    scenario = load_scenario()
    w, h = Cell(scenario.cell, scenario.robot).paper_size_mm
    page = (round(2 * h), round(2 * w))  # (rows, cols)
    names = {"png": _page_png(tmp_path / "page.png", page),
             "wide": _page_png(tmp_path / "wide.png", (300, 400)),
             "blank": _page_png(tmp_path / "blank.png", page, dots=False),
             "drawn": small_drawn, "missing": tmp_path / "nothing.npz",
             "wx250s_file": Path(__file__).parents[2] / "inkarm/robots/data/wx250s.toml"}
    status, _, err = _main(capsys, "calibrate", "kinematics",
                           *(a.format(**names) for a in argv))
    assert status == 2
    assert re.search(match, err), err


def test_a_drawn_file_of_another_part_is_refused(capsys, tmp_path, small_drawn):
    sheet = _page_png(tmp_path / "page.png", (10, 10))
    status, _, err = _main(capsys, "calibrate", "pen", "--read", small_drawn, "--scan", sheet)
    assert status == 2
    assert "--read: " in err and "holds a drawn kinematics pattern, not pen (read it with " \
        "`inkarm calibrate kinematics --read" in err


def test_a_file_that_is_not_a_drawn_file_is_refused(capsys, tmp_path):
    other = tmp_path / "log.npz"
    np.savez(other, q=np.zeros(3))
    sheet = _page_png(tmp_path / "page.png", (10, 10))
    status, _, err = _main(capsys, "calibrate", "paper", "--read", other, "--scan", sheet)
    assert status == 2 and "--read: " in err and "is not a drawn calibration file" in err


def test_all_has_no_two_step_form(capsys):
    with pytest.raises(SystemExit):
        main(["calibrate", "all", "--drawn", "x.npz"])
    assert "unrecognized arguments: --drawn" in capsys.readouterr().err
