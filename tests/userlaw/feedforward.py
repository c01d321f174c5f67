"""Joint goals with a feed-forward torque: a user's own control law."""

import numpy as np

from inkarm.core.plant import PositionCommand


class FeedForward:
    """The shaped joint goal for the plant's own position loop (arm drives, servo firmware),
    with a feed-forward torque: gravity at the goal (times ``gravity_scale``), the planned
    acceleration's M(q) qdd, and the planned contact force while the pen presses."""

    commands = frozenset({"position"})  # what it sends: "position" and/or "torque"

    def __init__(self, gravity_scale: float = 1.0):
        if not 0.0 <= gravity_scale <= 2.0:
            raise ValueError(f"gravity_scale: expected a number in [0, 2], got {gravity_scale}")
        self.gravity_scale = gravity_scale

    def start(self, context):
        """Once, before the first period: the plan and the controller's own model."""
        self.bias = context.kinematics.bias  # c(q, qd): gravity and velocity torques [N m]
        self.at_rest = np.zeros(context.kinematics.n)
        self.inertia = context.plan.inertia  # M(q) qdd per plan row [N m]
        self.contact = context.plan.contact_tau  # J^T f per plan row [N m]

    def command(self, state, setpoint):
        """Every period: the plant's reading and the shaped reference -> one command."""
        torque = self.gravity_scale * self.bias(setpoint.q, self.at_rest)
        if not setpoint.stopping:  # (a safe stop after a fault: lift and hold)
            torque = torque + self.inertia[setpoint.row]
            if setpoint.pressing:
                torque = torque + self.contact[setpoint.row]
        return PositionCommand(setpoint.q, setpoint.qd, setpoint.qdd, torque)
