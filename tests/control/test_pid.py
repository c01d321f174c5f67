"""Joint PID: the control law term by term, saturation, derivative on measurement, and
anti-windup on a 1-DOF MuJoCo pendulum with a weak motor."""

import mujoco
import numpy as np
import pytest

from inkarm.control.pid import JointPID, PIDGains
from inkarm.errors import InputError

PENDULUM = """
<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <body>
      <joint name="hinge" type="hinge" axis="0 1 0" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="1"/>
    </body>
  </worldbody>
  <actuator><motor joint="hinge" ctrlrange="-4 4"/></actuator>
</mujoco>
"""


def gains(kp=10.0, ki=0.0, kd=0.0, limit=100.0, ilimit=100.0):
    return PIDGains(kp=[kp], ki=[ki], kd=[kd], torque_limit=[limit], integral_limit=[ilimit])


def one(x):
    return np.array([x], dtype=float)


def test_proportional_and_derivative_terms():
    pid = JointPID(gains(kp=10.0, kd=2.0), dt=0.01)
    tau = pid.update(one(1.0), one(0.25), qd=one(0.5), qd_ref=one(1.5))
    assert tau[0] == pytest.approx(10.0 * 0.75 + 2.0 * (1.5 - 0.5))


def test_integral_accumulates_error_times_dt_then_acts():
    pid = JointPID(gains(kp=0.0, ki=4.0), dt=0.01)
    first = pid.update(one(1.0), one(0.0), one(0.0))
    second = pid.update(one(1.0), one(0.0), one(0.0))
    assert first[0] == 0.0  # the integrator acts from the next period on
    assert second[0] == pytest.approx(4.0 * 1.0 * 0.01)


def test_output_saturates_at_the_torque_limit():
    pid = JointPID(gains(kp=1000.0, limit=5.0), dt=0.01)
    assert pid.update(one(1.0), one(0.0), one(0.0))[0] == 5.0
    assert pid.update(one(-1.0), one(0.0), one(0.0))[0] == -5.0


def test_derivative_acts_on_the_measurement_so_a_set_point_step_gives_no_kick():
    pid = JointPID(gains(kp=10.0, kd=50.0), dt=0.001)
    before = pid.update(one(0.0), one(0.0), one(0.0))
    after = pid.update(one(1.0), one(0.0), one(0.0))  # set point jumps, plant at rest
    assert after[0] - before[0] == pytest.approx(10.0)  # the proportional step only


def test_feedforward_is_added_before_saturation():
    pid = JointPID(gains(kp=1.0, limit=3.0), dt=0.01)
    assert pid.update(one(1.0), one(0.0), one(0.0), feedforward=one(1.5))[0] == pytest.approx(2.5)
    assert pid.update(one(1.0), one(0.0), one(0.0), feedforward=one(10.0))[0] == 3.0


def test_integrator_is_frozen_while_saturated_and_bounded_otherwise():
    pid = JointPID(gains(kp=100.0, ki=50.0, limit=5.0, ilimit=2.0), dt=0.01)
    for _ in range(500):
        pid.update(one(1.0), one(0.0), one(0.0))  # saturated the whole time
    assert pid.integral[0] == 0.0
    pid = JointPID(gains(kp=0.0, ki=50.0, limit=5.0, ilimit=2.0), dt=0.01)
    for _ in range(500):
        pid.update(one(1.0), one(0.0), one(0.0))  # never saturated: clamped by integral_limit
    assert pid.integral[0] == pytest.approx(2.0)


def test_an_output_exactly_at_the_limit_is_not_saturated():
    # 5.0 is reachable but not exceeded: the integrator keeps integrating; just above it the
    # error pushes the saturated output further and the integrator freezes.
    pid = JointPID(gains(kp=5.0, ki=10.0, limit=5.0), dt=0.01)
    assert pid.update(one(1.0), one(0.0), one(0.0))[0] == 5.0
    assert pid.integral[0] == pytest.approx(0.1)
    pid = JointPID(gains(kp=5.0 + 1e-12, ki=10.0, limit=5.0), dt=0.01)
    assert pid.update(one(1.0), one(0.0), one(0.0))[0] == 5.0
    assert pid.integral[0] == 0.0


def test_only_the_saturated_joint_freezes():
    pid = JointPID(
        PIDGains(kp=[100.0, 1.0], ki=[10.0, 10.0], kd=0.0, torque_limit=5.0, integral_limit=9.0),
        dt=0.01,
    )
    tau = pid.update(np.ones(2), np.zeros(2), np.zeros(2))
    np.testing.assert_array_equal(tau, [5.0, 1.0])
    np.testing.assert_allclose(pid.integral, [0.0, 0.1])


def test_reset_empties_the_integrator():
    pid = JointPID(gains(ki=10.0), dt=0.01)
    pid.update(one(1.0), one(0.0), one(0.0))
    pid.reset()
    assert pid.integral[0] == 0.0


def simulate(pid: JointPID, target: float, steps: int, model, data, gravity_comp: bool) -> list:
    history = []
    for _ in range(steps):
        mujoco.mj_forward(model, data)
        feedforward = data.qfrc_bias.copy() if gravity_comp else None
        data.ctrl[:] = pid.update(
            one(target), data.qpos.copy(), data.qvel.copy(), feedforward=feedforward
        )
        mujoco.mj_step(model, data)
        history.append(float(data.qpos[0]))
    return history


def test_gravity_compensated_pid_holds_a_horizontal_pendulum():
    model = mujoco.MjModel.from_xml_string(PENDULUM)
    data = mujoco.MjData(model)
    pid = JointPID(gains(kp=40.0, ki=200.0, kd=2.0, limit=4.0, ilimit=2.0), model.opt.timestep)
    history = simulate(pid, 0.3, 1500, model, data, gravity_comp=True)
    assert history[-1] == pytest.approx(0.3, abs=1e-3)


def test_anti_windup_recovers_faster_than_a_naive_integrator():
    """A target the weak motor cannot reach, then a reachable one: the anti-windup controller
    overshoots the second far less than one whose integrator wound up."""
    model = mujoco.MjModel.from_xml_string(PENDULUM)

    class Naive(JointPID):
        def update(self, q_ref, q, qd, qd_ref=None, feedforward=None):
            g = self.gains
            error = q_ref - q
            tau = g.kp * error + self.integral - g.kd * qd
            self.integral = self.integral + g.ki * self.dt * error  # no limit, no freeze
            return np.clip(tau, -g.torque_limit, g.torque_limit)

    overshoot = {}
    for name, cls in [("anti-windup", JointPID), ("naive", Naive)]:
        data = mujoco.MjData(model)
        pid = cls(gains(kp=40.0, ki=40.0, kd=2.0, limit=2.0, ilimit=2.0), model.opt.timestep)
        simulate(pid, 1.5, 1000, model, data, gravity_comp=False)  # hangs short of it
        history = simulate(pid, -1.0, 1500, model, data, gravity_comp=False)
        overshoot[name] = -1.0 - min(history)
    assert overshoot["anti-windup"] < 0.1
    assert overshoot["naive"] > 3 * max(overshoot["anti-windup"], 0.05)


def test_scaled_gains():
    g = gains(kp=2.0, ki=3.0, kd=4.0).scaled(2.0)
    assert (g.kp[0], g.ki[0], g.kd[0], g.torque_limit[0]) == (4.0, 6.0, 8.0, 100.0)


def test_scalar_gains_broadcast():
    g = PIDGains(kp=[1.0, 2.0, 3.0], ki=0.0, kd=0.5, torque_limit=10.0, integral_limit=1.0)
    assert g.ki.shape == (3,) and g.torque_limit.tolist() == [10.0] * 3


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"kp": [1.0, 2.0], "ki": [1.0, 2.0, 3.0]}, r"PIDGains.ki: has 3 entries, expected 2"),
        ({"torque_limit": [0.0, 1.0]}, r"PIDGains.torque_limit: must be > 0"),
        ({"integral_limit": [-1.0, 1.0]}, r"PIDGains.integral_limit: must be >= 0"),
        ({"kd": [np.nan, 1.0]}, r"PIDGains.kd: NaN or inf"),
    ],
)
def test_bad_gains_are_refused(kwargs, message):
    base = {
        "kp": [1.0, 2.0],
        "ki": [0.0, 0.0],
        "kd": [0.1, 0.1],
        "torque_limit": [5.0, 5.0],
        "integral_limit": [1.0, 1.0],
    }
    base.update(kwargs)
    with pytest.raises(InputError, match=message):
        PIDGains(**base)


def test_bad_period_is_refused():
    with pytest.raises(
        InputError, match="JointPID: dt must be a positive number of seconds, got 0"
    ):
        JointPID(gains(), 0)
