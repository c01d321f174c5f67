"""The batched plant's physics steps in C (inkarm/sim/_batch.c through
inkarm.sim.batch_substeps) against its NumPy step, the reference: over the truths the C covers
(exact, quantised or noisy encoders; exact, differenced or servo-unit velocity; sensing and
actuation delays; force noise and bias; read-out jitter; the native drives) and with members
that stop stepping, every reading, the ring, the pen forces, the drives' state, the touches and
the ink fed to each member's canvas are the same bits."""

from __future__ import annotations

import re

import mujoco
import numpy as np
import pytest

from inkarm.sim import batch_substeps
from inkarm.sim.batch import BatchPlant, member_model
from inkarm.sim.cell import PAPER, make_cell
from inkarm.sim.imperfections import PlantTruth
from tests.compiled import compiled_or_skip

pytestmark = pytest.mark.sim
SEEDS = [3, 8, 11]
RANDOM = {"paper_height_mm": [0.0, 2.0], "mass_scale": [0.9, 1.1]}
RAISE_M = 0.240  # [m] the sheet raised to the pen at home: it touches, presses and lifts
TRUTHS = {
    "ideal": {},
    "realistic": {"q_noise_rad": 1e-4, "velocity": "differences", "force_noise_n": 0.02,
                  "force_bias_n": 0.01, "sensing_delay_ms": 2.0, "actuation_delay_ms": 2.0},
    "ticks_servo": {"encoder_ticks_per_rev": 4096, "velocity": "servo",
                    "actuation_delay_ms": 4.0},
    "ticks_differences_jitter": {"encoder_ticks_per_rev": 4096, "q_noise_rad": 2e-4,
                                 "velocity": "differences", "readout_jitter_ms": 3.0,
                                 "force_bias_n": -0.05},
    "exact_delayed": {"sensing_delay_ms": 4.0, "actuation_delay_ms": 2.0, "force_noise_n": 0.1},
}


@pytest.fixture(scope="module")
def cell():
    return make_cell()


@pytest.fixture
def built():
    """The extension, or a skip that says why (a failure with INKARM_REQUIRE_COMPILED=1)."""
    batch_substeps._load.cache_clear()
    return compiled_or_skip(batch_substeps.substeps_module(), "the compiled batch substeps")


class Rows:
    """A canvas that keeps what it is given."""

    def __init__(self):
        self.calls: list = []

    def touch_many(self, rows):
        self.calls.append(np.array(rows))

    def lift(self):
        self.calls.append("lift")


def pair(cell, monkeypatch, fields: dict) -> tuple[BatchPlant, BatchPlant]:
    """(the plant with the C substeps, the plant with the NumPy step) of the same members."""
    truths = [PlantTruth(seed=s, random=RANDOM, **fields).realised() for s in SEEDS]
    plants = []
    for switch in ("1", "0"):
        monkeypatch.setenv("INKARM_COMPILED", switch)
        models = [member_model(cell, t) for t in truths]
        for m in models:
            m.body_pos[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, PAPER), 2] += RAISE_M
        plants.append(BatchPlant(models, cell, truths[0], SEEDS, nthread=1))
    monkeypatch.delenv("INKARM_COMPILED")
    assert plants[0]._compiled is not None and plants[1]._compiled is None
    return plants[0], plants[1]


def assert_same(c: BatchPlant, p: BatchPlant) -> None:
    """Every number of the two plants' states that a reader or the canvas sees, bit for bit."""
    a, b = c.read(), p.read()
    for name in ("time", "q", "qd", "torque", "force", "tip_mm", "times"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    for name in ("time", "steps", "pen_force", "motor", "_ring_time", "_tip_prev"):
        np.testing.assert_array_equal(getattr(c, name), getattr(p, name), err_msg=name)
    for name in c._ring:
        np.testing.assert_array_equal(c._ring[name], p._ring[name], err_msg=f"ring {name}")
    for name in ("integral", "v", "q_prev", "q_goal", "qd_goal", "tau_ff", "since"):
        np.testing.assert_array_equal(getattr(c.drive, name), getattr(p.drive, name),
                                      err_msg=f"drive.{name}")
    for x, y in zip(c._touches.rows(), p._touches.rows(), strict=True):
        np.testing.assert_array_equal(x, y, err_msg="touches")
    np.testing.assert_array_equal(c._draws[:, c._drawn:], p._draws[:, p._drawn:])
    np.testing.assert_array_equal(c._ctrl, p._ctrl)


def drive_both(c: BatchPlant, p: BatchPlant, periods: int, stop: int | None = None) -> None:
    """A sine about home to every member for ``periods`` control periods (the pen on and off
    the sheet); member 1 neither commanded nor stepped from period ``stop`` on (as the executor
    leaves a faulted member)."""
    q0 = c.read().q[0].copy()
    p.read()  # (with read-out jitter each reading draws its age)
    for k in range(periods):
        q, qd = q0 + 0.02 * np.sin(0.2 * k), np.full(len(q0), 0.004 / c.dt * np.cos(0.2 * k))
        ids = np.array([0, 2] if stop is not None and k >= stop else [0, 1, 2])
        n = len(ids)
        for plant in (c, p):
            plant.command(ids, np.stack([q] * n), np.stack([qd] * n), np.zeros((n, len(q))))
            assert plant.step(ids) == {}
        assert_same(c, p)


@pytest.mark.parametrize("variant", sorted(TRUTHS))
def test_the_c_substeps_are_the_numpy_step_bit_for_bit(built, cell, monkeypatch, variant):
    c, p = pair(cell, monkeypatch, TRUTHS[variant])
    drive_both(c, p, 60, stop=40)
    _, on, force, _ = c._touches.rows()
    for member in range(len(SEEDS)):
        f = force[on[:, member], member]  # (the sums of the contact sensor's normals compared)
        assert (f > 0.0).any() and (f == 0.0).any()
        canvases = Rows(), Rows()
        c.feed(member, canvases[0])
        p.feed(member, canvases[1])
        assert len(canvases[0].calls) == 2
        np.testing.assert_array_equal(canvases[0].calls[0], canvases[1].calls[0])


def test_past_the_first_block_of_draws(built, cell, monkeypatch):
    """Noisy encoders draw 2 n + 1 normals a physics step: 4096 last 273 steps."""
    c, p = pair(cell, monkeypatch, TRUTHS["realistic"])
    drive_both(c, p, 100)
    assert c.steps > 4096 // (2 * c.n + 1)


def test_stiction_keeps_the_numpy_step(cell):
    truth = PlantTruth(stiction_nm=0.5)
    plant = BatchPlant([member_model(cell, truth)], cell, truth, [0], nthread=1)
    assert plant._compiled is None


def test_the_switch_keeps_the_numpy_step(cell, monkeypatch):
    monkeypatch.setenv("INKARM_COMPILED", "0")
    assert batch_substeps.substeps_module() is None


def test_the_c_refuses_arrays_of_another_shape_naming_them(built, cell, monkeypatch):
    c, _ = pair(cell, monkeypatch, TRUTHS["realistic"])
    s = c._compiled.c
    touches = c._touches
    touches.reserve(c.substeps)
    with pytest.raises(TypeError, match="touch_on must be a writable 2-d bool array"):
        s.period(c.batch.step, None, None, [], c._draws, c._drawn, touches.t,
                 touches.force, touches.force, touches.tip, 0, 0.0, 0.0, 0, False, False, False)
    with pytest.raises(ValueError, match="too few draws for a period"):
        s.period(c.batch.step, None, None, [], c._draws[:, :0], 0, touches.t, touches.on,
                 touches.force, touches.tip, 0, 0.0, 0.0, 0, False, False, False)
    with pytest.raises(ValueError, match="touch_force must have .* rows of the 3 members"):
        s.period(c.batch.step, None, None, [], c._draws, c._drawn, touches.t, touches.on,
                 touches.force[:1], touches.tip, 0, 0.0, 0.0, 0, False, False, False)
    with pytest.raises(ValueError, match="stepped not one per member"):
        s.period(c.batch.step, np.array([0], np.int32), np.ones(2, bool), [], c._draws,
                 c._drawn, touches.t, touches.on, touches.force, touches.tip, 0, 0.0, 0.0, 0,
                 False, False, False)
    assert c.steps == 0  # (nothing stepped)
    monkeypatch.setitem(c._ring, "q", c._ring["q"][:, :2])  # (2 members' columns of 3)
    with pytest.raises(ValueError, match="ring_q has .* rows|ring_q must be"):
        batch_substeps.CompiledSubsteps(c, built)


@pytest.mark.parametrize("delay_ms", [2.0, 4.0])
def test_a_ctrl_c_before_a_delayed_command_keeps_it_queued(built, cell, monkeypatch, delay_ms):
    """A KeyboardInterrupt from the batch's first step of a period whose later steps a delayed
    command comes due in: the command stays queued (the goals as they were), and the plants go
    on equal to the NumPy step's (helper R's finding F1)."""
    c, p = pair(cell, monkeypatch, {**TRUTHS["realistic"], "actuation_delay_ms": delay_ms})
    drive_both(c, p, 10)
    ids = np.arange(len(SEEDS))
    q0 = c.read().q[0].copy()
    p.read()
    for plant in (c, p):
        plant.command(ids, np.stack([q0 + 0.01] * 3), np.zeros((3, len(q0))),
                      np.zeros((3, len(q0))))
        real = plant.batch.step

        def interrupted(*args):
            raise KeyboardInterrupt

        monkeypatch.setattr(plant.batch, "step", interrupted)
        with pytest.raises(KeyboardInterrupt):
            plant.step(ids)
        monkeypatch.setattr(plant.batch, "step", real)
    assert len(c._queue) == len(p._queue) == 1
    for _ in range(3):
        for plant in (c, p):
            assert plant.step(ids) == {}
    assert_same(c, p)


def test_the_counters_are_the_c_calls_even_when_the_return_is_interrupted(built, cell,
                                                                          monkeypatch):
    """A Ctrl-C that lands just after the C period returned (before Python took its counters):
    the plant still counts the steps taken (helper R's finding F2)."""
    c, p = pair(cell, monkeypatch, TRUTHS["realistic"])
    drive_both(c, p, 5)
    ids = np.arange(len(SEEDS))
    real = c._compiled.c

    class Late:
        def period(self, *args):
            real.period(*args)
            raise KeyboardInterrupt  # (as a signal handled at the next bytecode)

        def progress(self):
            return real.progress()

    monkeypatch.setattr(c._compiled, "c", Late())
    with pytest.raises(KeyboardInterrupt):
        c.step(ids)
    monkeypatch.setattr(c._compiled, "c", real)
    assert p.step(ids) == {}
    assert_same(c, p)


def test_a_ctrl_c_in_the_batchs_step_leaves_the_steps_taken_counted(built, cell, monkeypatch):
    """A KeyboardInterrupt from the batch's step at the second physics step of a period: the C
    hands back the counters of the step it completed (time, steps, draws, touches), as the
    NumPy step leaves them, and the next period steps on from there."""
    c, p = pair(cell, monkeypatch, TRUTHS["realistic"])
    drive_both(c, p, 10)
    ids = np.arange(len(SEEDS))
    for plant in (c, p):
        real, calls = plant.batch.step, []

        def interrupted(*args, real=real, calls=calls):
            calls.append(args)
            if len(calls) == 2:
                raise KeyboardInterrupt
            return real(*args)

        monkeypatch.setattr(plant.batch, "step", interrupted)
        with pytest.raises(KeyboardInterrupt):
            plant.step(ids)
        monkeypatch.setattr(plant.batch, "step", real)
        assert plant.steps == 10 * plant.substeps + 1
    assert c.time == p.time and c._drawn == p._drawn and c._touches.count == p._touches.count
    for plant in (c, p):
        assert plant.step(ids) == {}
    assert c.steps == p.steps == 11 * c.substeps + 1


@pytest.mark.parametrize("push, message", [
    (500.0, r"simulation diverged at t = [0-9.]+ s: joint[0-9] moves at [0-9.]+ rad/s, above"),
    (np.nan, r"non-finite or huge joint state \(MuJoCo warned .*mjWARN_BADQVEL"),
])
def test_a_diverging_member_is_named_with_its_error_and_the_others_go_on(cell, monkeypatch,
                                                                         tmp_path, push,
                                                                         message):
    """The divergence check of a period (its common case one test of all members): the member
    pushed past the speed limit, or to NaN (MuJoCo's warning), is reported, alone."""
    monkeypatch.chdir(tmp_path)  # (MuJoCo may append its warnings to ./MUJOCO_LOG.TXT)
    truths = [PlantTruth(seed=s) for s in SEEDS]
    plant = BatchPlant([member_model(cell, t) for t in truths], cell, truths[0], SEEDS,
                       nthread=1, max_joint_speed=20.0)
    every = np.arange(len(SEEDS))
    q = plant.read().q
    plant.command(every, q, np.zeros_like(q), np.zeros_like(q))
    assert plant.step(every) == {}
    plant._qvel[1, 3] = push  # (a joint of member 1; the arm's dofs come first)
    diverged = plant.step(every)
    assert list(diverged) == [1]
    assert re.search(message, str(diverged[1]))
    assert plant.step(np.array([0, 2])) == {}
