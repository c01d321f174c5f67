"""The X-series firmware model against closed forms (inkarm.robots.servo)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from inkarm.errors import InputError
from inkarm.robots import servo
from inkarm.robots.servo import FirmwareGains, ServoFirmware

# A servo without back-EMF or current limit, so the PID alone shapes the torque.
IDEAL = dataclasses.replace(servo.SERVO_MODELS["XM430-W350"], name="ideal",
                            no_load_speed_rad_s=np.inf, current_unit_ma=None)


def test_pid_step_on_pure_inertia_matches_the_closed_form_discrete_loop():
    dt, inertia, goal = 0.002, 0.01, 2053.0
    p_tbl, i_tbl, d_tbl = 900.0, 400.0, 2500.0
    fw = ServoFirmware([IDEAL], FirmwareGains(position_p=p_tbl, position_i=i_tbl,
                                              position_d=d_tbl), dt)
    fw.reset([2048.0])
    x, w = 2048.0, 0.0                       # [ticks], [ticks/s]
    rad = 2 * np.pi / 4096
    errors = []
    for _ in range(400):
        errors.append(goal - x)
        tau = fw.torque([goal], [x], [w * rad])[0]
        w += tau / inertia / rad * dt        # semi-implicit Euler on J qdd = tau
        x += w * dt
    # The closed form: z_k = M^k z_0, z = (e_k, w_k, S_{k-1}, e_{k-1}), from the e-Manual
    # conversions KPP = P/128, KPI = I/65536, KPD = D/16 and torque = stall * PWM / 885.
    c, cyc = IDEAL.stall_torque_nm / 885.0, servo.FIRMWARE_CYCLE_S
    kp, ki, kd = p_tbl / 128, i_tbl / 65536, d_tbl / 16
    g = c / inertia / rad * dt               # ticks/s gained per PWM unit per step
    # u_k = kp e + ki (S + e dt/cyc) + kd (e - e_prev) cyc/dt
    u = np.array([kp + ki * dt / cyc + kd * cyc / dt, 0.0, ki, -kd * cyc / dt])
    m = np.zeros((4, 4))
    m[1] = np.array([0.0, 1.0, 0.0, 0.0]) + g * u           # w_{k+1} = w_k + g u_k
    m[0] = np.array([1.0, 0.0, 0.0, 0.0]) - dt * m[1]       # e_{k+1} = e_k - dt w_{k+1}
    m[2] = [dt / cyc, 0.0, 1.0, 0.0]                        # S_k = S_{k-1} + e_k dt/cyc
    m[3] = [1.0, 0.0, 0.0, 0.0]
    z0 = np.array([goal - 2048.0, 0.0, 0.0, 0.0])
    closed = [(np.linalg.matrix_power(m, k) @ z0)[0] for k in range(400)]
    np.testing.assert_allclose(errors, closed, rtol=1e-9, atol=1e-9)
    assert max(abs(np.linalg.eigvals(m))) < 1.0 and abs(errors[-1]) < 0.05


def _trapezoid(t, distance, v, a):
    """Closed-form velocity-based profile from rest (e-Manual: t1 = V/A, t3 = D/V + t1)."""
    if distance >= v * v / a:
        t1, t3 = v / a, distance / v + v / a
        t2 = t3 - t1
        return np.where(t < t1, 0.5 * a * t * t,
                        np.where(t < t2, 0.5 * a * t1 * t1 + v * (t - t1),
                                 np.where(t < t3, distance - 0.5 * a * (t3 - t) ** 2, distance)))
    t1 = np.sqrt(distance / a)
    return np.where(t < t1, 0.5 * a * t * t,
                    np.where(t < 2 * t1, distance - 0.5 * a * (2 * t1 - t) ** 2, distance))


@pytest.mark.parametrize("distance", [2000.0, 300.0, -1200.0])
def test_profile_generator_traces_the_closed_form_trapezoid(distance):
    dt, v_reg, a_reg = 0.001, 100.0, 20.0
    fw = ServoFirmware(["XM430-W350"], FirmwareGains(profile_velocity=v_reg,
                                                     profile_acceleration=a_reg), dt)
    fw.reset([0.0])
    ticks_per_rad = 4096 / (2 * np.pi)
    v = servo.velocity_units_to_rad_s(v_reg) * ticks_per_rad
    a = servo.acceleration_units_to_rad_s2(a_reg) * ticks_per_rad
    positions = []
    for _ in range(2500):
        fw.advance_profile([distance])
        positions.append(fw.profile.position[0])
        assert abs(fw.profile.velocity[0]) <= v + 1e-9
    t = dt * np.arange(1, 2501)
    expected = np.sign(distance) * _trapezoid(t, abs(distance), v, a)
    assert np.max(np.abs(np.array(positions) - expected)) < 3.0   # ticks, at 1 ms
    assert positions[-1] == distance and fw.profile.velocity[0] == 0.0


def test_zero_profile_registers_mean_a_step():
    fw = ServoFirmware(["XM430-W350"], FirmwareGains(), 0.004)
    fw.reset([100.0])
    fw.advance_profile([3000.0])
    assert fw.profile.position[0] == 3000.0


def test_full_duty_torque_falls_with_speed_and_stops_at_the_current_limit():
    models = ["XM430-W350", "XM430-W350", "XL430-W250"]
    fw = ServoFirmware(models, FirmwareGains(position_p=16000.0,
                                             current_limit=np.array([np.inf, 300.0, 300.0])),
                       0.002)
    fw.reset([0.0, 0.0, 0.0])
    xm, xl = servo.SERVO_MODELS["XM430-W350"], servo.SERVO_MODELS["XL430-W250"]
    w = np.array([0.5 * xm.no_load_speed_rad_s, 0.0, 0.25 * xl.no_load_speed_rad_s])
    tau = fw.torque([4000.0, 4000.0, 4000.0], [0.0, 0.0, 0.0], w)
    assert fw.pwm.tolist() == [885.0, 885.0, 885.0]
    assert tau[0] == pytest.approx(0.5 * xm.stall_torque_nm)
    assert tau[1] == pytest.approx(300 * 2.69e-3 * xm.torque_constant_nm_per_a)
    assert tau[2] == pytest.approx(0.75 * xl.stall_torque_nm)   # XL430: no current sensing
    back = fw.torque([-4000.0] * 3, [0.0] * 3, -w)
    assert back[0] == pytest.approx(-tau[0]) and back[2] == pytest.approx(-tau[2])


def test_torque_on_at_the_present_position_gives_no_torque():
    fw = ServoFirmware(["XM430-W350"] * 2, FirmwareGains(position_p=2000, position_i=500,
                                                          position_d=3000, profile_velocity=50,
                                                          profile_acceleration=10), 0.002)
    present = np.array([1234.0, 3001.0])
    fw.reset(present)
    for _ in range(10):
        assert np.all(fw.torque(present, present, np.zeros(2)) == 0.0)


def test_velocity_feedforward_adds_the_profile_velocity_per_cycle():
    fw = ServoFirmware([IDEAL], FirmwareGains(position_p=0.0, feedforward_1st=4.0,
                                              profile_velocity=100.0), 0.002)
    fw.reset([0.0])
    for _ in range(5):
        fw.torque([4000.0], [0.0], [0.0])
    v = fw.profile.velocity[0]
    assert fw.pwm[0] == pytest.approx(v * servo.FIRMWARE_CYCLE_S)


def test_unit_conversions_round_trip_and_match_the_control_table_units():
    assert servo.ticks_to_rad(3072) == pytest.approx(np.pi / 2)
    assert servo.ticks_to_rad(2048) == 0.0
    assert servo.velocity_units_to_rad_s(1) == pytest.approx(0.229 * 2 * np.pi / 60)
    assert servo.acceleration_units_to_rad_s2(1) == pytest.approx(214.577 * 2 * np.pi / 3600)
    assert servo.current_units_to_a(1000, 2.69) == pytest.approx(2.69)
    x = np.linspace(-7, 7, 11)
    np.testing.assert_allclose(servo.ticks_to_rad(servo.rad_to_ticks(x)), x)
    np.testing.assert_allclose(servo.velocity_units_to_rad_s(servo.rad_s_to_velocity_units(x)), x)
    np.testing.assert_allclose(
        servo.acceleration_units_to_rad_s2(servo.rad_s2_to_acceleration_units(x)), x)
    np.testing.assert_allclose(servo.a_to_current_units(servo.current_units_to_a(x, 2.69), 2.69),
                               x)


def test_unknown_model_and_bad_period_are_input_errors():
    with pytest.raises(InputError, match="unknown servo model 'XM430-W250'.*did you mean"):
        ServoFirmware(["XM430-W250"], FirmwareGains(), 0.002)
    with pytest.raises(InputError, match="period"):
        ServoFirmware(["XM430-W350"], FirmwareGains(), 0.0)
    with pytest.raises(InputError, match="unknown firmware register"):
        ServoFirmware(["XM430-W350"], FirmwareGains(), 0.002).set_register("kp", 1.0)


def test_joint_servos_round_goals_to_ticks_and_count_shadows():
    joints = servo.JointServos(["XM430-W350", "XM430-W350"], FirmwareGains(position_p=1000.0),
                               0.002, servos_per_joint=[1, 2])
    one_tick = 2 * np.pi / 4096
    tau = joints.torque(np.array([0.4, 0.4]) * one_tick, np.zeros(2), np.zeros(2))
    assert tau.tolist() == [0.0, 0.0]                    # under half a tick: no goal change
    tau = joints.torque(np.array([3.0, 3.0]) * one_tick, np.zeros(2), np.zeros(2))
    stall = servo.SERVO_MODELS["XM430-W350"].stall_torque_nm
    assert tau[0] == pytest.approx(3 * 1000 / 128 / 885 * stall)
    assert tau[1] == pytest.approx(2 * tau[0])


def test_a_firmware_moved_to_a_finer_period_runs_as_one_built_at_it():
    gains = {"position_p": 900.0, "position_i": 400.0, "position_d": 2500.0,
             "profile_velocity": 200.0, "profile_acceleration": 50.0}
    built = ServoFirmware([IDEAL], FirmwareGains(**gains), 0.0005)
    moved = ServoFirmware([IDEAL], FirmwareGains(**gains), 0.002)
    coarse_torque = moved.torque([2100.0], [2048.0], [0.0])  # coefficients cached at 2 ms
    moved.set_period(0.0005)
    moved.reset([2048.0])
    built.reset([2048.0])
    rng = np.random.default_rng(0)
    for _ in range(200):
        goal, present, speed = [2048 + rng.uniform(0, 80)], [2048 + rng.uniform(0, 60)], [0.1]
        assert moved.torque(goal, present, speed) == pytest.approx(
            built.torque(goal, present, speed), rel=1e-12, abs=1e-12)
    assert moved.period_s == 0.0005 and coarse_torque.shape == (1,)
    with pytest.raises(InputError, match=r"expected a firmware period in \(0, 0.1\] s, got 0.5"):
        moved.set_period(0.5)


def test_joint_servos_pass_their_period_on_and_read_the_output_shaft():
    joints = servo.JointServos(["XM430-W350"], FirmwareGains(), 0.002)
    joints.set_period(0.001)
    assert joints.firmware.period_s == 0.001
    assert joints.encoder_on_output  # a Dynamixel's encoder sits after its gear train
