"""``impedance``: a Cartesian impedance at the pen, sending torques, as torque-controlled arms
(the iiwa's own Cartesian impedance mode, Franka's example controllers) do it.

Each period, with the measured q, qd [rad, rad/s] and the shaped goal q* (plan, force-loop depth
along the paper normal, actuation lead) on the controller's kinematic model:

    x, R   = fk(q)          pen tip [m] and site axes (x_s, y_s, z_s: z_s along the pen)
    x*, a* = fk(q*)         the goal's tip [m] and pen axis (its z_s)
    e      = [x* - x ;  -y_s . a* ;  x_s . a*]              5-D pen error [m, m, m, rad, rad]
    J      = [Jp ; x_s^T Jr ; y_s^T Jr](q)                  5 x n pen Jacobian [m/rad, rad/rad]
    v      = J(q) qd,   v* = J(q*) qd*                      [m/s, rad/s]
    w      = K e + D (v* - v) + f_c                         wrench at the pen [N, N m]
    tau    = J(q)^T w + N^T [K_0 (q* - q) + D_0 (qd* - qd)]
             + c(q, qd) + M(q*) qdd* + F_c tanh(qd* / w_0)  [N m], clipped to the torque limits

* K = diag(R_p diag(k, k, k_n) R_p^T, k_t I_2), D = diag(R_p diag(d, d, d_n) R_p^T, d_t I_2):
  stiffness k and damping d in the page plane, k_n and d_n along the paper normal (R_p: the
  page's axes in the robot frame, ``model.placement``), k_t and d_t against the pen's tilt (the
  pen's roll about its own axis is left to the posture term).
* x* comes from fk(q*), not from the plan's page path: q* already carries the force loop's depth
  along the normal (``setpoint.depth`` through ``plan.normal_q``), the paper's surface estimate
  and the actuation lead, so the normal stiffness k_n acts on the depth-shaped reference and the
  executor's force loop (dz/dt = k_F (F* - F)) works unchanged: at equilibrium the normal spring
  is relaxed and the feed-forward f_c carries the set-point force. (The page path through
  ``placement.to_robot`` would lose the depth correction, and between knots of the joint-space
  approach and home moves it is only interpolated.)
* f_c = F* (mu u - n) while ``setpoint.pressing``, else 0: the set-point force F*
  (``config.force_n`` [N]) into the paper along -n, and the nib's Coulomb drag mu F* along the
  planned direction of motion u (smoothed below 5 mm/s), as the plan's contact feed-forward.
* N^T = I - J^T (J J^T + lambda^2 I)^-1 J: the posture term toward the plan's q* acts only in
  the null space of the pen task (for a 7-joint arm: the elbow's swivel and the pen's roll).
* c(q, qd): gravity, Coriolis and centrifugal forces at the measured state; M(q*) qdd*: the
  plan's inertial feed-forward; F_c tanh(qd*/w_0): the model's Coulomb friction in the planned
  direction of motion (``friction_feedforward``; w_0 = 0.01 rad/s).

While stopping (after a fault) the goal is the lift pose, qd* = qdd* = 0 and f_c = 0.

Units: settings in newtons and millimetres (converted once, at construction: k [N/mm] = 1000 k
[N/m], d [N s/mm] = 1000 d [N s/m]); SI inside.

Default gains, for the default letter on the iiwa 14 at its 6 ms control period (pen mass about
6..17 kg in translation, 0.8 kg m^2 in tilt; the wrist's joints 0.05..0.12 kg m^2):
k = 50 N/mm, k_n = 30 N/mm, d = 0.1 N s/mm, d_n = 0.5 N s/mm, k_t = 400 N m/rad,
d_t = 5 N m s/rad, k_0 = 20 N m/rad, d_0 = 1 N m s/rad. Chosen on the linearised sampled loop
(torques held for a period, the force loop's integrator k_F = 100 mm/(N s) in contact), checked
in simulation: the Cartesian damping reaches the light wrist joints through J^T D J, and in
the page plane 0.2 N s/mm (at k = 50 N/mm) drives a wrist mode unstable at 6 ms; along the
normal about 0.3 N s/mm or more is needed, or the arm's spring mode and the force loop oscillate
(the pen leaves the paper). Stiffness margin: about 1.35x (unstable near
k = 70 N/mm with the other gains scaled alike), plants down to about 0.75x the model's masses.
The default letter on the exact twin: tracking RMS 0.031 mm, ink chamfer 0.054 mm, no gap, force
0.960..1.031 N; masses +-20 % (centres of mass 20 mm off): 0.21 / 0.17 mm RMS; Coulomb friction
5/5/3/3/2/1/1 N m: 0.27 mm. What a host loop at 6 ms cannot take: 2 ms sensing + 2 ms actuation
delay, series elasticity, encoder noise of 1e-4 rad with velocity from differences (the
drive-side ``position`` law, at the physics step, can). A lighter arm (the wx250s: about 1 kg
at the pen) needs gains about ten times smaller.
"""

from __future__ import annotations

import math

import numpy as np

from inkarm.control.friction import FrictionCompensation
from inkarm.control.ik import pen_error, pen_jacobian
from inkarm.control.laws import LawContext, Setpoint
from inkarm.control.reference import DRAG_SPEED_MM_S
from inkarm.core.log import DRAW
from inkarm.core.plant import PlantState, TorqueCommand
from inkarm.errors import InputError

# Plausible ranges of the settings: (low, high, unit, whether 0 itself is refused).
SETTINGS = {
    "stiffness_n_per_mm": (0.0, 1e3, "N/mm", True),
    "normal_stiffness_n_per_mm": (0.0, 1e3, "N/mm", True),
    "damping_n_s_per_mm": (0.0, 1e2, "N s/mm", False),
    "normal_damping_n_s_per_mm": (0.0, 1e2, "N s/mm", False),
    "tilt_stiffness_nm_per_rad": (0.0, 1e5, "N m/rad", False),
    "tilt_damping_nm_s_per_rad": (0.0, 1e4, "N m s/rad", False),
    "posture_stiffness_nm_per_rad": (0.0, 1e5, "N m/rad", False),
    "posture_damping_nm_s_per_rad": (0.0, 1e4, "N m s/rad", False),
}
# Damping of the null-space projector's solve (as the IK's): keeps it finite at singularities.
PROJECTOR_DAMPING = 1e-3


def _checked(name: str, value) -> float:
    """``value`` as a float within the range of setting ``name``; InputError (key ``name``)
    otherwise."""
    low, high, unit, open_low = SETTINGS[name]
    interval = f"{'(' if open_low else '['}{low:g}, {high:g}] {unit}"
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(f"expected a number in {interval}, got {value!r}", key=name,
                         value=value)
    v = float(value)
    if not (math.isfinite(v) and (v > low if open_low else v >= low) and v <= high):
        raise InputError(f"expected a number in {interval}, got {value!r}", key=name,
                         value=value)
    return v


class Impedance:
    """Cartesian impedance at the pen, sending torques (module docstring).

    Args:
        stiffness_n_per_mm: k, in the page plane [N/mm].
        normal_stiffness_n_per_mm: k_n, along the paper normal [N/mm].
        damping_n_s_per_mm: d, in the page plane [N s/mm].
        normal_damping_n_s_per_mm: d_n, along the paper normal [N s/mm].
        tilt_stiffness_nm_per_rad: k_t, against the pen's tilt from its planned axis [N m/rad].
        tilt_damping_nm_s_per_rad: d_t [N m s/rad].
        posture_stiffness_nm_per_rad: K_0 = k_0 I, toward the plan's q in the null space of the
            pen task [N m/rad].
        posture_damping_nm_s_per_rad: D_0 = d_0 I [N m s/rad].
        friction_feedforward: Add the model's Coulomb friction in the planned direction.
    """

    commands = frozenset({"torque"})

    def __init__(self, stiffness_n_per_mm: float = 50.0, normal_stiffness_n_per_mm: float = 30.0,
                 damping_n_s_per_mm: float = 0.1, normal_damping_n_s_per_mm: float = 0.5,
                 tilt_stiffness_nm_per_rad: float = 400.0,
                 tilt_damping_nm_s_per_rad: float = 5.0,
                 posture_stiffness_nm_per_rad: float = 20.0,
                 posture_damping_nm_s_per_rad: float = 1.0,
                 friction_feedforward: bool = True):
        given = dict(locals())
        for name in SETTINGS:
            setattr(self, name, _checked(name, given[name]))
        if not isinstance(friction_feedforward, bool):
            raise InputError(f"expected true or false, got {friction_feedforward!r}",
                             key="friction_feedforward", value=friction_feedforward)
        self.friction_feedforward = friction_feedforward

    def start(self, context: LawContext) -> None:
        plan, kin, model = context.plan, context.kinematics, context.model
        rot = model.placement.rotation  # page axes in the robot frame (columns)
        k = 1000.0 * np.array([self.stiffness_n_per_mm] * 2 + [self.normal_stiffness_n_per_mm])
        d = 1000.0 * np.array([self.damping_n_s_per_mm] * 2 + [self.normal_damping_n_s_per_mm])
        self.K = np.zeros((5, 5))
        self.D = np.zeros((5, 5))
        self.K[:3, :3] = rot @ np.diag(k) @ rot.T  # [N/m]
        self.D[:3, :3] = rot @ np.diag(d) @ rot.T  # [N s/m]
        self.K[3:, 3:] = self.tilt_stiffness_nm_per_rad * np.eye(2)
        self.D[3:, 3:] = self.tilt_damping_nm_s_per_rad * np.eye(2)
        self.k0, self.d0 = self.posture_stiffness_nm_per_rad, self.posture_damping_nm_s_per_rad
        self.kin = kin
        self.torque_limit = np.asarray(context.gains.torque_limit, dtype=float)
        self.inertia = plan.inertia
        # The contact feed-forward f_c = F* (mu u - n) per plan row [N], robot frame (as the
        # plan's contact_tau, before J^T): u from the planned page velocity while drawing.
        config, placement = context.config, model.placement
        mu = config.nib_friction if config.nib_friction is not None else model.nib_friction
        velocity = np.gradient(plan.page_mm[:, :2], context.dt, axis=0) if len(plan) > 1 \
            else np.zeros((len(plan), 2))
        velocity = velocity @ rot[:, :2].T  # [mm/s], robot frame
        speed = np.linalg.norm(velocity, axis=1, keepdims=True)
        sliding = velocity / np.sqrt(speed**2 + DRAG_SPEED_MM_S**2)
        sliding[plan.phase != DRAW] = 0.0
        self.contact_force = config.force_n * (mu * sliding - placement.normal)
        friction = kin.model.dof_frictionloss[kin.dof_adr] if self.friction_feedforward \
            else np.zeros(kin.n)
        self.friction = friction * FrictionCompensation.direction(plan.qd)  # [N m] per row
        self._eye5 = PROJECTOR_DAMPING**2 * np.eye(5)

    def command(self, state: PlantState, setpoint: Setpoint) -> TorqueCommand:
        kin = self.kin
        q, qd = np.asarray(state.q, dtype=float), np.asarray(state.qd, dtype=float)
        q_goal, qd_goal = setpoint.q, setpoint.qd
        # The goal's pen pose (and velocity, while moving), then the measured one's.
        p_goal, R_goal, Jp_goal, Jr_goal = kin.jacobian_views(q_goal)
        p_goal, axis_goal = p_goal.copy(), R_goal[:, 2].copy()
        moving = not setpoint.stopping and bool(np.any(qd_goal))
        v_goal = pen_jacobian(R_goal, Jp_goal, Jr_goal) @ qd_goal if moving else np.zeros(5)
        p, R, Jp, Jr = kin.jacobian_views(q)
        J = pen_jacobian(R, Jp, Jr)
        e = pen_error(p, R, p_goal, axis_goal)
        wrench = self.K @ e + self.D @ (v_goal - J @ qd)
        if setpoint.pressing and not setpoint.stopping:
            wrench[:3] += self.contact_force[setpoint.row]
        tau = J.T @ wrench
        if self.k0 or self.d0:  # posture, projected into the null space of the pen task
            posture = self.k0 * (q_goal - q) + self.d0 * (qd_goal - qd)
            tau += posture - J.T @ np.linalg.solve(J @ J.T + self._eye5, J @ posture)
        tau += kin.bias(q, qd)
        if not setpoint.stopping:
            tau += self.inertia[setpoint.row]
            tau += self.friction[setpoint.row]
        return TorqueCommand(np.clip(tau, -self.torque_limit, self.torque_limit))


__all__ = ["SETTINGS", "Impedance"]
