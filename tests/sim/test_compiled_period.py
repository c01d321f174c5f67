"""The compiled control period (inkarm/sim/_period.c via inkarm.sim.compiled) against the plant's
Python period: the same bits in the logs and on the canvas and in each new set point of the
drives, the same faults, and the Python period whenever the extension cannot be used."""

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
from inkarm.robots.gains import PIDGains
from inkarm.sim import compiled
from inkarm.sim.cell import build_model
from inkarm.sim.drive import JointDrive
from tests.compiled import assert_same_log, compiled_or_skip

pytestmark = pytest.mark.sim

LINE = {"source": {"kind": "plan", "plan": {"strokes": [{"targets": [
    {"mean": [0.0, 0.0], "cov": 1.0}, {"mean": [20.0, 5.0], "cov": 1.0}]}]}},
    "ink": {"px_per_mm": 4.0}}


@pytest.fixture
def built():
    """The extension, or a skip that says why it is not usable here (a failure with
    INKARM_REQUIRE_COMPILED=1)."""
    compiled._load.cache_clear()
    return compiled_or_skip(compiled.period_module(), "the compiled period",
                            str(compiled._unusable() or "logged at debug level"))


def _run_both(scenario, monkeypatch):
    """``scenario`` run with the Python period then the compiled one: per run, the Run, the
    canvas's calls and the periods the plants were given."""
    calls: list = []
    touch, lift = Canvas.touch, Canvas.lift
    monkeypatch.setattr(Canvas, "touch", lambda c, p, f, t: (calls.append((tuple(p), f, t)),
                                                            touch(c, p, f, t)))
    monkeypatch.setattr(Canvas, "lift", lambda c: (calls.append("lift"), lift(c)))
    touch_many = Canvas.touch_many  # (the compiled period's feed: its calls one step at a time)
    monkeypatch.setattr(Canvas, "touch_many", lambda c, steps: [
        (calls.append(((x, y), f, t)) if f > 0.0 else None, touch_many(c, [(f, x, y, t)]))
        for f, x, y, t in steps])
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
    assert_same_log(a.log, b.log)
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


TWO_FEET = """<mujoco><option timestep="0.002"/><worldbody><geom type="plane" size="1 1 .1"/>
<body pos="0 0 .05"><joint name="x" type="slide" axis="1 0 0"/><joint name="z" type="slide"
axis="0 0 1"/><geom name="tip" type="sphere" size=".01" pos="0 0 -.04" mass=".1"/>
<geom name="other" type="sphere" size=".012" pos=".05 0 -.038" mass=".1"/><site name="s"
pos="0 0 -.04"/></body></worldbody><actuator><motor joint="x"/></actuator></mujoco>"""


def _periods_of(m: mujoco.MjModel, tip_geom: int, steps: int = 60):
    """The C period's pen forces over ``steps`` periods, and the same sums in Python (the
    contacts of ``tip_geom`` only, or every contact at -1) after each mj_step2."""
    d_c, d_py = mujoco.MjData(m), mujoco.MjData(m)
    for d in (d_c, d_py):
        mujoco.mj_forward(m, d)
    page = [1.0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0]
    period = compiled.period_module().Period((m, d_c), m._address, d_c._address, [0], 0,
                                             tip_geom, page, 3, 1e9, 0)
    contact, ours, theirs = np.zeros(6), [], []
    for _ in range(steps):
        ours += [row[0] for row in period.step(np.array([0.2]), np.zeros(1), 0.0)[2]]
        for _ in range(3):
            d_py.ctrl[0] = 0.2
            mujoco.mj_step2(m, d_py)
            force = 0.0
            for i in range(d_py.ncon):
                if tip_geom < 0 or tip_geom in d_py.contact.geom[i]:
                    mujoco.mj_contactForce(m, d_py, i, contact)
                    force += contact[0]
            theirs.append(force)
            mujoco.mj_step1(m, d_py)
    return ours, theirs


def test_the_compiled_pen_force_counts_only_the_tips_contacts(built):
    """Two feet on the floor: the pen force is the tip's contacts alone (the same bits as the
    Python sum), and every contact's where the plant says only the tip touches (-1)."""
    m = mujoco.MjModel.from_xml_string(TWO_FEET)
    tip = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "tip")
    tip_only, expected = _periods_of(m, tip)
    assert tip_only == expected and max(expected) > 0.5  # (the tip carries part of the weight)
    every, expected_every = _periods_of(m, -1)
    assert every == expected_every and max(every) > max(tip_only) + 0.5


def test_a_period_refuses_what_is_not_in_its_model(built):
    m = mujoco.MjModel.from_xml_string(TWO_FEET)
    d = mujoco.MjData(m)
    make = compiled.period_module().Period
    page = [1.0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0]
    with pytest.raises(ValueError, match="actuator 3 not in the model's 0..0"):
        make((m, d), m._address, d._address, [3], 0, -1, page, 3, 1e9, 0)
    with pytest.raises(ValueError, match="tip site 1 / geom -1 not in the model's 1 sites"):
        make((m, d), m._address, d._address, [0], 1, -1, page, 3, 1e9, 0)
    with pytest.raises(RuntimeError, match="the period was not initialised"):
        make.__new__(make).step(np.zeros(1), np.zeros(1), 0.0)
    period = make((m, d), m._address, d._address, [0], 0, -1, page, 3, 1e9, 0)
    with pytest.raises(ValueError, match="u and du must be 1 float64"):  # (8 bytes, not a double)
        period.step(np.zeros(2, np.float32), np.zeros(1), 0.0)
    with pytest.raises(ValueError, match="actuator 3 not in the model's 0..0"):
        period.__init__((m, d), m._address, d._address, [3], 0, -1, page, 3, 1e9, 0)
    with pytest.raises(RuntimeError, match="the period was not initialised"):  # (after a failed
        period.step(np.zeros(1), np.zeros(1), 0.0)                          # re-initialisation)
    from inkarm.sim import _period
    from inkarm.sim.divergence import DIVERGENCE_WARNINGS

    assert _period.WARNINGS == tuple(int(w) for w in DIVERGENCE_WARNINGS)


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


def test_an_extension_of_an_older_checkout_is_not_used(built, monkeypatch, caplog):
    from inkarm.sim import _period

    monkeypatch.delattr(_period, "API")  # (as the extension before Period.command)
    compiled._load.cache_clear()
    try:
        with caplog.at_level(logging.DEBUG, logger="inkarm.sim.compiled"):
            assert compiled.period_module() is None
            assert sim_plant.MujocoPlant(build_model())._period is None
    finally:
        compiled._load.cache_clear()
    assert f"of another inkarm (API none, this is {compiled.API}): build it again" in caplog.text


def test_the_switch_and_a_library_not_loaded_leave_the_python_period(built, monkeypatch):
    monkeypatch.setenv(compiled.SWITCH, "0")
    assert compiled.period_module() is None
    assert sim_plant.MujocoPlant(build_model())._period is None
    from inkarm.sim import _period

    with pytest.raises(ImportError, match="libnothing.so is not loaded"):
        _period.bind(os.path.join(os.sep, "nowhere", "libnothing.so"), mujoco.FatalError)


def test_a_new_set_point_in_c_gives_the_bits_of_the_drives_python(built):
    """compiled.set_point against JointDrive.set_point then affine_control: the same u, du,
    integral and goals, bit for bit, through the first set point, zero and negative times since
    the last, missing velocities, feed-forwards and link positions, goals not contiguous, NaN,
    and integrals clipped at their limits (one of them 0: the signed zeros of np.maximum and
    np.minimum)."""
    gains = PIDGains(kp=np.full(7, 800.0), ki=np.full(7, 4e5), kd=np.full(7, 30.0),
                     integral_limit=np.array([0.0, 5.0, 5.0, 5.0, 5.0, 5.0, 1e9]),
                     torque_limit=np.full(7, 300.0))
    plant = sim_plant.MujocoPlant(build_model(), drive_gains=gains)
    python = JointDrive(gains, plant.model.opt.timestep)
    rng = np.random.default_rng(5)
    clipped = set()
    for k in range(400):
        q = rng.normal(size=(7, 2))[:, 0] if k % 9 == 4 else rng.normal(size=7)  # (a view too)
        q[k % 7] = np.nan if k % 97 == 5 else q[k % 7]
        qd, tau_ff = (None if k % m == 1 else rng.normal(size=7) for m in (5, 7))
        q_link = None if k % 11 == 2 else q + rng.normal(size=7) * 1e-3 * (k % 3)
        python.since = plant.drive.since = (0.0, 0.006, -0.002, 0.004)[k % 4]
        python.set_point(q, qd, tau_ff, q_link)
        expected = (*python.affine_control(), python.integral, python.qd_goal, python.tau_ff)
        got = (*compiled.set_point(plant._period, plant.drive, PositionCommand(q, qd, None,
                                                                              tau_ff), q_link),
               plant.drive.integral, plant.drive.qd_goal, plant.drive.tau_ff)
        assert [x.tobytes() for x in got] == [x.tobytes() for x in expected], k
        assert plant.drive.q_goal.tobytes() == q.tobytes() and plant.drive.since == 0.0
        clipped |= set(python.integral[:6].tolist()) & {5.0, -5.0}
    assert clipped == {5.0, -5.0} and np.isnan(python.integral).any()


def test_a_set_point_refuses_arrays_of_another_size_or_kind(built):
    """The C call names the array it refuses (its length, dtype, layout), its arguments when
    it is given too few, and a period made without the drives' gains."""
    plant = sim_plant.MujocoPlant(build_model())
    n, drive = 7, plant.drive
    args = [np.zeros(n), np.zeros(n), drive.integral, None, None, np.zeros(n), None, None, None,
            0.0]
    for k, bad, message in ((5, np.zeros(n - 1), "q must be 7 float64"),
                            (2, np.zeros(n, dtype=np.float32), "integral must be 7 float64"),
                            (0, np.zeros(2 * n)[::2], "not C-contiguous")):
        wrong = list(args)
        wrong[k] = bad
        with pytest.raises((ValueError, BufferError), match=message):
            plant._period.command(*wrong)
    with pytest.raises(TypeError, match=r"command\(u, du, integral"):
        plant._period.command(*args[:9])
    m, d = plant.model, plant.data
    bare = compiled.period_module().Period((m, d), m._address, d._address, [0], 0, -1,
                                           [1.0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0], 3, 1e9, 0)
    with pytest.raises(RuntimeError, match="made without gains"):
        bare.command(*args)


class _Calls:
    """A canvas with touch and lift only (the plant's canvas protocol), recording the calls."""

    def __init__(self):
        self.calls = []

    def touch(self, p_mm, force_n, t):
        self.calls.append(("touch", tuple(p_mm), force_n, t))

    def lift(self):
        self.calls.append(("lift",))


def test_feed_gives_a_canvas_the_python_periods_calls_in_one():
    """feed against the Python period's loop (touch while the force is positive, lift when
    contact ends): the same (touching, last force) after every period, the same canvas through
    Canvas.touch_many, the same calls to a canvas without it, nothing without a canvas."""
    rng = np.random.default_rng(5)
    periods = []
    for k in range(200):
        forces = rng.choice([0.0, 0.0, -0.01, 0.05, 0.9, 1.3], size=3)
        periods.append(tuple((float(f), float(10 + rng.normal()), float(10 + rng.normal()),
                              0.006 * k + 0.002 * j) for j, f in enumerate(forces)))
    periods.append(())
    expected_canvas, expected_calls = Canvas(size_mm=(20.0, 20.0)), _Calls()
    canvas, calls = Canvas(size_mm=(20.0, 20.0)), _Calls()
    touching = was = False
    for steps in periods:
        force = 0.0
        for force, x, y, t in steps:
            if force > 0.0:
                was = True
                expected_canvas.touch((x, y), force, t)
                expected_calls.touch((x, y), force, t)
            elif was:
                was = False
                expected_canvas.lift()
                expected_calls.lift()
        assert compiled.feed(canvas, touching, steps) == (was, force)
        assert compiled.feed(calls, touching, steps) == (was, force)
        touching = compiled.feed(None, touching, steps)[0]
        assert touching == was
    np.testing.assert_array_equal(canvas.image, expected_canvas.image)
    assert canvas.n_strokes == expected_canvas.n_strokes > 20
    assert calls.calls == expected_calls.calls
