"""Stiction (inkarm.sim.stiction): a stuck joint holds up to Coulomb + stiction and then slides
with Coulomb only (oracles: a slow torque ramp on one joint of the arm, gravity off; MuJoCo's
own friction constraint force), its window from MuJoCo's regularisation (closed form), the
state machine on planted speeds, and the batched plant equal to the single one bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.core.plant import PositionCommand, TorqueCommand
from inkarm.errors import InputError
from inkarm.sim.cell import make_cell
from inkarm.sim.imperfections import PlantTruth
from inkarm.sim.perturb import plant_model
from inkarm.sim.plant import MujocoPlant
from inkarm.sim.stiction import STUCK_SPEED_FACTOR, Stiction, stuck_window
from tests.sim.batch_twins import command_both, sine_goals, twins

COULOMB = [7.5, 7.5, 4.5, 4.5, 3.0, 1.5, 1.5]  # 1.5 x the README's row [N m]


@pytest.fixture(scope="module")
def cell():
    return make_cell()


def weightless(cell, truth: PlantTruth, substeps: int = 1) -> MujocoPlant:
    """The arm with ``truth`` and without gravity: only the commanded torque and the friction
    act on a joint at rest."""
    model = plant_model(cell, truth)
    model.opt.gravity[:] = 0.0
    return MujocoPlant(model, cell=cell, truth=truth, substeps=substeps)


def test_the_window_is_mujocos_friction_regularisation(cell):
    # R = (1 - d0) / d0 * invweight0 at zero violation, B = 2 / (d_max timeconst): the speed up
    # to which a friction constraint of F holds is R F / B.
    model = plant_model(cell, PlantTruth())
    dofs = np.arange(7)
    holding = np.array(COULOMB) + 1.0
    d0, dmax = model.dof_solimp[dofs, 0], model.dof_solimp[dofs, 1]
    r = (1.0 - d0) / d0 * model.dof_invweight0[dofs]
    b = 2.0 / (dmax * model.dof_solref[dofs, 0])
    np.testing.assert_allclose(stuck_window(model, dofs, holding),
                               STUCK_SPEED_FACTOR * r * holding / b, rtol=1e-9)
    before = model.dof_frictionloss.copy()
    stuck_window(model, dofs, holding)
    np.testing.assert_array_equal(model.dof_frictionloss, before)  # (left as it was)
    assert stuck_window(model, dofs, np.zeros(7)).tolist() == [0.0] * 7


def test_the_state_machine_on_planted_speeds():
    s = Stiction(np.array([1.0]), np.array([0.5]), np.array([0.1]), np.zeros(1))
    assert s.stuck.tolist() == [True] and s.frictionloss().tolist() == [1.5]
    for v, stuck in [(0.05, True),  # within the window
                     (0.3, False), (0.5, False),  # rising out of it: sliding
                     (0.05, True),  # slow again: stuck
                     (0.3, False),
                     (-0.3, True),  # reversed within the step: stuck
                     (-0.2, True),  # above the window but falling: the friction holds it
                     (-0.25, False), (-0.9, False)]:  # rising: broken away
        changed = s.update(np.array([v]))
        assert s.stuck.tolist() == [stuck], v
        assert s.frictionloss().tolist() == [1.5 if stuck else 1.0]
        assert changed.dtype == bool and changed.shape == (1,)


def test_one_plants_float_loop_decides_as_the_arrays_do():
    rng = np.random.default_rng(5)
    window = np.array([0.01, 0.05, 0.1])
    arrays = Stiction(np.ones(3), np.full(3, 0.5), window, np.zeros(3))
    floats = Stiction(np.ones(3), np.full(3, 0.5), window, np.zeros(3))
    qd, switches = np.zeros(3), 0
    for _ in range(3000):  # a random walk of speeds through and around the windows
        qd = qd + rng.normal(0.0, 0.02, 3)
        qd[rng.random(3) < 0.05] = 0.0
        changed = arrays.update(qd)
        assert floats.step(qd.tolist()) == bool(changed.any())
        switches += int(changed.sum())
        np.testing.assert_array_equal(floats.stuck, arrays.stuck)
    assert switches > 100  # (the walk did cross the windows)


@pytest.mark.sim
@pytest.mark.parametrize("joint", [1, 6])
def test_a_slow_torque_ramp_breaks_away_at_coulomb_plus_stiction_then_slides_on_coulomb(
        cell, joint):
    """Stairs of 0.07 N m held 0.4 s each on one joint at rest, from 0.5 N m below C: every
    stair below C + S holds it (the friction equals the torque; it creeps at MuJoCo's R tau / B at most), the first at
    or above C + S breaks it away, and sliding the friction is C exactly."""
    stiction = 1.0
    truth = PlantTruth(coulomb_nm=COULOMB, stiction_nm=stiction)
    plant = weightless(cell, truth, substeps=200)
    c = COULOMB[joint]
    creep_per_nm = plant.stiction.window[joint] / STUCK_SPEED_FACTOR / (c + stiction)
    tau, step = np.zeros(7), 0.07
    for k in range(40):
        tau[joint] = c - 0.5 + k * step
        plant.command(TorqueCommand(tau.copy()))
        plant.step()
        v, friction = plant.data.qvel[joint], -plant.data.qfrc_constraint[joint]
        if tau[joint] < c + stiction:
            assert plant.stiction.stuck[joint], tau[joint]
            assert friction == pytest.approx(tau[joint], rel=5e-3)
            assert 0.0 <= v <= 1.01 * creep_per_nm * tau[joint]
        else:
            assert tau[joint] < c + stiction + step  # broken on the first stair above
            assert not plant.stiction.stuck[joint]
            assert friction == pytest.approx(c, abs=1e-9)  # Coulomb only
            assert v > 10 * plant.stiction.window[joint]
            break
    else:
        raise AssertionError("never broke away")


@pytest.mark.sim
def test_without_stiction_the_same_ramp_breaks_away_at_coulomb(cell):
    plant = weightless(cell, PlantTruth(coulomb_nm=COULOMB), substeps=200)
    assert plant.stiction is None
    tau, c = np.zeros(7), COULOMB[1]
    for k in range(20):
        tau[1] = c - 0.5 + k * 0.07
        plant.command(TorqueCommand(tau.copy()))
        plant.step()
        friction = -plant.data.qfrc_constraint[1]
        if tau[1] < c:
            assert friction == pytest.approx(tau[1], rel=5e-3)
        else:
            assert friction == pytest.approx(c, abs=1e-9)  # saturated on the first stair
            break


@pytest.mark.sim
def test_a_joint_at_rest_under_a_torque_between_coulomb_and_breakaway_stays(cell):
    """tau = C + S / 2 for one second: with stiction the joint creeps at MuJoCo's R tau / B at
    most (the friction constraint's own softness, as with Coulomb friction alone below C);
    without it, the joint slides away."""
    joint, stiction = 3, 1.0
    moved = {}
    for s in (stiction, 0.0):
        plant = weightless(cell, PlantTruth(coulomb_nm=COULOMB, stiction_nm=s), substeps=50)
        q0 = plant.data.qpos[joint]
        tau = np.zeros(7)
        tau[joint] = COULOMB[joint] + 0.5 * stiction
        plant.command(TorqueCommand(tau))
        for _ in range(10):  # 10 x 50 x 2 ms = 1 s
            plant.step()
            if s:
                assert plant.stiction.stuck.all()
        moved[s] = abs(plant.data.qpos[joint] - q0)
        if s:
            creep = plant.stiction.window[joint] / STUCK_SPEED_FACTOR * tau[joint] / (
                COULOMB[joint] + stiction)
            assert moved[s] <= 1.01 * creep * 1.0
    assert moved[0.0] > 10 * moved[stiction]  # 0.5 N m / I for a second


def drive_a_sine(plant, periods: int) -> np.ndarray:
    q0 = plant.read().q.copy()
    amp = np.array([0.2, -0.15, 0.2, 0.2, -0.3, 0.3, 0.4])
    qs = []
    for k in range(periods):
        phase = 2 * np.pi * 0.5 * k * plant.dt
        plant.command(PositionCommand(q0 + amp * np.sin(phase), amp * np.pi * np.cos(phase)))
        plant.step()
        qs.append(plant.read().q.copy())
    return np.array(qs)


@pytest.mark.sim
def test_the_drives_stick_and_slip_with_stiction_and_stiction_zero_is_the_plant_of_before(cell):
    nominal = PlantTruth(coulomb_nm=COULOMB)
    zero = MujocoPlant(plant_model(cell, nominal), cell=cell,
                       truth=PlantTruth(coulomb_nm=COULOMB, stiction_nm=0.0))
    assert zero.stiction is None
    base = drive_a_sine(MujocoPlant(plant_model(cell, nominal), cell=cell, truth=nominal), 200)
    np.testing.assert_array_equal(drive_a_sine(zero, 200), base)
    truth = PlantTruth(coulomb_nm=COULOMB, stiction_nm=[1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 1.0])
    sticky = MujocoPlant(plant_model(cell, truth), cell=cell, truth=truth)
    states = []
    dofs = sticky._friction_dofs
    original = sticky.step

    def step():  # (the joints' states once per period)
        original()
        states.append(sticky.stiction.stuck.copy())
        np.testing.assert_array_equal(sticky.model.dof_frictionloss[dofs],
                                      sticky.stiction.frictionloss())

    sticky.step = step
    q = drive_a_sine(sticky, 200)
    states = np.array(states)
    assert (sticky.model.dof_frictionloss[dofs][5] == COULOMB[5])
    switched = np.abs(np.diff(states.astype(int), axis=0)).sum(axis=0)
    assert switched[[0, 1, 2, 3, 4, 6]].min() >= 2  # each stuck and slid again (reversals)
    assert np.abs(q - base).max() > 1e-4  # and it shows in the motion


@pytest.mark.sim
def test_the_brakes_hold_whatever_the_joints_state(cell):
    truth = PlantTruth(stiction_nm=1.0)
    plant = weightless(cell, truth)
    plant.brake()
    held = plant.model.dof_frictionloss[:7].copy()
    assert held.min() >= 100.0
    plant.data.qvel[:7] = 1.0  # (what would switch every joint to sliding)
    plant.step()
    np.testing.assert_array_equal(plant.model.dof_frictionloss[:7], held)


@pytest.mark.sim
def test_the_batched_plant_sticks_as_the_single_one_bit_for_bit(cell):
    seeds = [3, 8]
    truths = [PlantTruth(seed=s, coulomb_nm=COULOMB, stiction_nm=1.0,
                         random={"mass_scale": [0.9, 1.1]}).realised() for s in seeds]
    batch, singles = twins(cell, truths, seeds)
    for q, qd in sine_goals(batch.read().q[0].copy(), batch.dt, 150):
        command_both(batch, singles, q, qd)
        reading = batch.read()
        for m, plant in enumerate(singles):
            np.testing.assert_array_equal(reading.q[m], plant.read().q)
    np.testing.assert_array_equal(batch.stiction.stuck, [p.stiction.stuck for p in singles])


@pytest.mark.parametrize("name", ["stiction_nm", "readout_jitter_ms"])
def test_a_batch_needs_one_stiction_and_one_jitter_for_every_member(name):
    from inkarm.sim.batch import check_batchable

    check_batchable([PlantTruth(**{name: 1.0}), PlantTruth(**{name: 1.0}, seed=2)])
    with pytest.raises(InputError, match=f"needs one {name} for every member") as err:
        check_batchable([PlantTruth(**{name: 1.0}), PlantTruth(**{name: 2.0})])
    assert err.value.key == f"plant.{name}"


def test_a_stiction_list_of_the_wrong_length_is_refused_naming_the_field(cell):
    truth = PlantTruth(stiction_nm=(1.0, 2.0))
    with pytest.raises(InputError, match=r"stiction_nm: expected 1 or 7 numbers"):
        MujocoPlant(plant_model(cell, truth), cell=cell, truth=truth)
    with pytest.raises(InputError, match=r"stiction_nm: expected a number in \[0, 500\]"):
        PlantTruth(stiction_nm=-1.0)


def test_a_closed_plant_gives_its_model_the_coulomb_friction_back(cell):
    """The stuck level is written into the model while the plant runs; a model used again
    (another plant on it) must start from its own Coulomb friction, not C + S."""
    truth = PlantTruth(coulomb_nm=2.0, stiction_nm=3.0)
    model = plant_model(cell, truth)
    before = model.dof_frictionloss.copy()
    plant = MujocoPlant(model, cell=cell, truth=truth)
    assert model.dof_frictionloss.max() > before.max()  # stuck: C + S in the model
    plant.close()
    assert np.array_equal(model.dof_frictionloss, before)
    again = MujocoPlant(model, cell=cell, truth=truth)
    assert np.array_equal(again.stiction.coulomb, plant.stiction.coulomb)
