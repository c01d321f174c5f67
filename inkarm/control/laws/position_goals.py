"""``position``: joint goals with feed-forward, for plants whose own loop holds them (arm drives,
servo firmware): the default law.

Each period the drive gets the shaped goal q* (plan, force-loop depth along the normal,
actuation lead), the planned velocity qd* and acceleration qdd*, and the torque feed-forward

    tau_ff = c(q*, qd*) + M(q*) qdd* + F_hat tanh(qd* / w) [+ J(q*)^T f while pressing]

with the bias and inertia terms of the plan row, and the Coulomb friction estimate F_hat
adapted online from the joint error of the row the reading belongs to
(:class:`inkarm.control.friction.FrictionCompensation`). A safe stop sends the lift goal with
zero velocity and the bias c(q*, 0) only.

Past the safe stop, the feed-forward's arithmetic runs in one C call where the extension is
built (:mod:`inkarm.control.compiled`; the same bits, ``INKARM_COMPILED=0`` switches it off);
a reading or goal that is not float64 arrays of the arm's length turns the law to Python.
"""

from __future__ import annotations

import numpy as np

from inkarm.control.compiled import position_law
from inkarm.control.friction import FrictionCompensation
from inkarm.control.laws import LawContext, Setpoint
from inkarm.core.plant import PlantState, PositionCommand


class PositionGoals:
    """Position goals with feed-forward (module docstring).

    Args:
        friction_adaptation: Rate gamma of the Coulomb estimate's adaptation [N m/(rad s)];
            None: the ``[controller]`` table's ``friction_adaptation``; 0: the model's
            friction, fixed.
    """

    commands = frozenset({"position"})

    def __init__(self, friction_adaptation: float | None = None):
        if friction_adaptation is not None and not (0.0 <= friction_adaptation < 1e9):
            raise ValueError(f"friction_adaptation: expected a rate in [0, 1e9) N m/(rad s), "
                             f"got {friction_adaptation}")
        self.friction_adaptation = friction_adaptation

    def start(self, context: LawContext) -> None:
        plan, kin = context.plan, context.kinematics
        gamma = (context.config.friction_adaptation if self.friction_adaptation is None
                 else self.friction_adaptation)
        self.friction = FrictionCompensation(kin.model.dof_frictionloss[kin.dof_adr],
                                             context.dt, gamma)
        self.adapt = bool(self.friction.rate)
        # What depends on the plan row only, for all rows at once (the same bits as row by row).
        self.direction = FrictionCompensation.direction(plan.qd)
        self.planned_torque = plan.bias + plan.inertia
        self.contact_tau, self.q_ref, self.normal_q = plan.contact_tau, plan.q, plan.normal_q
        self.last_row = len(plan) - 1
        self.bias = kin.bias
        compiled = position_law() if len(plan) else None
        self.compiled = None if compiled is None else compiled(
            *(np.ascontiguousarray(a, dtype=float) for a in (
                self.planned_torque, self.direction, self.contact_tau, self.q_ref,
                self.normal_q)),
            self.friction.estimate, self.friction.ceiling, self.friction.rate)

    def command(self, state: PlantState, setpoint: Setpoint) -> PositionCommand:
        c, q, qd, qdd, q_row, pressing, depth, seen, blend, stopping = setpoint
        if stopping:
            return PositionCommand(q, qd, qdd, self.bias(q, qd).copy())
        if self.compiled is not None:  # (it checks every argument before it writes)
            feedforward = np.empty(len(self.friction.estimate))
            try:
                self.compiled.command(feedforward, q_row, state.q, c, seen, depth, blend, pressing)
            except (TypeError, ValueError):  # (not float64 arrays of the arm's length)
                self.compiled = None  # (Python from now on: it replaces the estimate's array)
            else:
                return PositionCommand(q, qd, qdd, feedforward)
        error = None
        if self.adapt:  # the joint error of the row the reading belongs to
            q_ref = self.q_ref
            q_then = q_row if seen == c else q_ref[seen] + depth * self.normal_q[seen]
            if blend:
                q_then = q_then + blend * (q_ref[min(seen + 1, self.last_row)] - q_ref[seen])
            error = q_then - state.q
        feedforward = self.planned_torque[c] + self.friction.torque(self.direction[c], error)
        if pressing:
            feedforward += self.contact_tau[c]
        return PositionCommand(q, qd, qdd, feedforward)


__all__ = ["PositionGoals"]
