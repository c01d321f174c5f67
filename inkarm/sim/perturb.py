"""The plant's model: the nominal cell changed by a :class:`PlantTruth`.

Model-level differences are applied here, once, before the simulation starts: the sheet's pose,
underlay, contact and relief (on the MjSpec), the links' masses, inertias, centres of mass and
lengths, a payload at the flange, and joint friction (on the compiled MjModel, then
``mj_setConst``); joint offsets, link lengths given per joint and the pen tip's offset through
:func:`inkarm.robots.geometry.apply_geometry` (the calibrated belief goes through it too); a
tilted base as the gravity vector turned. The controller never sees this model: it keeps
:func:`inkarm.sim.cell.kinematic_model`.

Relief (:mod:`inkarm.sim.relief`) is a contact patch that follows the pen: a box
``paper_relief`` on the paper body (:data:`PATCH_HALF_MM` square, the sheet box's depth and
contact settings) whose top is the tangent plane of the relief under the tip, put there before
every physics step's collision detection by :class:`ReliefFollower` (the plant calls
``follow(data)``); the sheet's own box stays, colliding with nothing, for the page's placement
and the ink's texture. For a tip of radius r on relief of curvature radius >> r this is the
relief's contact: one contact, as on the flat sheet, so the relief changes nothing but the height
and slope under the tip. (A MuJoCo height field, tried first, makes a contact per facet prism the
tip dips into, about 20 on a 1 mm grid, and their births and deaths as the tip slides move the
force by +-50 % on a relief of 0.01 mm: tests/sim/test_relief.py keeps the numbers.) The canvas
takes the tip's page x, y as before. Without relief the model is the one of before, bit for bit.
"""

from __future__ import annotations

import dataclasses
import math
import threading
import weakref
from collections.abc import Callable

import mujoco
import numpy as np

from inkarm.errors import InputError
from inkarm.robots.geometry import apply_geometry
from inkarm.sim.cell import (
    _PAPER_DEPTH_M,
    HOME_KEY,
    PAPER,
    PAPER_ORIGIN,
    PEN_TIP,
    Cell,
    _pen_contact,
    build_spec,
)
from inkarm.sim.imperfections import PlantTruth
from inkarm.sim.relief import check_relief, has_relief, relief_field

RELIEF = "paper_relief"
RELIEF_GROUP = 3  # a geom group MuJoCo's renderers hide by default
PATCH_HALF_MM = 10.0  # the patch's half side: the tip moves < 2 mm a step at 1 m/s


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
    built_for = cell
    if changes:
        cell = Cell(dataclasses.replace(config, **changes), cell.robot)
    spec = _fresh_spec(built_for, cell, tuple(sorted(changes.items())))
    if edit_spec is not None:
        edit_spec(spec)
    _move_paper(spec, truth)
    if has_relief(truth):
        check_relief(truth, cell.paper_size_mm)
        _add_relief(spec, cell)
    model = spec.compile()
    if truth.paper_timeconst_s is not None:
        # The sheet's side of the contact only; the nib (a felt) keeps its own, and MuJoCo
        # mixes the two geoms' settings.
        for name in (PAPER, RELIEF):
            paper = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)
            if paper >= 0:
                model.geom_solref[paper, 0] = max(truth.paper_timeconst_s,
                                                  2.0 * model.opt.timestep)
    _change_links(model, cell, truth)
    _change_geometry(model, cell, truth)
    if has_relief(truth):
        _turnable(model, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, RELIEF))
    return model


# the caller's Cell -> {its config's changes: the spec built, unedited}, a few each
_BUILT: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_CHANGES_KEPT = 4


def _fresh_spec(cell: Cell, changed: Cell, changes: tuple) -> mujoco.MjSpec:
    """An editable spec of ``changed`` (``cell`` with its config's ``changes``): a copy of the
    one built for them once (:func:`build_spec`; a copy costs a twentieth of a build, and
    compiles to the same model bit for bit: an ensemble builds one plant model per member).
    Kept per ``cell``, the caller's, for the last :data:`_CHANGES_KEPT` changes."""
    built = _BUILT.setdefault(cell, {})
    if changes not in built:
        while len(built) >= _CHANGES_KEPT:
            del built[next(iter(built))]
        built[changes] = build_spec(changed)
    return built[changes].copy()


def _turnable(model: mujoco.MjModel, geom: int) -> None:
    """Let ``geom`` be turned at run time: MuJoCo would otherwise take its frame for its body's
    (``mj_setConst`` sets this flag again from the geom's pose of the moment)."""
    model.geom_sameframe[geom] = int(mujoco.mjtSameFrame.mjSAMEFRAME_NONE)


def _add_relief(spec: mujoco.MjSpec, cell: Cell) -> None:
    """Add the relief's contact patch to the paper body, at the sheet's centre until the tip is
    followed, and take the sheet's box out of the contact."""
    box = spec.geom(PAPER)
    box.contype, box.conaffinity = 0, 0
    half = PATCH_HALF_MM / 1000.0
    spec.body(PAPER).add_geom(name=RELIEF, type=mujoco.mjtGeom.mjGEOM_BOX,
                              size=[half, half, _PAPER_DEPTH_M / 2], pos=box.pos,
                              group=RELIEF_GROUP, rgba=[0.97, 0.97, 0.94, 1.0],
                              **_pen_contact(cell.config))


class ReliefFollower:
    """Puts the relief's contact patch under the pen tip: the plane through the relief's point
    under the tip, normal to it, before each physics step's collision detection.

    In the paper body's frame (origin at the sheet's centre, z along its normal) the tip at page
    (x, y) meets ``P = (x - w/2, y - h/2, t + z(x, y))`` (t the sheet's thickness) with normal
    ``n = (-z_x, -z_y, 1) / |.|``; the patch's centre is ``P - n D/2`` (D its depth) and its
    rotation the shortest one from z to n, ``quat = (1 + n_z, -n_y, n_x, 0) / |.|``. The tip's
    page point is that of its site after the last step (one physics step old: at 1 m/s on a
    slope of 0.2 the plane is then off by under 0.01 mm).

    Args:
        model: The plant's model (from :func:`plant_model` with relief); its patch is moved.
        cell: The cell (the sheet's size and thickness).
        truth: The plant's truth with relief.
    """

    def __init__(self, model: mujoco.MjModel, cell: Cell, truth: PlantTruth):
        self.field = relief_field(truth.realised() if truth.random else truth,
                                  cell.paper_size_mm)
        ids = {name: mujoco.mj_name2id(model, kind, name) for name, kind in (
            (RELIEF, mujoco.mjtObj.mjOBJ_GEOM), (PEN_TIP, mujoco.mjtObj.mjOBJ_SITE),
            (PAPER_ORIGIN, mujoco.mjtObj.mjOBJ_SITE))}
        if min(ids.values()) < 0:
            raise InputError(f"ReliefFollower: the model has no relief patch {RELIEF!r} (build "
                             "it with plant_model and a truth with relief)")
        self._patch, self._tip, self._origin = ids[RELIEF], ids[PEN_TIP], ids[PAPER_ORIGIN]
        _turnable(model, self._patch)  # (again: the plant may have called mj_setConst since)
        self._pos, self._quat = model.geom_pos[self._patch], model.geom_quat[self._patch]
        w, h = cell.paper_size_mm
        self._offset = (-w / 2000.0, -h / 2000.0, cell.config.paper_thickness_mm / 1000.0)
        self._half_depth = _PAPER_DEPTH_M / 2
        self._data = self._views = None

    def follow(self, data: mujoco.MjData) -> tuple[float, float, float]:
        """Move the patch under the tip of ``data``'s state; returns the relief's (height [mm],
        dz/dx, dz/dy) there."""
        if data is not self._data:  # views into MjData (an attribute look-up builds an array)
            self._data = data
            self._views = (data.site_xpos[self._tip], data.site_xpos[self._origin],
                           data.site_xmat[self._origin])
        tip, origin, rot = self._views
        tx, ty, tz = tip.tolist()
        ox, oy, oz = origin.tolist()
        r = rot.tolist()
        dx, dy, dz = tx - ox, ty - oy, tz - oz
        return self.place(1000.0 * (r[0] * dx + r[3] * dy + r[6] * dz),
                          1000.0 * (r[1] * dx + r[4] * dy + r[7] * dz))

    def place(self, x_mm: float, y_mm: float) -> tuple[float, float, float]:
        """Move the patch under page point (``x_mm``, ``y_mm``); returns (height, slopes)."""
        z, zx, zy = self.field.at(x_mm, y_mm)
        norm = math.sqrt(1.0 + zx * zx + zy * zy)
        nx, ny, nz = -zx / norm, -zy / norm, 1.0 / norm
        ox, oy, oz = self._offset
        d = self._half_depth
        self._pos[:] = (x_mm / 1000.0 + ox - nx * d, y_mm / 1000.0 + oy - ny * d,
                        oz + z / 1000.0 - nz * d)
        qn = math.sqrt((1.0 + nz) ** 2 + ny * ny + nx * nx)
        self._quat[:] = ((1.0 + nz) / qn, -ny / qn, nx / qn, 0.0)
        return z, zx, zy


def relief_follower(model: mujoco.MjModel, cell: Cell,
                    truth: PlantTruth | None) -> ReliefFollower | None:
    """The follower of ``model``'s relief patch, placed under the tip of its home state; None
    when ``truth`` has no relief."""
    if truth is None or not has_relief(truth.realised() if truth.random else truth):
        return None
    follower = ReliefFollower(model, cell, truth)
    data = mujoco.MjData(model)
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, HOME_KEY)
    if key >= 0:
        mujoco.mj_resetDataKeyframe(model, data, key)
    mujoco.mj_kinematics(model, data)
    follower.follow(data)
    return follower


def _change_geometry(model: mujoco.MjModel, cell: Cell, truth: PlantTruth) -> None:
    """Joint offsets, link lengths given per joint and the pen tip's offset (apply_geometry;
    a scalar link-length error was applied by :func:`_change_links` with its own arithmetic),
    and the base's tilt: gravity ``g <- R(u, base_tilt_deg) g``, ``u`` the horizontal axis at
    ``base_tilt_axis_deg`` from the base's x axis."""
    names = cell.robot.joint_names
    errors = truth.geometry(names)
    if np.ndim(truth.link_length_error_mm) == 0:
        errors = dataclasses.replace(errors, link_length_mm=())
    if not errors.is_zero:
        apply_geometry(model, names, errors, PEN_TIP)
    if truth.base_tilt_deg != 0.0:
        a = np.deg2rad(truth.base_tilt_axis_deg)
        turn = _axis_angle([np.cos(a), np.sin(a), 0.0], np.deg2rad(truth.base_tilt_deg))
        model.opt.gravity = turn @ model.opt.gravity


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
        if i > 0 and np.ndim(truth.link_length_error_mm) == 0:
            # the link from the previous joint to this one gets longer or shorter
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
    _set_const(model)


# this thread's scratch data for mj_setConst, by the layout of the models it serves
_SCRATCH = threading.local()


def _set_const(model: mujoco.MjModel) -> None:
    """``mj_setConst`` of ``model`` on data reset to its defaults: the thread's scratch data
    when the last model had the same layout (``_sizes``, the sizes MjData is laid out by), else
    a new MjData (the same bits either way: mj_resetData leaves what a new MjData holds; a new
    one costs ~0.35 ms, its arena, for each member of an ensemble). The scratch keeps its
    arena (13 MiB for the iiwa14 cell, mostly untouched) and its model for the thread's life."""
    sizes = getattr(model, "_sizes", None)
    key = None if sizes is None else sizes.tobytes()
    data = getattr(_SCRATCH, "data", None)
    if key is not None and data is not None and _SCRATCH.key == key:
        mujoco.mj_resetData(model, data)
    else:
        data = mujoco.MjData(model)
        _SCRATCH.key, _SCRATCH.data = key, data
    mujoco.mj_setConst(model, data)


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


__all__ = ["PATCH_HALF_MM", "RELIEF", "ReliefFollower", "plant_model", "relief_follower"]
