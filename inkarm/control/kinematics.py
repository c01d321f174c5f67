"""Arm kinematics and rigid-body dynamics on the controller's own MuJoCo model (SI units).

The model is the controller's belief about the robot (:class:`inkarm.robots.kinematic.
KinematicModel`), never the plant's: a plant that differs from it is what a testbed is for.
"""

from __future__ import annotations

import mujoco
import numpy as np

from inkarm.errors import InputError
from inkarm.robots.kinematic import KinematicModel


def _index(addresses: list[int]) -> slice | np.ndarray:
    """A slice when the addresses are consecutive (cheaper to index with), else an array."""
    first = int(addresses[0])
    if list(addresses) == list(range(first, first + len(addresses))):
        return slice(first, first + len(addresses))
    return np.array(addresses)


class ArmKinematics:
    """Kinematics and rigid-body dynamics of an arm on the controller's own MjModel/MjData.

    Only the hinge joints named in ``joint_names`` (default: every hinge joint) are controlled;
    other joints (the pen slide) stay at their reference value. Never shares MjData with a plant.
    """

    def __init__(self, model: mujoco.MjModel, site: str, joint_names=None):
        self.model = model
        self.data = mujoco.MjData(model)
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
        if sid < 0:
            raise InputError(f"kinematic model: no site named {site!r}")
        self.site_id = sid
        if joint_names is None:
            joint_names = [
                model.joint(j).name
                for j in range(model.njnt)
                if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE
            ]
        ids = []
        for name in joint_names:
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
            if jid < 0:
                raise InputError(f"kinematic model: no joint named {name!r}")
            ids.append(jid)
        self.joint_names = tuple(joint_names)
        self.qpos_adr = _index([model.jnt_qposadr[j] for j in ids])
        self.dof_adr = _index([model.jnt_dofadr[j] for j in ids])
        self.n = len(ids)
        self.lower = model.jnt_range[ids, 0].copy()
        self.upper = model.jnt_range[ids, 1].copy()
        self._jacp = np.zeros((3, model.nv))
        self._jacr = np.zeros((3, model.nv))
        self._bias = np.zeros(model.nv)
        self._dense_mass = np.zeros((model.nv, model.nv))
        # Views into MjData and the Jacobian buffers (their memory never moves): an attribute
        # look-up on MjData builds a new array object each time, which the per-period calls
        # (bias, IK iterations) would pay for again and again.
        self._qpos = self.data.qpos
        self._qvel = self.data.qvel
        self._site_xpos = self.data.site_xpos[sid]
        self._site_xmat = self.data.site_xmat[sid].reshape(3, 3)
        # The arm's columns of the Jacobians, inertia matrix and bias: views made once when the
        # joints' dofs are consecutive (a slice), else taken (copied) at each evaluation;
        # fixed_views: then the (p, R, Jp, Jr) that every jacobian_views call fills and returns.
        self._arm_views = self.fixed_views = None
        if isinstance(self.dof_adr, slice):
            self._arm_views = self._arm_parts()
            self.fixed_views = (self._site_xpos, self._site_xmat, *self._arm_views[:2])

    def _arm_parts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The arm's (Jp, Jr, M, c) in the buffers of the whole model's dofs."""
        if self._arm_views is not None:
            return self._arm_views
        a = self.dof_adr
        return self._jacp[:, a], self._jacr[:, a], self._dense_mass[a][:, a], self._bias[a]

    def _set(self, q: np.ndarray, qd: np.ndarray | None = None) -> None:
        self._qpos[self.qpos_adr] = q
        if qd is not None:
            self._qvel[self.dof_adr] = qd

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Site position (3,) in [m] and orientation (3, 3) (columns: site axes) at ``q``."""
        self._set(q)
        mujoco.mj_kinematics(self.model, self.data)
        return (
            self.data.site_xpos[self.site_id].copy(),
            self.data.site_xmat[self.site_id].reshape(3, 3).copy(),
        )

    def jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(p, R, Jp, Jr): site pose and its translational/rotational Jacobians (3, n)."""
        return tuple(a.copy() for a in self.jacobian_views(q))

    def jacobian_views(
        self, q: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`jacobian` without the copies: views into this object's buffers, valid until
        its next evaluation (for the IK iterations, which use them at once; p and R are the
        same arrays at every call, and Jp and Jr too when the arm's dofs are consecutive)."""
        m, d = self.model, self.data
        self._qpos[self.qpos_adr] = q
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_jacSite(m, d, self._jacp, self._jacr, self.site_id)
        if self.fixed_views is not None:
            return self.fixed_views
        return (self._site_xpos, self._site_xmat, *self._arm_parts()[:2])

    def plan_terms(
        self, q: np.ndarray, qd: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(p, R, Jp, Jr, M, c): :meth:`jacobian_views`, :meth:`mass` and :meth:`bias` at
        (``q``, ``qd``) from one forward-kinematics pass (the same numbers as the three
        calls); views valid until this object's next evaluation (the planner's slow terms)."""
        m, d = self.model, self.data
        self._set(q, qd)
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_jacSite(m, d, self._jacp, self._jacr, self.site_id)
        mujoco.mj_makeM(m, d)
        mujoco.mj_fullM(m, d, self._dense_mass)
        mujoco.mj_comVel(m, d)
        mujoco.mj_rne(m, d, 0, self._bias)
        return (self._site_xpos, self._site_xmat, *self._arm_parts())

    def bias(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """Bias force c(q, qd) = C(q, qd) qd + g(q) in [N m] (n,): gravity, Coriolis and
        centrifugal terms by recursive Newton-Euler (no passive spring or damper forces)."""
        self._set(q, qd)
        m, d = self.model, self.data
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_comVel(m, d)
        mujoco.mj_rne(m, d, 0, self._bias)
        return self._arm_parts()[3]

    def mass(self, q: np.ndarray) -> np.ndarray:
        """Joint-space inertia M(q) (n, n) in [kg m^2], armature included."""
        self._set(q)
        m, d = self.model, self.data
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_makeM(m, d)
        mujoco.mj_fullM(m, d, self._dense_mass)
        return self._arm_parts()[2].copy()


    @classmethod
    def of(cls, kinematic: KinematicModel) -> ArmKinematics:
        """The kinematics of a controller's :class:`KinematicModel` (its joints and tip)."""
        return cls(kinematic.model, site=kinematic.tip_site, joint_names=kinematic.joint_names)
