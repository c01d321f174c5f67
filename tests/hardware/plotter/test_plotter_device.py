"""The plotter backend on the emulator as stock GRBL with homing and soft limits on: the
issue-20 Done-when run, the device check (``$C``), one driver per port, Ctrl-C."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

from inkarm.cli import main
from inkarm.hardware.plotter.emulator import EmulatorConfig, GrblEmulator
from inkarm.hardware.plotter.stream import GrblStreamer
from inkarm.jobs.backends.plotter import (
    page_size_mm,
    prepared,
    run_lines,
    run_plotter_scenario,
)
from inkarm.jobs.outcome import RunInterrupted
from inkarm.jobs.scenario import load_scenario

HOMED = {22: 1, 20: 1}  # homing and soft limits on, as a real plotter is set up
QUICK = "scenarios/quick_stroke.toml"


@pytest.mark.hardware_emulated
@pytest.mark.slow
def test_a_plotter_run_with_homing_and_soft_limits_is_ok_with_no_gaps():
    """Issue 20, Done when: ok, 0 gaps, chamfer <= 0.2 mm, tracking within the scenario's
    bound, on the emulator answering as stock GRBL 1.1h (reports without A: in most of them)
    set up with $22=1 and $20=1; the run streams what ``draw --check`` announces."""
    scenario = load_scenario(QUICK)
    canvas = scenario.ink.canvas(page_size_mm(scenario))
    with GrblEmulator(EmulatorConfig(settings=HOMED), canvas=canvas) as emu:
        run = run_plotter_scenario(scenario, emu.port, canvas=canvas)
        received = emu.stats.lines
    m = run.metrics
    assert run.status == "ok", (run.reason, dict(m))
    assert m["gap_mm"] == 0.0
    assert m["ink_chamfer_mm"] <= 0.2
    assert m["tracking_rms_mm"] <= scenario.judge.tracking_rms_mm
    assert any("homed ($22=1)" in note for note in run.notes)
    pen, _, drawing = prepared(scenario, None)
    sent = len(run_lines(scenario, pen, drawing))
    assert any(f"plotter: {sent} G-code lines" in note for note in run.notes)
    assert received >= sent


@pytest.mark.hardware_emulated
def test_draw_check_with_a_port_runs_the_job_in_grbl_check_mode(tmp_path, capsys):
    scenario = load_scenario(QUICK)
    pen, _, drawing = prepared(scenario, None)
    sent = len(run_lines(scenario, pen, drawing))
    with GrblEmulator(EmulatorConfig(speedup=5, settings=HOMED)) as emu:
        assert main(["draw", QUICK, "--check", "--backend", "plotter", "--port", emu.port,
                     "--time-scale", "5", "--out", str(tmp_path / "o")]) == 0
        out = capsys.readouterr().out
        assert f"the {sent} G-code lines a run streams" in out and "check mode ($C)" in out
        assert emu.stats.lines >= sent + 3  # $$, G10 L2, G54, $#, $C, the job, $C
        assert np.allclose(emu.machine.position[:2], 0.0)  # nothing moved: never homed
    assert main(["draw", QUICK, "--check", "--backend", "plotter", "--out",
                 str(tmp_path / "o")]) == 0  # without a port: offline
    assert "nothing sent" in capsys.readouterr().out


@pytest.mark.hardware_emulated
def test_a_second_driver_on_the_port_is_refused_at_once_naming_the_holder(tmp_path, capsys):
    import os

    with GrblEmulator(EmulatorConfig(speedup=5)) as emu:
        first = GrblStreamer(emu.port, time_scale=5)
        try:
            start = time.monotonic()
            assert main(["draw", QUICK, "--backend", "plotter", "--port", emu.port,
                         "--time-scale", "5", "--quiet", "--out", str(tmp_path / "o")]) == 2
            assert time.monotonic() - start < 5.0
            err = capsys.readouterr().err
            assert "--port" in err and emu.port in err and f"process {os.getpid()}" in err
            assert "one driver per port" in err
        finally:
            first.close()
        second = GrblStreamer(emu.port, time_scale=5)  # released on close
        second.close()


@pytest.mark.hardware_emulated
def test_ctrl_c_keeps_the_partial_trace_with_status_interrupted(tmp_path):
    from inkarm.jobs.outputs import write_run

    scenario = load_scenario(QUICK)
    calls = []

    def progress(fraction, stage):
        calls.append(stage)
        if stage == "plot" and fraction > 0.6:
            raise KeyboardInterrupt

    with GrblEmulator(EmulatorConfig(speedup=2)) as emu, \
            pytest.raises(RunInterrupted) as caught:
        run_plotter_scenario(scenario, emu.port, time_scale=2, progress=progress)
    run = caught.value.run
    assert run.status == "interrupted" and run.log is not None and len(run.log) > 0
    files = write_run(run, tmp_path / "out")
    trace = np.load(files["trace.npz"])
    assert len(trace["time"]) == len(run.log)
    status = json.loads(files["status.json"].read_text())
    assert status["status"] == "interrupted" and "Ctrl-C" in status["reason"]
