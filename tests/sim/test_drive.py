"""The joint drives: as MuJoCo actuators the affine actuator applies the drive law exactly
(closed form), its integral runs at the command rate, a plant with native drives draws the same
run as the same plant with the drives in Python (to rounding), and a torque command turns the
motors back into plain motors; an elastic joint leads its motor by the spring's deflection."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import inkarm.sim.plant as plant_module
from inkarm.core.plant import PositionCommand, TorqueCommand
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario
from inkarm.robots.gains import PIDGains
from inkarm.sim.actuators import affine_drives, native_drive
from inkarm.sim.cell import build_model, make_cell
from inkarm.sim.drive import JointDrive
from inkarm.sim.imperfections import PlantTruth
from inkarm.sim.plant import MujocoPlant

pytestmark = pytest.mark.sim

N = 7
GAINS = PIDGains(kp=np.full(N, 800.0), ki=np.full(N, 400.0), kd=np.full(N, 30.0),
                 integral_limit=np.full(N, 5.0), torque_limit=np.full(N, 300.0))


def test_affine_actuator_gives_the_drive_law_in_closed_form():
    cell = make_cell()
    model = build_model(cell)
    data = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    limit = np.array([20.0, 300.0, 300.0, 300.0, 300.0, 300.0, 300.0])  # the first saturates
    arm = slice(0, N)
    affine_drives(model, arm, GAINS, limit)
    drive = JointDrive(GAINS, model.opt.timestep)
    q, qd = rng.uniform(-0.5, 0.5, N), rng.uniform(-0.3, 0.3, N)
    data.qpos[:N], data.qvel[:N] = q, qd
    goal, goal_v, tau_ff = q + rng.uniform(-0.01, 0.01, N), rng.uniform(-0.2, 0.2, N), \
        rng.uniform(-5, 5, N)
    goal[0] = q[0] + 0.1  # 80 N m asked of a 20 N m motor
    drive.set_point(goal, goal_v, tau_ff)
    drive.integral = rng.uniform(-1, 1, N)
    u, du = drive.affine_control()
    for k in range(3):  # the set point ramps with its velocity, one physics step at a time
        data.ctrl[arm] = u + k * du
        mujoco.mj_forward(model, data)
        expected = tau_ff + GAINS.kp * (goal + goal_v * k * model.opt.timestep - q) \
            + drive.integral + GAINS.kd * (goal_v - qd)
        assert np.allclose(data.actuator_force[arm], np.clip(expected, -limit, limit),
                           rtol=1e-12, atol=1e-9)
    assert data.actuator_force[0] == pytest.approx(20.0)
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER


def test_integral_runs_at_the_command_rate_with_anti_windup():
    drive = JointDrive(GAINS, 0.002)
    q0 = np.zeros(N)
    drive.set_point(q0, np.full(N, 0.1), None, q_link=q0)
    assert not drive.integral.any()  # the first set point has no past error
    for _ in range(3):
        drive.torque(q0, np.zeros(N))  # three steps: 6 ms since the set point
    q_link = np.full(N, 0.0002)
    drive.set_point(q0, None, None, q_link=q_link)
    # I = K_i (t - t_cmd) (q*(t) - q_link) with q*(t) = 0.1 rad/s * 6 ms
    assert np.allclose(drive.integral, 400.0 * 0.006 * (0.1 * 0.006 - 0.0002))
    drive.since = 10.0
    drive.set_point(q0, None, None, q_link=np.full(N, -1.0))
    assert np.array_equal(drive.integral, np.full(N, 5.0))  # clipped at the integral limit


@pytest.mark.parametrize("truth, native", [
    (PlantTruth(), True),
    (PlantTruth(paper_height_mm=2.0, mass_scale=1.1, coulomb_nm=[3.0] * N), True),
    (PlantTruth(q_noise_rad=1e-4), False),
    (PlantTruth(encoder_ticks_per_rev=4096), False),
    (PlantTruth(velocity="differences"), False),
    (PlantTruth(actuation_delay_ms=2.0), False),
])
def test_drives_run_natively_only_where_the_actuator_sees_what_the_drive_does(truth, native):
    assert native_drive(True, truth, False) is native
    assert not native_drive(True, PlantTruth(), True)  # a transmission between motor and link
    assert not native_drive(False, PlantTruth(), False)  # servo firmware


def test_native_and_python_drives_draw_the_same_run(monkeypatch):
    scenario = load_scenario("scenarios/quick_stroke.toml")
    native = run(scenario)
    monkeypatch.setattr(plant_module, "native_drive", lambda *args: False)
    python = run(scenario)
    assert native.ok and python.ok and len(native.log) == len(python.log)
    # the same law, summed in C instead of NumPy: equal to the last bits
    assert np.abs(native.log.q - python.log.q).max() < 1e-12
    assert np.abs(native.log.force - python.log.force).max() < 1e-9
    assert np.abs(native.log.torque - python.log.torque).max() < 1e-8
    assert np.array_equal(native.canvas.image, python.canvas.image)


def test_a_torque_command_turns_the_drives_back_into_motors():
    cell = make_cell()
    plant = MujocoPlant(cell=cell)
    q = plant.read().q
    plant.command(PositionCommand(q, np.zeros(N), None, np.zeros(N)))
    plant.step()
    assert plant.model.actuator_biastype[0] == mujoco.mjtBias.mjBIAS_AFFINE
    held = plant.read().torque  # the drives hold the arm against gravity
    assert np.abs(held).max() > 1.0
    tau = np.array([1.0, -2.0, 0.5, 0.0, 0.0, 0.0, 0.0])
    plant.command(TorqueCommand(tau))
    plant.step()
    assert plant.model.actuator_biastype[0] == mujoco.mjtBias.mjBIAS_NONE
    assert np.allclose(plant.data.actuator_force[:N], tau)
    assert np.array_equal(plant.read().torque, tau)


def test_an_elastic_joint_leads_its_motor_by_the_spring_deflection():
    drive = JointDrive(GAINS, 0.002)
    k = np.array([2e4, 1e4])
    drive.elastic(np.array([1, 3]), k)
    assert drive.ki[1] == drive.ki[0] / 10 and drive.ki[3] == drive.ki[0] / 10
    tau_ff = np.linspace(-40.0, 40.0, N)
    q = np.zeros(N)
    drive.set_point(q, None, tau_ff)
    # at the motor goal q* + tau_ff / k the P term is silent: the motor passes tau_ff
    motor = q.copy()
    motor[[1, 3]] += tau_ff[[1, 3]] / k
    assert np.allclose(drive.torque(motor, np.zeros(N)), tau_ff, rtol=0, atol=1e-9)


def test_the_static_deflection_of_an_elastic_arm_is_led_away():
    """Holding a pose against gravity through springs: the links sit where they are asked to,
    without waiting for the integral (the lead alone)."""
    from inkarm.control.kinematics import ArmKinematics
    from inkarm.sim.cell import kinematic_model

    cell = make_cell()
    plant = MujocoPlant(cell=cell, truth=PlantTruth(elasticity_nm_per_rad=[2e4, 2e4, 1e4, 1e4,
                                                                           5e3, 2e3, 2e3]))
    plant.drive.ki[:] = 0.0
    pose = np.array([0.0, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])
    gravity = ArmKinematics.of(kinematic_model(cell)).bias(pose, np.zeros(N)).copy()
    for _ in range(300):
        plant.command(PositionCommand(pose, np.zeros(N), None, gravity))
        plant.step()
    assert np.abs(gravity).max() > 20.0  # 55 N m at the shoulder: 2.8 mrad of spring
    assert np.abs(plant.data.qpos[:N] - pose).max() < 2e-5


def test_a_plant_with_a_transmission_starts_where_it_is_put():
    pose = np.array([0.0, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])
    plant = MujocoPlant(cell=make_cell(), q0=pose,
                        truth=PlantTruth(elasticity_nm_per_rad=[2e4] * N, backlash_deg=0.1))
    assert np.array_equal(plant.read().q, pose)
    assert np.array_equal(plant.transmission.theta, pose)  # rotors at rest against the links
