"""``inkarm calibrate`` and ``inkarm draw --calibration``: what they print and write, where, and
every refusal with its message."""

from __future__ import annotations

import sys
import types
from pathlib import Path

import numpy as np
import pytest

from inkarm.cli import main
from inkarm.robots.calibration import (
    CellCalibration,
    HeightMap,
    read_calibration,
    write_calibration,
)
from inkarm.robots.geometry import GeometryErrors

SCENARIOS = Path(__file__).parents[2] / "scenarios"


@pytest.fixture(autouse=True)
def config_dir(monkeypatch, tmp_path):
    monkeypatch.setenv("INKARM_CONFIG_DIR", str(tmp_path / "config"))
    return tmp_path / "config"


def _main(capsys, *argv) -> tuple[int, str, str]:
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


def test_calibrate_without_what_says_what_it_can(capsys):
    status, _, err = _main(capsys, "calibrate")
    assert status == 2
    assert "inkarm calibrate: error: WHAT: expected what to calibrate: joints, paper, pen, " \
           "kinematics, all (e.g. `inkarm calibrate joints --port PORT`" in err


@pytest.mark.parametrize("argv", [
    ("calibrate", "--port", "/dev/null-no-such-port"),  # the old form
    ("calibrate", "joints", "--port", "/dev/null-no-such-port"),
])
def test_the_joints_calibration_opens_the_port_in_both_forms(capsys, argv):
    status, _, err = _main(capsys, *argv, "--robot", "wx250s")
    assert status == 2 and "cannot open /dev/null-no-such-port" in err


def test_calibrate_paper_writes_the_robots_file_and_says_what_it_found(capsys, config_dir):
    status, out, err = _main(capsys, "calibrate", "paper", str(SCENARIOS / "quick_stroke.toml"),
                             "--spacing", "5", "--quiet")
    assert status == 0, err
    path = config_dir / "calibration" / "iiwa14.toml"
    lines = out.splitlines()
    assert lines[0].startswith("paper: ") and "touches; heights " in lines[0]
    assert "RMS residual" in lines[0]
    assert lines[1].startswith("calibration of iiwa14: paper map ")
    assert lines[2] == f"wrote {path} (draw with it: inkarm draw --calibration auto)"
    cal = read_calibration(path)
    assert cal.robot == "iiwa14" and cal.paper is not None and cal.geometry.is_zero
    assert cal.notes[0].startswith("paper: ") and "(sim, scenario 'Quick stroke (LQT)')" in \
        cal.notes[0]
    # on the believed sheet the map is flat at 0 (the stroke is straight: constant across it)
    assert np.abs(cal.paper.z_mm).max() < 0.02


def test_calibrate_paper_refuses_what_cannot_probe(capsys, tmp_path):
    status, _, err = _main(capsys, "calibrate", "paper", "--backend", "dynamixel", "--quiet")
    # (an arm without a force sensor probes with ramped dashes read from their ink: a port)
    assert status == 2 and "--port: the dynamixel backend needs a serial port" in err
    status, _, err = _main(capsys, "calibrate", "paper", "--spacing", "0", "--quiet")
    assert status == 2 and "--spacing: expected a spacing of 0.5 to 100 mm, got 0" in err
    status, _, err = _main(capsys, "calibrate", "paper", "--backend", "simm", "--quiet")
    assert status == 2 and "did you mean 'sim'" in err
    write_calibration(CellCalibration("wx250s"), tmp_path / "other.toml")
    status, _, err = _main(capsys, "calibrate", "paper", "--out", str(tmp_path / "other.toml"),
                           "--quiet")
    assert status == 2 and "is the calibration of robot 'wx250s', not 'iiwa14'" in err


def test_calibrate_pen_and_kinematics_merge_only_their_part(capsys, monkeypatch, tmp_path):
    out = tmp_path / "cell.toml"
    paper = HeightMap([0.0, 1.0], [0.0, 1.0], np.full((2, 2), 0.25))
    write_calibration(CellCalibration("iiwa14", paper=paper, geometry=GeometryErrors(
        link_length_mm=(0.0, 0.5), joint_offset_deg=(0.1, 0.2), tip_offset_mm=(1.0, 1.0, 1.0))),
        out)
    seen = {}

    def calibrate_pen(scenario, backend, options, progress):
        seen["pen"] = scenario.calibration
        return GeometryErrors(link_length_mm=(0.0, 9.0), tip_offset_mm=(0.0, 0.5, 2.0))

    def calibrate_kinematics(scenario, backend, options, progress):
        seen["kinematics"] = scenario.calibration
        return GeometryErrors(link_length_mm=(0.0, -0.25), joint_offset_deg=(0.05, 0.0),
                              tip_offset_mm=(9.0, 9.0, 9.0)), "before 0.6 mm, after 0.1 mm"

    for name, fn in (("pen", calibrate_pen), ("kinematics", calibrate_kinematics)):
        fake = types.ModuleType(f"inkarm.jobs.calibration_{name}")
        setattr(fake, fn.__name__, fn)
        monkeypatch.setitem(sys.modules, fake.__name__, fake)
    status, text, err = _main(capsys, "calibrate", "pen", "--out", str(out), "--quiet")
    assert status == 0, err
    assert "pen: tip offset (+0.000, +0.500, +2.000) mm in the flange frame" in text
    g = read_calibration(out).geometry
    assert g.tip_offset_mm == (0.0, 0.5, 2.0) and g.link_length_mm == (0.0, 0.5)
    assert seen["pen"].geometry.tip_offset_mm == (0.0, 0.0, 0.0)  # probed without its part
    assert seen["pen"].paper is not None
    status, text, err = _main(capsys, "calibrate", "kinematics", "--out", str(out), "--quiet")
    assert status == 0, err
    assert "kinematics: before 0.6 mm, after 0.1 mm" in text
    back = read_calibration(out)
    assert back.geometry == GeometryErrors(link_length_mm=(0.0, -0.25),
                                           joint_offset_deg=(0.05, 0.0),
                                           tip_offset_mm=(0.0, 0.5, 2.0))
    assert seen["kinematics"].geometry.link_length_mm == ()
    np.testing.assert_array_equal(back.paper.z_mm, paper.z_mm)
    assert [n.split(":")[0] for n in back.notes] == ["pen", "kinematics"]


def test_calibrate_pen_without_its_module_says_so(capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "inkarm.jobs.calibration_pen", None)
    status, _, err = _main(capsys, "calibrate", "pen", "--quiet")
    assert status == 2  # (None in sys.modules: the import fails as for a missing module)
    assert "WHAT: calibrate pen is not available in this installation (no " \
           "inkarm.jobs.calibration_pen)" in err


def test_a_calibration_of_another_joint_count_is_refused_naming_its_file(capsys, tmp_path):
    path = tmp_path / "short.toml"
    write_calibration(CellCalibration("iiwa14", geometry=GeometryErrors(
        link_length_mm=(0.0, 1.0))), path)
    status, _, err = _main(capsys, "draw", "--calibration", str(path), "--check")
    assert status == 2
    assert (f"{path}: geometry.link_length_mm: expected 7 numbers (one per joint of iiwa14), "
            "got 2") in err


def test_draw_with_a_calibration(capsys, tmp_path, config_dir):
    status, out, err = _main(capsys, "draw", "--calibration", str(tmp_path / "none.toml"),
                             "--check")
    assert status == 2 and "no such calibration file" in err
    status, out, err = _main(capsys, "draw", "--calibration", "auto", "--check")
    assert status == 0 and out.startswith("ok: ")
    write_calibration(CellCalibration("iiwa14", geometry=GeometryErrors(
        tip_offset_mm=(0.0, 0.0, 0.5))), config_dir / "calibration" / "iiwa14.toml")
    status, out, err = _main(capsys, "draw", str(SCENARIOS / "quick_stroke.toml"),
                             "--calibration", "auto", "--quiet", "--out", str(tmp_path / "run"))
    assert status in (0, 1), err
    path = config_dir / "calibration" / "iiwa14.toml"
    assert f"note: calibration: {path}: pen tip (+0.00, +0.00, +0.50) mm" in out
    status, out, err = _main(capsys, "draw", str(SCENARIOS / "quick_stroke.toml"),
                             "--calibration", "none", "--quiet", "--out", str(tmp_path / "r2"))
    assert status in (0, 1) and "note: calibration" not in out


@pytest.mark.slow
def test_calibrate_all_then_draw_within_the_bounds(capsys, tmp_path, config_dir):
    """The pen 2 mm long and 1 mm off its axis, links 1 mm and joints 0.2 deg off: degraded on
    the model's belief; `calibrate all` (pen, kinematics, paper), then ok within the README's
    bounds."""
    from inkarm.jobs.robustness import ARM_OFF, PEN_OFF

    plant = "\n".join(f"{k} = {v}" for k, v in {**PEN_OFF, **ARM_OFF}.items())
    default = (Path(__file__).parents[2] / "inkarm" / "data" / "default.toml").read_text()
    scenario = tmp_path / "off.toml"
    scenario.write_text(f"{default}\n[sim.plant]\n{plant}\nseed = 0\n")
    status, out, err = _main(capsys, "draw", str(scenario), "--quiet", "--out",
                             str(tmp_path / "before"))
    assert status == 0 and "the drawing is degraded: tracking RMS" in err, out + err
    status, out, err = _main(capsys, "calibrate", "all", str(scenario), "--quiet")
    assert status == 0, err
    tip = read_calibration(config_dir / "calibration" / "iiwa14.toml").geometry.tip_offset_mm
    assert abs(tip[0] - 1.0) < 0.2 and abs(tip[1]) < 0.2  # across the pen: its offset
    status, out, err = _main(capsys, "draw", str(scenario), "--calibration", "auto", "--quiet",
                             "--out", str(tmp_path / "after"))
    import json

    verdict = json.loads((tmp_path / "after" / "status.json").read_text())
    assert status == 0 and verdict["status"] == "ok", out + err
