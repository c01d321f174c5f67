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
