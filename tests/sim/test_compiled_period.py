"""The compiled control period (inkarm/sim/_period.c via inkarm.sim.compiled) against the plant's
Python period: the same bits in the logs and on the canvas, the same faults, and the Python
period whenever the extension cannot be used."""

from __future__ import annotations

import logging
import os
import sys

import mujoco
import numpy as np
import pytest

import inkarm.sim
import inkarm.sim.plant as sim_plant
from inkarm.core.plant import PositionCommand
from inkarm.errors import SimulationError
from inkarm.ink.canvas import Canvas
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario, parse_scenario
from inkarm.sim import compiled
from inkarm.sim.cell import build_model

pytestmark = pytest.mark.sim

LOGGED = ("time", "q", "qd", "torque", "tip", "force", "reference", "phase", "stroke")
LINE = {"source": {"kind": "plan", "plan": {"strokes": [{"targets": [
    {"mean": [0.0, 0.0], "cov": 1.0}, {"mean": [20.0, 5.0], "cov": 1.0}]}]}},
    "ink": {"px_per_mm": 4.0}}


@pytest.fixture
def built():
    """The extension, or a skip that says why it is not usable here."""
    compiled._load.cache_clear()
    if compiled.period_module() is None:
        pytest.skip(f"the compiled period is not usable here: {compiled._unusable()}")


def _run_both(scenario, monkeypatch):
    """``scenario`` run with the Python period then the compiled one: per run, the Run, the
    canvas's calls and the periods the plants were given."""
    calls: list = []
    touch, lift = Canvas.touch, Canvas.lift
    monkeypatch.setattr(Canvas, "touch", lambda c, p, f, t: (calls.append((tuple(p), f, t)),
                                                            touch(c, p, f, t)))
    monkeypatch.setattr(Canvas, "lift", lambda c: (calls.append("lift"), lift(c)))
    periods: list = []
    period_for = sim_plant.period_for
    monkeypatch.setattr(sim_plant, "period_for", lambda p: periods.append(period_for(p)) or
                        periods[-1])
    out = []
    for switch in ("0", "1"):
        monkeypatch.setenv(compiled.SWITCH, switch)
        calls.clear(), periods.clear()
        out.append((run(scenario), list(calls), list(periods)))
    return out


def _assert_same(python, native, touches: int = 0):
    (a, a_calls, a_periods), (b, b_calls, b_periods) = python, native
    assert a_periods == [None] and b_periods[0] is not None  # (each path taken)
    assert (a.status, a.reason) == (b.status, b.reason)
    for key in LOGGED:
        x, y = getattr(a.log, key), getattr(b.log, key)
        assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), key
    assert a.canvas.image.tobytes() == b.canvas.image.tobytes()
    assert a_calls == b_calls and len(a_calls) >= touches


def test_the_default_drawing_is_bit_identical_with_the_compiled_period(built, monkeypatch):
    _assert_same(*_run_both(load_scenario(), monkeypatch), touches=1000)


def test_a_failed_run_fails_the_same_way_with_the_compiled_period(built, monkeypatch, tmp_path):
    scenario = parse_scenario(LINE, "job.toml", tmp_path).with_overrides(
        {"robot.gains.kp": 1e7, "robot.gains.kd": 0.0})
    python, native = _run_both(scenario, monkeypatch)
    assert python[0].status == "failed"
    _assert_same(python, native)


@pytest.mark.parametrize("push, message", [
    (500.0, r"joint[0-9] moves at [0-9.]+ rad/s, above the 20.0"),
    (np.nan, r"non-finite or huge joint state \(MuJoCo warned .*mjWARN_BADQVEL"),
])
def test_divergence_is_found_after_a_compiled_period(built, monkeypatch, tmp_path, push, message):
    monkeypatch.chdir(tmp_path)  # (MuJoCo may append its warnings to ./MUJOCO_LOG.TXT)
    errors, states = [], []
    for switch in ("0", "1"):
        monkeypatch.setenv(compiled.SWITCH, switch)
        plant = sim_plant.MujocoPlant(build_model(), max_joint_speed=20.0)
        assert (plant._period is None) == (switch == "0")
        plant.command(PositionCommand(plant.read().q))
        plant.step()
        plant.data.qvel[3] = push
        plant.command(PositionCommand(plant.read().q))
        with pytest.raises(SimulationError, match=message) as error:
            plant.step()
        errors.append(str(error.value))
        states.append(np.concatenate([plant.data.qpos, plant.data.qvel, [plant.data.time]]))
    assert errors[0] == errors[1] and states[0].tobytes() == states[1].tobytes()


def test_a_fatal_mujoco_error_in_a_compiled_period_raises_as_in_python(built):
    """MuJoCo's mju_error inside the C period (here: its arena overflows) is the bindings'
    FatalError, as from mj_step in Python, and leaves MuJoCo's own error handler in place."""
    boxes = "".join(f'<body pos="{0.01 * i} 0 0.05"><freejoint/><geom type="box" '
                    'size=".1 .1 .1"/></body>' for i in range(8))
    m = mujoco.MjModel.from_xml_string(
        '<mujoco><size memory="6K"/><worldbody><geom type="plane" size="1 1 .1"/><body>'
        '<joint name="j"/><geom type="capsule" size=".01 .1" pos="0 0 .5"/><site name="s"/>'
        f'</body>{boxes}</worldbody><actuator><motor joint="j"/></actuator></mujoco>')
    d = mujoco.MjData(m)
    period = compiled.period_module().Period((m, d), m._address, d._address, [0], 0, -1,
                                             [1.0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0], 3, 1e9, 0)
    with pytest.raises(mujoco.FatalError, match="mj_stackAlloc: out of memory"):
        period.step(np.zeros(1), np.zeros(1), 0.0)
    with pytest.raises(mujoco.FatalError, match="mj_stackAlloc: out of memory"):
        mujoco.mj_step(m, mujoco.MjData(m))


def test_without_the_extension_the_plant_runs_its_python_period(monkeypatch, caplog):
    monkeypatch.delattr(inkarm.sim, "_period", raising=False)
    monkeypatch.setitem(sys.modules, "inkarm.sim._period", None)  # (its import fails)
    compiled._load.cache_clear()
    try:
        with caplog.at_level(logging.DEBUG, logger="inkarm.sim.compiled"):
            plant = sim_plant.MujocoPlant(build_model())
            assert compiled.period_module() is None  # (a second look: no second notice)
    finally:
        compiled._load.cache_clear()
    notices = [r.getMessage() for r in caplog.records if r.name == "inkarm.sim.compiled"]
    assert len(notices) == 1 and "the extension is not built" in notices[0]
    assert plant._period is None
    for _ in range(3):
        plant.command(PositionCommand(plant.read().q))
        plant.step()
    assert plant.read().time == pytest.approx(3 * plant.dt)


def test_an_extension_built_for_another_mujoco_is_not_used(built, monkeypatch, caplog):
    monkeypatch.setattr(mujoco, "__version__", "0.0.1")
    compiled._load.cache_clear()
    try:
        with caplog.at_level(logging.DEBUG, logger="inkarm.sim.compiled"):
            assert compiled.period_module() is None
    finally:
        compiled._load.cache_clear()
    from inkarm.sim import _period

    assert f"built for MuJoCo {_period.MUJOCO_VERSION}, this is 0.0.1" in caplog.text


def test_the_switch_and_a_library_not_loaded_leave_the_python_period(built, monkeypatch):
    monkeypatch.setenv(compiled.SWITCH, "0")
    assert compiled.period_module() is None
    assert sim_plant.MujocoPlant(build_model())._period is None
    from inkarm.sim import _period

    with pytest.raises(ImportError, match="libnothing.so is not loaded"):
        _period.bind(os.path.join(os.sep, "nowhere", "libnothing.so"), mujoco.FatalError)
