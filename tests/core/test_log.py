"""DrawLog to and from .npz: a real run comes back bit for bit, notes included; a file that is
not a log is refused naming it."""

import numpy as np
import pytest

from inkarm.control.config import LoopConfig
from inkarm.control.executor import run_drawing
from inkarm.control.reference import plan_within_speed_limits
from inkarm.control.sequencing import minimum_jerk
from inkarm.core.log import APPROACH, DRAW, HOME, PHASES, DrawLog
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError
from inkarm.robots.registry import load_robot
from inkarm.sim.cell import build_model, kinematic_model, make_cell
from inkarm.sim.plant import MujocoPlant

FIELDS = ("time", "q", "qd", "torque", "tip", "force", "reference", "phase", "stroke")


@pytest.fixture(scope="module")
def run_log() -> DrawLog:
    """A short bar drawn on the simulated iiwa14 cell, slowed to speed limits below the
    stroke's so that the log carries a note."""
    robot = load_robot("iiwa14")
    cell = make_cell(robot=robot)
    km = kinematic_model(cell)
    t = np.arange(0.0, 0.3 + 1e-9, 0.01)
    s = minimum_jerk(len(t))[:, None]
    bar = Trajectory(t, np.array([90.0, 130.0]) + s * np.array([40.0, 0.0]))
    drawing, config = Drawing([bar]), LoopConfig(go_home=False)
    plant = MujocoPlant(build_model(cell))
    # limits below the bar's joint speeds, above those of the descent and lift (which slowing
    # the drawing leaves as they are)
    ref, _ = plan_within_speed_limits(drawing, km, config, plant.read().q, plant.dt)
    speed = np.abs(ref.qd)
    limits = np.maximum(0.7 * speed[ref.phase == DRAW].max(axis=0),
                        1.1 * speed[~np.isin(ref.phase, [DRAW, APPROACH, HOME])].max(axis=0))
    limits = np.maximum(limits, 0.01)  # a joint the bar hardly moves keeps a limit
    return run_drawing(drawing, plant, km, robot.gains, config, speed_limits=limits)


@pytest.mark.sim
def test_a_real_run_round_trips_bit_for_bit(run_log, tmp_path):
    log = run_log
    assert len(log) > 50 and np.any(log.phase == DRAW)
    assert log.notes and log.notes[0].startswith("slowed ")
    path = tmp_path / "run.npz"
    log.to_npz(path)
    back = DrawLog.from_npz(path)
    assert back == log
    for name in FIELDS:
        a, b = getattr(log, name), getattr(back, name)
        assert a.dtype == b.dtype and a.shape == b.shape, name
        assert a.tobytes() == b.tobytes(), name  # bit-equal, NaNs and signed zeros included
    assert back.wall_s == log.wall_s and back.wall_s > 0
    assert back.notes == log.notes and isinstance(back.notes, tuple)
    with np.load(path) as saved:
        assert list(saved["phases"]) == list(PHASES)


@pytest.mark.sim
def test_equality_sees_every_column_and_the_notes(run_log):
    log = run_log
    assert log == log.truncated(len(log))
    assert log != log.truncated(len(log) - 1)
    other = log.truncated(len(log))
    other.notes = ()
    assert other != log
    changed = log.truncated(len(log))
    changed.force = changed.force.copy()
    changed.force[3] += 1e-12
    assert changed != log
    assert DrawLog.__hash__ is None
    assert (log == "a log") is False


def test_logs_without_notes_round_trip(tmp_path):
    log = DrawLog.empty(4, 2)
    log.wall_s = 1.5
    log.to_npz(tmp_path / "plain.npz")
    back = DrawLog.from_npz(tmp_path / "plain.npz")
    assert back == log and back.notes == () and back.wall_s == 1.5


def test_logs_with_nan_columns_round_trip(tmp_path):
    log = DrawLog.empty(5, 3)
    log.force[:] = np.nan
    log.to_npz(tmp_path / "empty.npz")
    back = DrawLog.from_npz(tmp_path / "empty.npz")
    assert back == log and back.notes == ()


def test_an_npz_that_is_not_a_log_is_refused_naming_the_file(tmp_path):
    path = tmp_path / "weights.npz"
    np.savez(path, a=np.arange(3))
    with pytest.raises(InputError, match="not a DrawLog: missing time, q") as info:
        DrawLog.from_npz(path)
    assert info.value.file == str(path)
    assert str(info.value).startswith(f"{path}: ")


def test_a_file_that_is_not_an_npz_is_refused_naming_it(tmp_path):
    path = tmp_path / "log.npz"
    path.write_text("not a zip")
    with pytest.raises(InputError, match="not a DrawLog") as info:
        DrawLog.from_npz(path)
    assert info.value.file == str(path)
    missing = tmp_path / "absent.npz"
    with pytest.raises(InputError) as info:
        DrawLog.from_npz(missing)
    assert info.value.file == str(missing)


def test_other_phase_names_are_refused(tmp_path):
    log = DrawLog.empty(3, 2)
    path = tmp_path / "old.npz"
    columns = {name: getattr(log, name) for name in FIELDS}
    np.savez(path, **columns, wall_s=0.0, phases=np.array(["approach", "draw"]))
    with pytest.raises(InputError, match="phase names") as info:
        DrawLog.from_npz(path)
    assert info.value.file == str(path)
