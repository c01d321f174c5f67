"""Read-out jitter (inkarm.sim.senses): each reading is ``sensing_delay_ms`` plus uniform(0,
``readout_jitter_ms``) old. Oracles: a joint spinning at constant speed reads behind by exactly
its age times the speed, the ages spread uniformly over [delay, delay + J]; one age per period;
the draws from the truth's seed; the batched plant equal to the single one; J = 0 the delay of
before, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from inkarm.sim.cell import make_cell
from inkarm.sim.imperfections import PlantTruth
from inkarm.sim.perturb import plant_model
from inkarm.sim.plant import MujocoPlant, SimState
from inkarm.sim.senses import JITTER_BLOCK, Senses, blend, history_length, jitter_generator
from tests.sim.batch_twins import command_both, sine_goals, twins


@pytest.fixture(scope="module")
def cell():
    return make_cell()


def spinning(cell, truth: PlantTruth, w: float) -> MujocoPlant:
    """The arm without gravity or friction, joints 1-6 held by huge rotor inertias, joint 7
    turning at ``w`` [rad/s]: a joint at constant speed."""
    model = plant_model(cell, truth)
    model.opt.gravity[:] = 0.0
    model.dof_damping[:7] = 0.0
    model.dof_armature[:6] = 1e6
    plant = MujocoPlant(model, cell=cell, truth=truth)
    plant.data.qvel[6] = w
    return plant


@pytest.mark.sim
def test_a_joint_at_constant_speed_reads_behind_by_a_uniform_age(cell):
    delay, jitter, w = 2.0, 6.0, 0.5
    truth = PlantTruth(coulomb_nm=0.0, sensing_delay_ms=delay, readout_jitter_ms=jitter)
    plant = spinning(cell, truth, w)
    lags = []
    for k in range(1000):  # 6 s, 3 rad: short of the joint's limit
        plant.step()
        reading = plant.read()
        lag = (plant.data.qpos[6] - reading.q[6]) / w  # [s]
        assert lag == pytest.approx(plant.data.time - reading.time, abs=1e-9)  # its own age
        if k >= 3:  # (once the history reaches back before the spin began)
            assert reading.qd[6] == pytest.approx(w, abs=1e-9)
            lags.append(lag * 1000.0)
    lags = np.array(lags)
    assert lags.min() >= delay - 1e-6 and lags.max() <= delay + jitter + 1e-6
    assert lags.min() < delay + 0.05 and lags.max() > delay + jitter - 0.05
    assert lags.mean() == pytest.approx(delay + jitter / 2, abs=0.2)  # 3.6 sigma
    assert stats.kstest((lags - delay) / jitter, "uniform").pvalue > 1e-3


@pytest.mark.sim
def test_without_jitter_the_reading_is_the_delayed_step_of_before(cell):
    truth = PlantTruth(sensing_delay_ms=4.0, readout_jitter_ms=0.0)
    plant = MujocoPlant(plant_model(cell, truth), cell=cell, truth=truth, substeps=1)
    history = []
    for _ in range(10):
        plant.step()
        history.append(plant.data.qpos[:7].copy())
        reading = plant.read()
    assert reading is plant.senses_model.snapshots[0]  # the stored step itself, no arithmetic
    np.testing.assert_array_equal(reading.q, history[-3])
    assert len(plant.senses_model.snapshots) == history_length(2, 0.0) == 3


def readings(truth: PlantTruth, periods: int = 50) -> list[SimState]:
    """A Senses fed a planted history q = t (3 steps of 2 ms per period), read each period."""
    senses = Senses(truth, 1, 0.002)
    out = []
    for step in range(3 * periods + 1):
        t = 0.002 * step
        senses.record(SimState(time=t, q=np.array([t]), qd=np.ones(1), force=2.0 * t,
                               tip_mm=np.array([t, 0.0, 1.0]), errors=("x",)))
        if step % 3 == 0:
            first = senses.latest()
            assert senses.latest() is first  # one age per period
            out.append(first)
    return out


def test_the_ages_come_from_the_truths_seed_and_every_number_is_interpolated():
    a, b = (readings(PlantTruth(readout_jitter_ms=6.0, seed=s)) for s in (1, 2))
    again = readings(PlantTruth(readout_jitter_ms=6.0, seed=1))
    assert [r.time for r in a] == [r.time for r in again]
    assert [r.time for r in a] != [r.time for r in b]
    for r in a[4:]:  # the planted history is linear: every field is of the reading's time
        assert r.q[0] == pytest.approx(r.time, abs=1e-15)
        assert r.force == pytest.approx(2.0 * r.time, abs=1e-15)
        np.testing.assert_allclose(r.tip_mm, [r.time, 0.0, 1.0], atol=1e-15)
        assert r.errors == ("x",) and r.current is None
    # the draws: the truth's own stream, in blocks
    u = jitter_generator(1).random(JITTER_BLOCK)
    now = 0.006 * np.arange(len(a))
    ages = (now - np.array([r.time for r in a])) / 0.002
    np.testing.assert_allclose(ages[4:], 3.0 * u[4:len(a)], atol=1e-9)


def test_blend_takes_the_numbers_of_the_way_and_keeps_the_rest():
    newer = SimState(time=1.0, q=np.array([1.0, 2.0]), qd=np.zeros(2), force=None,
                     errors=("late",), pen_compression_mm=1.0)
    older = SimState(time=0.0, q=np.array([0.0, 0.0]), qd=np.ones(2), force=None,
                     errors=(), pen_compression_mm=3.0)
    mid = blend(newer, older, 0.25)
    assert type(mid) is SimState and mid.time == 0.75 and mid.q.tolist() == [0.75, 1.5]
    assert mid.qd.tolist() == [0.25, 0.25] and mid.pen_compression_mm == 1.5
    assert mid.force is None and mid.errors == ("late",)


def test_the_history_is_long_enough_for_the_oldest_reading():
    assert history_length(0, 0.0) == 1 and history_length(1, 0.0) == 2
    assert history_length(1, 3.0) == 6 and history_length(1, 2.5) == 6
    # the oldest age: d + J/h steps, interpolated with the step before it
    senses = Senses(PlantTruth(sensing_delay_ms=2.0, readout_jitter_ms=5.0), 1, 0.002)
    assert senses.snapshots.maxlen >= 1 + int(np.ceil(2.5)) + 1


@pytest.mark.sim
def test_the_batched_plant_reads_as_the_single_one_bit_for_bit(cell):
    seeds = [3, 8]
    truths = [PlantTruth(seed=s, sensing_delay_ms=2.0, readout_jitter_ms=6.0, q_noise_rad=1e-4,
                         random={"mass_scale": [0.9, 1.1]}).realised() for s in seeds]
    batch, singles = twins(cell, truths, seeds)
    # (past the first block of draws)
    for q, qd in sine_goals(batch.read().q[0].copy(), batch.dt, JITTER_BLOCK + 20):
        reading = batch.read()
        for m, plant in enumerate(singles):
            alone = plant.read()
            assert reading.times[m] == alone.time
            np.testing.assert_array_equal(reading.q[m], alone.q)
            np.testing.assert_array_equal(reading.qd[m], alone.qd)
            assert reading.force[m] == alone.force
        command_both(batch, singles, q, qd)
    assert reading.times[0] != reading.times[1]  # each member its own age
    from inkarm.sim.batch_members import BatchMembers

    member = BatchMembers(batch).plants[1]
    assert member.read().time == batch.read().times[1]


@pytest.mark.sim
def test_an_ensemble_member_with_stiction_and_jitter_is_the_run_of_its_seed():
    """Through the jobs: the batched ensemble (one mujoco.batch) against ``run`` member by
    member, with stiction, a delay and read-out jitter: the same log and ink, bit for bit."""
    from inkarm.jobs.ensemble import batch_refusal, run_ensemble
    from inkarm.jobs.run import run
    from inkarm.jobs.scenario import load_scenario

    scenario = load_scenario("scenarios/quick_stroke.toml").with_overrides({
        "plant.stiction_nm": 1.0, "plant.sensing_delay_ms": 2.0, "plant.readout_jitter_ms": 6.0,
        "plant.random": {"mass_scale": [0.9, 1.1]}})
    seeds = [1, 2]
    assert batch_refusal(scenario, seeds) is None
    for seed, batched in zip(seeds, run_ensemble(scenario, seeds, processes=1)):
        alone = run(scenario.with_overrides({"plant.seed": seed}))
        assert batched.status == alone.status
        np.testing.assert_array_equal(batched.log.time, alone.log.time)
        np.testing.assert_array_equal(batched.log.q, alone.log.q)
        np.testing.assert_array_equal(batched.canvas.image, alone.canvas.image)
