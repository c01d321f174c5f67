"""Stiction: a joint at rest holds a larger torque than the friction that drags it once it
slides (the plant truth's ``stiction_nm`` above its Coulomb friction).

MuJoCo's dry joint friction (``dof_frictionloss`` F) is a soft constraint on the joint's speed:
its force is

    f = -clamp(B v / R, -F, F)        (steady state: the constraint's acceleration is 0)

with R the constraint's regulariser (from its ``solimp`` and the joint's inverse inertia) and B
its reference damping (from ``solref``): below the speed v_F = R F / B it holds the joint (a
stiff viscous stick: a torque tau < F lets it creep at R tau / B), above it drags it with F. A
single F is therefore stiction = Coulomb. :class:`Stiction` gives each joint two levels,
switched per physics step on the joint's own speed (a Karnopp friction model):

    F = C + S   while the joint is stuck,     F = C   while it slides

(C: the model's Coulomb friction, S: ``stiction_nm``). The state changes

    stuck -> sliding   when |v| >= v_s and |v| > |v_prev|: the joint speeds up out of the
                       window, which the constraint allows only once the torque on it exceeds
                       C + S (below, it creeps at R tau / B < v_s and any faster motion decays);
    sliding -> stuck   when |v| < v_s, or v v_prev <= 0 (it stopped or reversed within the
                       step: a reversal jumps over a narrow window in one step, h = 2 ms).

The window is v_s = ``STUCK_SPEED_FACTOR`` R (C + S) / B per joint: the speed up to which the
C + S constraint holds, times 1.5, so that a stuck joint creeping under a torque just below
C + S never counts as sliding (the breakaway would come early, at C). It is the speed scale of
MuJoCo's own regularisation of Coulomb friction (0.006 to 0.08 rad/s on the iiwa14 with the
issue's C + S = [8.5, 8.5, 5.5, 5.5, 4, 2.5, 2.5] N m): below it MuJoCo's friction is a holding
damper in any case, so the window adds no stickiness the friction model did not have, only the
breakaway level. Within it the friction rises from C to C + S as the speed falls, a Stribeck
curve with a Stribeck speed of that order, as harmonic-drive joints have.

The level chosen from the speeds of states k - 1 and k acts on the step from state k + 1 (it is
set after the step that reached state k, whose constraints MuJoCo has built already): the switch
lags one physics step (2 ms), the same in a single plant and in a batch. A joint starts stuck
when it starts within its window. Cost: a plant's step with stiction takes about 1.15 times
its step without (one Python loop over the joints; the level is written only when a joint
changes state); without stiction nothing runs. Units: SI (rad/s, N m).
"""

from __future__ import annotations

import mujoco
import numpy as np

STUCK_SPEED_FACTOR = 1.5


class Stiction:
    """The friction levels of the joints of one plant (arrays (n,)) or of a batch of plants
    (arrays (N, n)), switched between stuck and sliding.

    Args:
        coulomb: C, the sliding friction [N m].
        stiction: S, the breakaway torque above C [N m].
        window: v_s, the speed below which a joint counts as stuck [rad/s]
            (:func:`stuck_window`).
        qd: The joints' initial speeds [rad/s].
    """

    def __init__(self, coulomb: np.ndarray, stiction: np.ndarray, window: np.ndarray,
                 qd: np.ndarray):
        self.coulomb = np.asarray(coulomb, dtype=float)
        self.stiction = np.asarray(stiction, dtype=float)
        self.window = np.asarray(window, dtype=float)
        self.qd_prev = np.array(qd, dtype=float)
        self.speed_prev = np.abs(self.qd_prev)
        self.stuck = self.speed_prev < self.window
        # (one plant's state as Python lists: see :meth:`step`)
        self._rows = list(zip(self.window.ravel().tolist(), self.stuck.ravel().tolist()))
        self._prev = self.qd_prev.ravel().tolist()

    def frictionloss(self) -> np.ndarray:
        """F per joint [N m]: C + S where stuck, C where sliding."""
        return self.coulomb + self.stiction * self.stuck

    def update(self, qd: np.ndarray) -> np.ndarray:
        """Take the joints' speeds ``qd`` [rad/s] after a physics step; return where a joint
        changed state (bool, the shape of ``qd``; :meth:`frictionloss` gives the new F).

        stuck' = (|v| < v_s) | (|v| <= |v_prev| where stuck, v v_prev <= 0 where sliding)."""
        speed = np.abs(qd)
        stuck = np.where(self.stuck, speed <= self.speed_prev, qd * self.qd_prev <= 0.0)
        stuck |= speed < self.window
        changed = stuck != self.stuck
        self.stuck, self.qd_prev, self.speed_prev = stuck, qd.copy(), speed
        return changed

    def step(self, qd: list[float]) -> bool:
        """:meth:`update` for one plant (arrays (n,)) on Python floats, the same comparisons
        of the same numbers (a loop over a few joints costs a third of the array calls); True
        when a joint changed state. Use one of the two on a Stiction, not both."""
        rows, changed = self._rows, False
        for j, (v, p) in enumerate(zip(qd, self._prev)):
            window, stuck = rows[j]
            speed = abs(v)
            now = speed < window or (speed <= abs(p) if stuck else v * p <= 0.0)
            if now is not stuck:
                rows[j] = (window, now)
                changed = True
        self._prev = qd
        if changed:
            self.stuck = np.array([stuck for _, stuck in rows])
        return changed


def stuck_window(model: mujoco.MjModel, dofs: np.ndarray, holding: np.ndarray) -> np.ndarray:
    """v_s [rad/s] of the dofs ``dofs`` when they hold ``holding`` = C + S [N m]:
    ``STUCK_SPEED_FACTOR`` R F / B of their friction constraints, read from MuJoCo (a forward
    pass on scratch data with F = ``holding``; R and B do not depend on the pose). 0 where
    ``holding`` is 0 (no constraint)."""
    saved = model.dof_frictionloss[dofs].copy()
    model.dof_frictionloss[dofs] = holding
    try:
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
    finally:
        model.dof_frictionloss[dofs] = saved
    rows = np.flatnonzero(data.efc_type[:data.nefc] == mujoco.mjtConstraint.mjCNSTR_FRICTION_DOF)
    ids = data.efc_id[rows]
    held = np.zeros(model.nv)
    held[dofs] = holding
    speed = np.zeros(model.nv)
    speed[ids] = data.efc_R[rows] * held[ids] / data.efc_KBIP[rows, 1]
    return STUCK_SPEED_FACTOR * speed[dofs]


__all__ = ["STUCK_SPEED_FACTOR", "Stiction", "stuck_window"]
