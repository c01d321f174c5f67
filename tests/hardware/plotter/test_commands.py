"""inkarm gcode, inkarm emulate grbl and inkarm draw --backend plotter."""

import json
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from inkarm.cli import main
from inkarm.hardware.plotter.emulator import EmulatorConfig, GrblEmulator
from inkarm.hardware.plotter.stream import GrblStreamer
from inkarm.jobs.backends import backend_names


def test_gcode_writes_a_job_and_its_estimate(tmp_path, capsys):
    out = tmp_path / "n.gcode"
    assert main(["gcode", "inkarm/data/default.toml", "--out", str(out), "--optimise"]) == 0
    lines = out.read_text().splitlines()
    assert lines[0] == "G21" and "M3 S1000" in lines and lines[-1] == "G0 X0 Y0"
    assert "estimated" in capsys.readouterr().out


def test_gcode_reads_vpypes_svg(tmp_path):
    """vpype writes its layers as Inkscape groups, in CSS pixels (96 per inch) under a
    millimetre-sized page: 377.953 px is 100 mm; SVG's y points down, the page's up."""
    svg = tmp_path / "vpype.svg"
    svg.write_text(
        '<?xml version="1.0" encoding="utf-8" ?>\n<svg xmlns="http://www.w3.org/2000/svg" '
        'xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape" height="297.0mm" '
        'version="1.1" viewBox="0 0 1122.5197 1122.5197" width="297.0mm"><defs />'
        '<g id="layer1" inkscape:groupmode="layer" inkscape:label="1" style="fill:none;'
        'stroke:#0000ff;stroke-width:1"><path d="M377.953,377.953 L755.906,377.953 '
        'L755.906,755.906" /></g></svg>')
    out = tmp_path / "vpype.gcode"
    assert main(["gcode", str(svg), "--out", str(out), "--profile", "z"]) == 0
    text = out.read_text()
    assert "G1 Z0 F1200" in text
    assert "G0 X100.000 Y197.000" in text and "G1 X200.000 Y97.000" in text


@pytest.mark.parametrize("argv, message", [
    (["--out", "x.txt"], "expected a G-code file name (.gcode or .nc or .ngc)"),
    (["--out", "{tmp}"], "is a folder: expected a G-code file name"),
    (["--out", "/no/such/dir/a.gcode"], "/no/such/dir is not a writable folder"),
    (["--out", "{tmp}/a.gcode", "--profile", "sevro"], "did you mean 'servo'"),
    (["--out", "{tmp}/a.gcode", "--speed", "-3"], "--speed"),
])
def test_gcode_errors(tmp_path, capsys, argv, message):
    argv = [a.format(tmp=tmp_path) for a in argv]
    assert main(["gcode", "inkarm/data/default.toml", *argv]) == 2
    assert message in capsys.readouterr().err


def test_profile_file_errors_name_the_key(tmp_path, capsys):
    bad = tmp_path / "pen.toml"
    bad.write_text('pen_dwn = ["M3"]\n')
    assert main(["gcode", "inkarm/data/default.toml", "--out", str(tmp_path / "a.gcode"),
                 "--profile", str(bad)]) == 2
    assert "pen_dwn: unknown key (did you mean 'pen_down'?)" in capsys.readouterr().err


def test_backends_are_registered():
    assert backend_names()[:2] == ("sim", "plotter")


@pytest.mark.hardware_emulated
def test_draw_on_the_emulated_plotter_writes_the_run(tmp_path, capsys):
    with GrblEmulator(EmulatorConfig(speedup=4)) as emu:
        status = main(["draw", "--backend", "plotter", "--port", emu.port, "--time-scale", "4",
                       "--quiet", "--out", str(tmp_path / "run")])
    assert status == 0, capsys.readouterr().err
    written = json.loads((tmp_path / "run" / "status.json").read_text())
    # (degraded only by its tracking error when a loaded machine keeps the emulator waiting)
    assert written["status"] == "ok" or all(
        r.startswith(("tracking RMS", "tracking max")) for r in written["reason"].split("; "))
    assert (tmp_path / "run" / "metrics.json").is_file()
    assert "tracking RMS" in capsys.readouterr().out


@pytest.mark.parametrize("argv, message", [
    (["--backend", "plotter"], "the plotter backend needs a serial port"),
    (["--backend", "plottr", "--port", "/dev/null"], "did you mean 'plotter'"),
])
def test_draw_backend_errors(tmp_path, capsys, argv, message):
    assert main(["draw", *argv, "--quiet", "--out", str(tmp_path / "o")]) == 2
    assert message in capsys.readouterr().err


def test_emulate_needs_a_device(capsys):
    assert main(["emulate"]) == 2
    assert "which device? expected one of grbl" in capsys.readouterr().err


@pytest.mark.hardware_emulated
def test_emulate_grbl_prints_its_port_and_writes_its_canvas_on_ctrl_c(tmp_path):
    out = tmp_path / "canvas.png"
    proc = subprocess.Popen([sys.executable, "-m", "inkarm.cli", "emulate", "grbl", "--speedup",
                             "10", "--out", str(out)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        proc.stdout.readline()
        port = proc.stdout.readline().strip()
        s = GrblStreamer(port, time_scale=10)
        s.wake()
        s.stream(["G21 G90 F3000", "G0 X20 Y20", "M3 S1000", "G4 P0.2", "G1 X60 Y20", "M5"])
        s.wait_idle(10)
        s.close()
    finally:
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=10)
    assert proc.returncode == 0, err
    assert out.is_file() and "received 6 lines, 0 bytes lost" in err


def test_draw_check_on_the_plotter_sends_nothing(tmp_path, capsys):
    from inkarm.hardware.plotter.gcode import drawing_to_gcode
    from inkarm.jobs.backends.plotter import prepared, run_lines
    from inkarm.jobs.scenario import load_scenario

    assert main(["draw", "--backend", "plotter", "--check", "--out", str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert "G-code lines (one per 10 ms of the pen path) for pen profile 'servo'" in out
    assert "nothing sent" in out
    # the count is what a run streams (issue 21: it was the `inkarm gcode` file's)
    scenario = load_scenario(None)
    pen, _, drawing = prepared(scenario, None)
    sent, written = run_lines(scenario, pen, drawing), drawing_to_gcode(drawing, pen).lines
    assert f"a run streams {len(sent)} G-code lines" in out and len(sent) != len(written)
    scenario = tmp_path / "off.toml"
    scenario.write_text('[source]\nkind = "text"\ntext = "hi"\n[placement]\n'
                        'centre_mm = [5.0, 5.0]\nheight_mm = 40.0\n')
    assert main(["draw", str(scenario), "--backend", "plotter", "--check", "--out",
                 str(tmp_path / "o")]) == 2
    assert "beyond the 210 x 297 mm sheet" in capsys.readouterr().err


def test_gcode_refuses_a_scenario_drawn_off_its_sheet(tmp_path, capsys):
    scenario = tmp_path / "off.toml"
    text = Path("inkarm/data/default.toml").read_text()
    scenario.write_text(text.replace("centre_mm = [105.0, 148.5]", "centre_mm = [195.0, 148.5]"))
    out = tmp_path / "off.gcode"
    assert main(["gcode", str(scenario), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "off.toml" in err and "placement" in err and "beyond the 210 x 297 mm sheet" in err
    assert not out.exists()


@pytest.mark.hardware_emulated
def test_draw_on_a_homed_plotter_with_soft_limits():
    """GRBL as a real plotter is set up: homing and soft limits on ($22=1, $20=1), the machine
    space [-$13x, 0]: the plant homes, puts the page origin in G54 and draws in work
    coordinates; the pen state comes from the oks (the emulator writes A: only with Ov:)."""
    from inkarm.jobs.backends.plotter import page_size_mm, run_plotter_scenario
    from inkarm.jobs.scenario import load_scenario

    scenario = load_scenario("inkarm/data/default.toml")
    canvas = scenario.ink.canvas(page_size_mm(scenario))
    config = EmulatorConfig(speedup=4, settings=((22, 1.0), (20, 1.0)))
    with GrblEmulator(config, canvas=canvas) as emu:
        run = run_plotter_scenario(scenario, emu.port, time_scale=4, canvas=canvas)
        travel = emu.machine.settings[130], emu.machine.settings[131]
        position = np.asarray(emu.machine.position[:2])
    assert run.status == "ok" or all(r.startswith(("tracking RMS", "tracking max"))
                                     for r in run.reason.split("; ")), run.reason
    assert run.metrics.gap_mm == 0.0 and run.metrics.ink_chamfer_mm <= 0.2
    assert np.all(position <= 0.0) and np.all(position >= -np.asarray(travel))
    assert f"page origin at machine ({-travel[0]:g}, {-travel[1]:g}) mm (G54), homed ($22=1)" \
        in " ".join(run.notes)


@pytest.mark.hardware_emulated
def test_check_mode_on_the_device_moves_nothing():
    from inkarm.jobs.backends import BackendOptions, check_backend
    from inkarm.jobs.scenario import load_scenario

    config = EmulatorConfig(speedup=10, settings=((22, 1.0), (20, 1.0)))
    with GrblEmulator(config) as emu:
        summary = check_backend("plotter", load_scenario("inkarm/data/default.toml"),
                                BackendOptions(port=emu.port, time_scale=10))
        position = np.asarray(emu.machine.position[:2])
    assert "accepted by the device in check mode ($C)" in summary and "nothing moved" in summary
    assert position == pytest.approx([0.0, 0.0])  # never homed, never moved
