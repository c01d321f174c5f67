"""Geometric errors of an arm and its pen, and how they change a compiled MuJoCo model.

:class:`GeometryErrors` describes how a real arm differs from its drawing: links longer or
shorter, joints whose zero is off, a pen tip that is not where the holder's axis and the pen's
length put it. :func:`apply_geometry` edits a compiled model in place. The simulated plant's
truth (:mod:`inkarm.sim.perturb`) and the controller's calibrated belief
(:func:`inkarm.sim.cell.kinematic_model`) both go through it, so a fitted correction equal to
the truth gives the truth's kinematics.

The edits, per joint ``i`` with body ``b`` (the body the joint moves), in the parent's frame:

- link length ``dl_i`` [mm] (i > 0): ``body_pos[b] <- p (1 + dl_i / 1000 / |p|)``: the offset
  ``p`` from the previous body gets longer along its own direction;
- joint offset ``d_i`` [deg]: the body turned by ``d_i`` about the joint's axis ``a`` through
  the joint's anchor ``c`` (body frame), so that the link sits at ``q + d_i`` when the joint
  reads ``q``: ``quat[b] <- quat[b] * quat(a, d_i)``, ``pos[b] <- pos[b] + R_b (c - R(a, d_i) c)``;
- tip offset ``t`` [mm] (flange frame, z along the pen): the tip site and the tip geom (and
  only they) moved by ``t / 1000`` in the pen body's frame, which is the flange frame.

Then ``mj_setConst``. Lengths in [mm] and angles in [deg] here; SI in the model.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from inkarm.errors import InputError

if TYPE_CHECKING:  # MuJoCo is imported where a model is changed: a scenario that only names
    import mujoco  # errors (a plotter's run) never loads it


@dataclass(frozen=True)
class GeometryErrors:
    """How the real arm and pen differ from the model. Defaults: no difference.

    Attributes:
        link_length_mm: Per joint i > 0: change of the length of the link from joint i - 1 to
            joint i (the offset of joint i's body from its parent), along its current direction
            [mm]; index 0 unused and must be 0; () = none.
        joint_offset_deg: Per joint: the link sits at q + offset when the controller believes q
            [deg]; () = none.
        tip_offset_mm: The real pen tip minus the believed one, in the flange frame, z along the
            pen [mm].
    """

    link_length_mm: tuple[float, ...] = ()
    joint_offset_deg: tuple[float, ...] = ()
    tip_offset_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        for name in ("link_length_mm", "joint_offset_deg", "tip_offset_mm"):
            value = getattr(self, name)
            try:
                values = tuple(float(v) for v in np.asarray(value, dtype=float).reshape(-1))
            except (TypeError, ValueError):
                raise InputError(f"expected numbers, got {value!r}", key=name,
                                 value=value) from None
            if not all(math.isfinite(v) for v in values):
                raise InputError(f"expected finite numbers, got {values}", key=name, value=value)
            object.__setattr__(self, name, values)
        if len(self.tip_offset_mm) != 3:
            raise InputError(f"expected 3 numbers (x, y, z in the flange frame) [mm], got "
                             f"{len(self.tip_offset_mm)}", key="tip_offset_mm",
                             value=self.tip_offset_mm)
        if self.link_length_mm and self.link_length_mm[0] != 0.0:
            raise InputError(f"expected 0 first (no link before joint 0), got "
                             f"{self.link_length_mm[0]}", key="link_length_mm",
                             value=self.link_length_mm)

    @property
    def is_zero(self) -> bool:
        """True when the arm and pen are as modelled."""
        return not (any(self.link_length_mm) or any(self.joint_offset_deg)
                    or any(self.tip_offset_mm))


def apply_geometry(model: mujoco.MjModel, joint_names: Sequence[str], errors: GeometryErrors,
                   tip_site: str = "pen_tip") -> None:
    """Change ``model`` in place to the arm ``errors`` describes (module docstring), then
    ``mj_setConst``. Raises InputError for a joint or tip site the model lacks, a list of errors
    whose length is not the number of joints, or an offset on a joint that is not a hinge."""
    import mujoco

    names = list(joint_names)
    n = len(names)
    joints = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name) for name in names]
    missing = [name for name, j in zip(names, joints, strict=True) if j < 0]
    if missing:
        raise InputError(f"apply_geometry: the model has no joint {missing[0]!r}",
                         key="joint_names", value=missing[0])
    for key in ("link_length_mm", "joint_offset_deg"):
        value = getattr(errors, key)
        if value and len(value) != n:
            raise InputError(f"expected {n} numbers (one per joint: {', '.join(names)}), got "
                             f"{len(value)}", key=key, value=value)
    bodies = [int(model.jnt_bodyid[j]) for j in joints]
    for i, dl in enumerate(errors.link_length_mm):
        if i > 0 and dl != 0.0:
            offset = model.body_pos[bodies[i]]
            length = float(np.linalg.norm(offset))
            if length > 0:
                model.body_pos[bodies[i]] = offset * (1.0 + dl / 1000.0 / length)
    for i, offset_deg in enumerate(errors.joint_offset_deg):
        if offset_deg != 0.0:
            _turn_body(model, joints[i], bodies[i], names[i], math.radians(offset_deg))
    if any(errors.tip_offset_mm):
        _move_tip(model, tip_site, np.asarray(errors.tip_offset_mm) / 1000.0)
    mujoco.mj_setConst(model, mujoco.MjData(model))


def _turn_body(model: mujoco.MjModel, joint: int, body: int, name: str, angle: float) -> None:
    """Body ``body`` turned by ``angle`` [rad] about hinge ``joint``'s axis through its anchor."""
    import mujoco

    if model.jnt_type[joint] != mujoco.mjtJoint.mjJNT_HINGE:
        raise InputError(f"apply_geometry: joint {name!r} is not a hinge; a joint offset [deg] "
                         "needs one", key="joint_offset_deg", value=name)
    axis, anchor = model.jnt_axis[joint].copy(), model.jnt_pos[joint].copy()
    turn, turn_mat, body_mat = np.zeros(4), np.zeros(9), np.zeros(9)
    mujoco.mju_axisAngle2Quat(turn, axis, angle)
    mujoco.mju_quat2Mat(turn_mat, turn)
    mujoco.mju_quat2Mat(body_mat, model.body_quat[body])
    shift = body_mat.reshape(3, 3) @ (anchor - turn_mat.reshape(3, 3) @ anchor)
    quat = np.zeros(4)
    mujoco.mju_mulQuat(quat, model.body_quat[body].copy(), turn)
    model.body_pos[body] = model.body_pos[body] + shift
    model.body_quat[body] = quat


def _move_tip(model: mujoco.MjModel, tip_site: str, offset_m: np.ndarray) -> None:
    """The tip site and the geom of the same name moved by ``offset_m`` [m] in the pen body's
    frame (the flange frame: the pen body is not turned against it)."""
    import mujoco

    site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, tip_site)
    if site < 0:
        raise InputError(f"apply_geometry: the model has no site {tip_site!r} at the pen tip",
                         key="tip_site", value=tip_site)
    model.site_pos[site] = model.site_pos[site] + offset_m
    geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, tip_site)
    if geom >= 0:
        model.geom_pos[geom] = model.geom_pos[geom] + offset_m


__all__ = ["GeometryErrors", "apply_geometry"]
