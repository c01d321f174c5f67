"""The plotter executor's commands from the shared pen sequencing, GrblPlant's protocol, the
side-by-side figure."""

import numpy as np
import pytest

from inkarm.control.config import LoopConfig
from inkarm.control.plotter import plotter_commands
from inkarm.control.sequencing import sequence_pen
from inkarm.core.log import APPROACH, DESCEND, DRAW, LIFT, TRAVEL
from inkarm.core.plant import PenCommand, Plant, PositionCommand, TorqueCommand
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError
from inkarm.hardware.plotter.emulator import EmulatorConfig, GrblEmulator
from inkarm.hardware.plotter.plant import GrblPlant
from inkarm.hardware.plotter.profiles import load_profile
from inkarm.hardware.plotter.stream import GrblStreamer
from inkarm.ink.canvas import Canvas
from inkarm.plots.backends import BackendPanel, backends_figure


def two_strokes() -> Drawing:
    t = np.linspace(0, 0.5, 51)
    a = Trajectory(t=t, pos=np.column_stack([10 + 40 * t, 20 + 0 * t]))
    b = Trajectory(t=t, pos=np.column_stack([60 + 0 * t, 20 + 40 * t]))
    return Drawing([a, b], page_size=(210, 297))


def test_commands_follow_the_pen_phases():
    config = LoopConfig()
    path = sequence_pen(two_strokes(), config, 0.0, 0.01)
    commands, rows, phases = plotter_commands(path, 0.01)
    kinds = [(type(c).__name__, p) for c, p in zip(commands, phases, strict=True)]
    assert kinds[0] == ("PositionCommand", APPROACH) and commands[0].qd is None
    assert kinds[1] == ("PenCommand", DESCEND) and commands[1].down
    lifts = [i for i, (_, p) in enumerate(kinds) if p == LIFT]
    travels = [i for i, (_, p) in enumerate(kinds) if p == TRAVEL]
    assert len(lifts) == 2 and len(travels) == 1  # one rapid between the strokes
    assert commands[travels[0]].qd is None
    assert commands[travels[0]].q == pytest.approx([0.060, 0.020])  # [m]
    draws = [c for c, p in zip(commands, phases, strict=True) if p == DRAW]
    assert all(isinstance(c, PositionCommand) and c.qd is not None for c in draws)
    speeds = np.array([np.linalg.norm(c.qd) * 1000 for c in draws])
    assert np.median(speeds) == pytest.approx(40.0, rel=0.01)  # 20 mm in 0.5 s
    assert rows == sorted(rows)
    assert isinstance(commands[lifts[-1]], PenCommand) and not commands[lifts[-1]].down


@pytest.mark.hardware_emulated
def test_grbl_plant_is_a_plant_and_refuses_torques():
    with GrblEmulator(EmulatorConfig(speedup=10)) as emu:
        streamer = GrblStreamer(emu.port, time_scale=10)
        streamer.wake()
        plant = GrblPlant(streamer, load_profile("servo"), time_scale=10)
        assert isinstance(plant, Plant)
        assert plant.commands == {"position", "pen"} and plant.senses == {"tip"}
        assert plant.settings[120] == 1500.0
        with pytest.raises(InputError, match="GrblPlant does not take torque commands"):
            plant.command(TorqueCommand(np.zeros(2)))
        plant.command(PositionCommand(q=np.array([0.01, 0.02])))
        plant.step()
        assert plant.finish()
        assert plant.read().q == pytest.approx([0.01, 0.02])
        plant.close()
        plant.close()  # idempotent
    with pytest.raises(InputError, match="expected a period"):
        GrblPlant.__new__(GrblPlant).__init__(None, load_profile("servo"), dt=1e-4)


def test_side_by_side_figure():
    canvas = Canvas((50, 50), 5)
    canvas.touch((10, 10), 1.0, 0.0)
    canvas.touch((40, 10), 1.0, 1.0)
    canvas.lift()
    plan = [np.array([[10.0, 10.0], [40.0, 10.0]])]
    metrics = {"ink_chamfer_mm": 0.1, "tracking_rms_mm": 0.2, "gap_mm": 0.0}
    fig = backends_figure([("line", [BackendPanel("arm", canvas, plan, metrics),
                                     BackendPanel("plotter", canvas, plan, {}, "failed")])])
    titles = [ax.get_title() for ax in fig.axes]
    assert "ink chamfer 0.100 mm" in titles[0] and titles[1] == "line: plotter: failed"
    with pytest.raises(InputError, match="at least one job"):
        backends_figure([])


def test_the_schedule_starts_where_the_machine_stands_and_follows_the_pen_oks():
    """The planner model starts at the machine's work position (after homing, not the page
    origin), and its clock is anchored at every line GRBL answers only when done (M3/M5, G4):
    a device whose clock ran 10 % slow over a stroke gets the stroke stretched between the
    pen-down dwell's ok and the pen-up line's, not shifted at the dwell alone."""
    from types import SimpleNamespace

    from inkarm.hardware.plotter.plant import _synchronous
    from inkarm.hardware.plotter.timing import simulate

    plant = GrblPlant.__new__(GrblPlant)
    plant.lines = ["G21", "G90", "M5", "G0 X10 Y10", "M3 S1000", "G4 P0.150",
                   "G1 X60 Y10 F600", "M5", "G4 P0.150"]
    plant.command_line = list(range(len(plant.lines)))
    plant.settings, plant.time_scale, plant._t0 = {110: 500.0, 111: 500.0}, 1.0, 100.0
    plant._start_mm = (199.0, 199.0, 0.0)
    model = simulate(["G21 G90 G0 X199 Y199"] + plant.lines, plant.settings)
    ends = model.line_end_s[1:] - model.line_end_s[0]
    stroke = ends[6] - ends[5]
    assert ends[3] > 10.0 and 5.0 < stroke < 7.0  # 50 mm at 10 mm/s, and the ramps
    slow = {i + 1: 100.0 + e + (1.1 - 1) * max(0.0, e - ends[5]) for i, e in enumerate(ends)}
    plant.profile = load_profile("servo")
    plant.streamer = SimpleNamespace(state=SimpleNamespace(ack_times=slow, send_times={}))
    line_end, plan = plant.schedule()
    assert line_end[7] - line_end[5] == pytest.approx(1.1 * (ends[7] - ends[5]), rel=1e-6)
    middle = line_end[5] + 0.55 * stroke  # half-way through the stretched stroke
    assert np.interp(middle, plan.samples[:, 0], plan.samples[:, 1]) == pytest.approx(35.0,
                                                                                    abs=0.3)
    assert [_synchronous(x) for x in ("M3 S1000", "G4 P0.1", "G1 X1 M5", "G0 X1", "G21")] == \
        [True, True, False, False, False]


def test_planner_anchors_pair_each_waiting_ok_with_the_block_15_before():
    """GRBL answers a motion line once a planner block is free: with 15 blocks, the ok of
    the 16th block since the last pen change marks the end of the 1st. Lines of less than a
    step make no block; an ok that did not wait says nothing; a pen change drains the
    planner and starts the count again."""
    from types import SimpleNamespace

    from inkarm.hardware.plotter.plant import PLANNER_BLOCKS, planner_anchors

    lines = ["M3 S1000", "G4 P0.1"] + [f"G1 X{k:.3f} Y0 F600" for k in range(1, 21)]
    lines.insert(5, "G1 X3.001 Y0")  # 0.25 steps at 250 steps/mm: no block
    lines += ["M5"] + [f"G1 X{k:.3f} Y1" for k in range(30, 50)]
    n = len(lines)
    state = SimpleNamespace(send_times={i: 0.0 for i in range(1, n + 1)},
                            ack_times={i: 1.0 for i in range(1, n + 1)})
    state.ack_times[n] = 0.001  # answered at once: the planner was not full
    pairs = planner_anchors(lines, {100: 250.0, 101: 250.0}, state, 1.0)
    first_block = lines.index("G1 X1.000 Y0 F600")
    assert pairs[0] == (first_block, lines.index("G1 X16.000 Y0 F600") + 1)
    assert len(pairs) == (20 - PLANNER_BLOCKS) + (20 - PLANNER_BLOCKS - 1)
    assert all(lines[i].startswith("G1") for i, _ in pairs)
    m5 = lines.index("M5")
    assert next(p for p in pairs if p[1] > m5) == (m5 + 1, m5 + 17)
