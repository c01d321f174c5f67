"""The plant's model: the nominal cell changed by a :class:`PlantTruth`.

Model-level differences are applied here, once, before the simulation starts: the sheet's pose,
underlay and contact (on the MjSpec), the links' masses, inertias, centres of mass and lengths, a
payload at the flange, and joint friction (on the compiled MjModel, then ``mj_setConst``). The
controller never sees this model: it keeps :func:`inkarm.sim.cell.kinematic_model`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import mujoco
import numpy as np

from inkarm.sim.cell import PAPER, Cell, build_spec
from inkarm.sim.imperfections import PlantTruth


def plant_model(cell: Cell, truth: PlantTruth | None = None,
                edit_spec: Callable[[mujoco.MjSpec], None] | None = None) -> mujoco.MjModel:
    """The cell as the plant really is: :func:`build_model` of ``cell`` with ``truth`` applied
    (drawn first when it has random fields). ``edit_spec`` may add to the spec before it is
    compiled (sensors that change no dynamics)."""
    truth = truth or PlantTruth()
    if truth.random:
        truth = truth.realised()
    config = cell.config
    changes = {}
    if truth.paper_stiffness_n_per_mm is not None:
        changes["paper_stiffness_n_per_mm"] = truth.paper_stiffness_n_per_mm
    if truth.nib_friction is not None:
        changes["friction"] = truth.nib_friction
    if changes:
        cell = Cell(dataclasses.replace(config, **changes), cell.robot)
    spec = build_spec(cell)
    if edit_spec is not None:
        edit_spec(spec)
    _move_paper(spec, truth)
    model = spec.compile()
    if truth.paper_timeconst_s is not None:
        # The sheet's side of the contact only; the nib (a felt) keeps its own, and MuJoCo
        # mixes the two geoms' settings.
        paper = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, PAPER)
        model.geom_solref[paper, 0] = max(truth.paper_timeconst_s, 2.0 * model.opt.timestep)
    _change_links(model, cell, truth)
    return model


def _move_paper(spec: mujoco.MjSpec, truth: PlantTruth) -> None:
    """Shift, lift, turn and tilt the sheet about its centre, in its own frame."""
    paper = spec.body(PAPER)
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, np.asarray(paper.quat, dtype=float))
    rot = rot.reshape(3, 3)
    shift = rot @ np.array([truth.paper_shift_x_mm, truth.paper_shift_y_mm, 0.0]) / 1000.0
    paper.pos = np.asarray(paper.pos) + shift + [0.0, 0.0, truth.paper_height_mm / 1000.0]
    turn = _axis_angle([0.0, 0.0, 1.0], np.deg2rad(truth.paper_yaw_deg))
    a = np.deg2rad(truth.paper_tilt_axis_deg)
    tilt = _axis_angle(rot @ [np.cos(a), np.sin(a), 0.0], np.deg2rad(truth.paper_tilt_deg))
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, (tilt @ turn @ rot).ravel())
    paper.quat = quat


def _axis_angle(axis, angle: float) -> np.ndarray:
    quat, mat = np.zeros(4), np.zeros(9)
    mujoco.mju_axisAngle2Quat(quat, np.asarray(axis, dtype=float), float(angle))
    mujoco.mju_quat2Mat(mat, quat)
    return mat.reshape(3, 3)


def _change_links(model: mujoco.MjModel, cell: Cell, truth: PlantTruth) -> None:
    names = cell.robot.joint_names
    joints = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n) for n in names]
    bodies = [int(model.jnt_bodyid[j]) for j in joints]
    dofs = [int(model.jnt_dofadr[j]) for j in joints]
    n = len(joints)
    directions, fractions = truth.directions(n)
    for i, b in enumerate(bodies):
        model.body_mass[b] *= truth.mass_scale
        model.body_inertia[b] *= truth.mass_scale * truth.inertia_scale
        model.body_ipos[b] += truth.com_offset_mm / 1000.0 * directions[i]
        if i > 0:  # the link from the previous joint to this one gets longer or shorter
            offset = model.body_pos[b]
            length = float(np.linalg.norm(offset))
            if length > 0:
                model.body_pos[b] = offset * (1.0 + truth.link_length_error_mm / 1000.0
                                              * fractions[i] / length)
    if truth.payload_kg > 0:
        flange = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "flange")
        _add_point_mass(model, int(model.site_bodyid[flange]), model.site_pos[flange].copy(),
                        truth.payload_kg)
    if truth.coulomb_nm is not None:
        model.dof_frictionloss[dofs] = truth.per_joint("coulomb_nm", n)
    model.dof_damping[dofs] += truth.per_joint("viscous_nms", n)
    if truth.torque_limit_scale != 1.0:
        for a in range(model.nu):
            if model.actuator_trnid[a, 0] in joints:
                model.actuator_ctrlrange[a] *= truth.torque_limit_scale
                model.actuator_forcerange[a] *= truth.torque_limit_scale
    mujoco.mj_setConst(model, mujoco.MjData(model))


def _add_point_mass(model: mujoco.MjModel, body: int, where: np.ndarray, mass: float) -> None:
    """Body ``body`` with a point mass ``mass`` [kg] at ``where`` (body frame) added: the
    combined centre of mass and principal inertia (parallel-axis theorem)."""
    m0, c0 = float(model.body_mass[body]), model.body_ipos[body].copy()
    r = np.zeros(9)
    mujoco.mju_quat2Mat(r, model.body_iquat[body])
    r = r.reshape(3, 3)
    total = m0 + mass
    c = (m0 * c0 + mass * where) / total

    def shifted(m: float, d: np.ndarray) -> np.ndarray:
        return m * (d @ d * np.eye(3) - np.outer(d, d))

    inertia = r @ np.diag(model.body_inertia[body]) @ r.T + shifted(m0, c0 - c) + \
        shifted(mass, where - c)
    values, vectors = np.linalg.eigh(inertia)
    if np.linalg.det(vectors) < 0:
        vectors[:, 0] *= -1.0
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, vectors.ravel())
    model.body_mass[body], model.body_ipos[body] = total, c
    model.body_inertia[body], model.body_iquat[body] = values, quat


__all__ = ["plant_model"]
