"""GrblPlant's pen state through a hold with the pen lifted, and the device-clock warp of its
schedule (the plotter's reference)."""

import time

import numpy as np
import pytest

from inkarm.core.plant import PenCommand, PositionCommand
from inkarm.hardware.plotter.emulator import EmulatorConfig, GrblEmulator
from inkarm.hardware.plotter.plant import PREP_LEAD_S, GrblPlant, warp_offsets
from inkarm.hardware.plotter.profiles import load_profile
from inkarm.hardware.plotter.stream import GrblStreamer


def _pump_until(plant: GrblPlant, done, timeout_s: float = 10.0) -> None:
    end = time.monotonic() + timeout_s
    while not done() and time.monotonic() < end:
        plant.step()
    assert done(), "timed out"


@pytest.mark.hardware_emulated
def test_a_hold_with_the_pen_lifted_reads_pen_up_until_the_resume():
    with GrblEmulator(EmulatorConfig(speedup=4)) as emu:
        streamer = GrblStreamer(emu.port, time_scale=4)
        streamer.wake()
        plant = GrblPlant(streamer, load_profile("servo"), time_scale=4)
        try:
            plant.command(PositionCommand(q=np.array([0.01, 0.01])))
            plant.command(PenCommand(down=True))
            plant.command(PositionCommand(q=np.array([0.15, 0.01]), qd=np.array([0.02, 0.0])))
            pen_acked = plant.pen_marks[0][0]
            _pump_until(plant, lambda: streamer.state.acked >= pen_acked
                        and streamer.last_status is not None
                        and streamer.last_status.acked >= pen_acked)
            assert plant.read().force > 0  # drawing: pen down
            held = plant.pause(lift=True)
            assert held is not None and held.state == "Hold:0"
            for _ in range(3):
                s = streamer.status()
                assert s.state.startswith("Hold")
                state = plant.read()
                assert state.force == 0.0 and np.isnan(state.tip_mm[2]), s
            plant.resume()
            time.sleep(0.1)
            _pump_until(plant, lambda: streamer.status().state == "Run")
            assert plant.read().force > 0  # back down after the resume
            in_hold = [r for r in plant.readings() if r.force == 0.0 and r.time > 0.3]
            assert in_hold, "the hold's readings say pen up"
        finally:
            plant.close()


def test_warp_offsets_take_the_least_later_bound_within_a_stroke():
    # a stroke between exact anchors at model 1.0 (10 ms late) and 2.0 (30 ms late); planner
    # bounds overstate the lateness by 0..10 ms (the 10 ms segment phase) and by latency
    exact = [(0.0, 0.0), (1.0, 1.010), (2.0, 2.030)]
    true = 0.020
    rng = np.random.default_rng(0)
    ms = np.arange(1.2, 1.9, 0.01)
    bounds = [(m, m + true + rng.uniform(0.0, 0.010)) for m in ms]
    model, offset = warp_offsets(exact, bounds)
    assert np.all(np.diff(model) > 0)
    inside = (model > 1.0) & (model < 2.0)
    assert np.all(offset[inside] >= true - 1e-12)
    assert np.max(offset[inside]) < true + 0.003  # the least later bound is tight
    assert np.all(np.diff(offset[inside]) >= -1e-12)  # never ahead again within a stroke
    # before its first bound the stroke is as late as that bound says, not the pen change
    assert np.interp(1.1, model, offset) == pytest.approx(offset[inside][0])
    # exact anchors stand
    for m, d in exact:
        assert np.interp(m, model, offset) == pytest.approx(d - m)
    # face value of the bounds (the old warp) would have swung the speed by the phase noise
    assert PREP_LEAD_S == pytest.approx(0.05)  # the executing segment and 4 prepared, 10 ms


def test_warp_offsets_without_planner_bounds_are_the_exact_anchors():
    model, offset = warp_offsets([(0.0, 0.001), (0.5, 0.52)], [])
    assert model.tolist() == [0.0, 0.5]
    assert offset == pytest.approx([0.001, 0.02])
