"""``joint_pid``: the host closes the joint loop and sends torques (seed 001, sec. 4).

    tau = PID(q* - q, qd* - qd) + c(q, qd) + M(q*) qdd* [+ J(q*)^T f while pressing]

The joint PID (:class:`inkarm.control.pid.JointPID`: derivative on measurement, conditional
anti-windup, torque saturation) acts on the measured q, qd against the shaped goal q*; the
gravity and Coriolis compensation c(q, qd) is evaluated at the *measured* state on the
controller's kinematic model; the inertial feed-forward M(q*) qdd* and, while pressing, the
planned contact force J(q*)^T f come from the plan. The measured force is not fed forward:
with one period of delay, cancelling it exactly is a positive feedback on the contact.
For plants that take torques (simulated arms, servos in current mode).
"""

from __future__ import annotations

from inkarm.control.laws import LawContext, Setpoint
from inkarm.control.pid import JointPID
from inkarm.core.plant import PlantState, TorqueCommand


class JointPIDLaw:
    """Joint PID with the profile's gains, sending torques (module docstring)."""

    commands = frozenset({"torque"})

    def start(self, context: LawContext) -> None:
        plan = context.plan
        self.pid = JointPID(context.gains, context.dt)
        self.bias = context.kinematics.bias
        self.inertia, self.contact_tau = plan.inertia, plan.contact_tau

    def command(self, state: PlantState, setpoint: Setpoint) -> TorqueCommand:
        q, qd = state.q, state.qd
        feedforward = self.bias(q, qd)
        if not setpoint.stopping:
            feedforward = feedforward + self.inertia[setpoint.row]
            if setpoint.pressing:
                feedforward += self.contact_tau[setpoint.row]
        return TorqueCommand(self.pid.update(setpoint.q, q, qd, setpoint.qd, feedforward))


__all__ = ["JointPIDLaw"]
