"""The drawing cell, built in code with :class:`mujoco.MjSpec`: a robot arm from its profile
(:mod:`inkarm.robots`), a spring-loaded pen on its flange, a table and a sheet of paper.

This module owns the cell's names: the site ``pen_tip``, the pen joint ``pen_slide``, the paper
geom and its corner site ``paper_origin``, the ``home`` keyframe. Nothing outside ``sim/`` and
``robots/`` names them; the controller receives a :class:`inkarm.robots.kinematic.KinematicModel`.

The pen is a slide joint ``pen_slide`` along the flange axis: positive values push the tip into
the holder (compression), a linear spring of ``pen_stiffness`` pushes it back against the stop
at 0, and a small sphere ``pen_tip`` at its end is the only geom that touches anything: it
collides with the paper only (contype/conaffinity bit 2).

Contact. The paper is a box whose top face is the sheet and which reaches 5 mm down into the
table, so a pressed tip cannot tunnel through a sheet-thin box. Friction cones are elliptic and
the contact is soft (solref time constant 10 ms, at least twice the time step as the MuJoCo docs
ask; solimp 0.1 to 0.5 over 1 mm): the paper behaves as a sheet on a felt underlay, sinking
about 0.5 mm under 1 N. Stiffer settings (MuJoCo's defaults, or pyramidal cones) make the light,
spring-preloaded pen cartridge chatter on the paper while it slides: it loses contact for a
step, falls tens of microns in that step, and the force jumps between 0 and about 2 N.

Frames: the world frame is the robot base frame (base on the table top, z up). The page frame
(site ``paper_origin``) sits at the paper's lower-left corner on its top surface, x to the
right, y up the page, z out of the paper. With ``paper_yaw_deg = 0`` the page's y axis points
away from the robot (world +x): the robot sits where the writer would.

Cameras: ``paper_top`` (top-down on the page, image up = page up), ``overview`` (the cell,
three-quarter view) and ``pen_cam`` (on the flange, looking at the pen tip).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from inkarm.core.frames import PagePlacement
from inkarm.errors import InputError
from inkarm.robots.builders import arm_spec
from inkarm.robots.geometry import apply_geometry
from inkarm.robots.kinematic import KinematicModel
from inkarm.robots.profile import RobotProfile
from inkarm.robots.registry import load_robot
from inkarm.sim.cell_config import Cell, CellConfig

if TYPE_CHECKING:
    from inkarm.robots.calibration import CellCalibration

PEN_TIP = "pen_tip"
PEN_SLIDE = "pen_slide"
PAPER = "paper"
PAPER_ORIGIN = "paper_origin"
HOME_KEY = "home"
CAMERAS = ("paper_top", "overview", "pen_cam")
PEN_COLLISION_BIT = 2
_PAPER_DEPTH_M = 0.005
CONTACT_MARGIN_M = 0.0005


def make_cell(config: CellConfig | None = None, robot: RobotProfile | str | None = None) -> Cell:
    """A :class:`Cell` from a configuration (default :class:`CellConfig`) and a robot (a profile,
    a built-in name or a profile path; default the built-in iiwa14)."""
    if not isinstance(robot, RobotProfile):
        robot = load_robot(robot) if robot is not None else load_robot()
    return Cell(config or CellConfig(), robot)


def paper_rotation(yaw_deg: float) -> np.ndarray:
    """Rotation (3, 3) whose columns are the page x, y, z axes in the robot base frame."""
    yaw = np.deg2rad(yaw_deg)
    y_axis = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    z_axis = np.array([0.0, 0.0, 1.0])
    return np.column_stack([np.cross(y_axis, z_axis), y_axis, z_axis])


def _quat(rotation: np.ndarray) -> np.ndarray:
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(rotation).ravel())
    return q


def _look_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Quaternion of a camera at ``eye`` looking at ``target`` (MuJoCo cameras look along -z)."""
    back = np.asarray(eye, float) - np.asarray(target, float)
    back /= np.linalg.norm(back)
    right = np.cross(up, back)
    if np.linalg.norm(right) < 1e-9:  # looking along ``up``: any right vector will do
        right = np.cross((0.0, 1.0, 0.0), back)
    right /= np.linalg.norm(right)
    return _quat(np.column_stack([right, np.cross(back, right), back]))


def build_spec(cell: Cell | None = None) -> mujoco.MjSpec:
    """The cell as an editable :class:`mujoco.MjSpec` (compile it with ``.compile()``).

    Raises InputError when the robot's model cannot be built (a Menagerie arm without
    ``MENAGERIE_ROOT``, a missing model file or mesh)."""
    cell = cell or make_cell()
    cfg, robot = cell.config, cell.robot
    spec, flange = arm_spec(robot)  # fitted before the cell is added, which must leave it alone
    spec.modelname = "inkarm_cell"
    spec.compiler.degree = False
    spec.option.timestep = cfg.timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    # One arm pressing one sheet is a single constraint island: finding islands only costs
    # (7 % of a physics step), and solving them apart changes nothing.
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_ISLAND
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    # The contact was tuned with MuJoCo's default impratio; Menagerie's Panda raises it to 10
    # for grasping, which would stiffen the nib's friction.
    spec.option.impratio = 1.0
    spec.visual.global_.offwidth = 1280
    spec.visual.global_.offheight = 960
    world = spec.worldbody

    centre = np.array([*cell.paper_centre_mm, 0.0]) / 1000.0
    world.add_light(name="sun", pos=[0.5 * centre[0], 0.0, 2.5], dir=[0.0, 0.0, -1.0],
                    diffuse=[0.8] * 3)
    # A table under the base and the sheet, with 50 mm to spare beyond the far edge.
    far = float(np.linalg.norm(centre[:2])) + 0.5 * max(cell.paper_size_mm) / 1000.0 + 0.05
    world.add_geom(
        name="table",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[0.5 * (far + 0.1), 0.6, 0.02],
        pos=[0.5 * (far - 0.1), 0.0, -0.02],
        rgba=[0.55, 0.45, 0.35, 1.0],
        contype=0,
        conaffinity=0,
    )
    _add_paper(world, cell)
    _add_pen(flange, cfg, robot)

    rot = paper_rotation(cfg.paper_yaw_deg)
    height = 0.6
    half = 0.55 * max(cell.paper_size_mm) / 1000.0
    world.add_camera(
        name=CAMERAS[0],
        pos=centre + [0.0, 0.0, height],
        quat=_quat(rot),
        fovy=float(np.rad2deg(2.0 * np.arctan(half / height))),
    )
    reach = max(far, 0.3)
    eye = np.array([1.7, -1.3, 1.2]) * reach / 0.9
    world.add_camera(name=CAMERAS[1], pos=eye, quat=_look_at(eye, [0.5 * reach, 0.0, 0.5 * reach]),
                     fovy=45.0)
    pad = [0.0] if cfg.paper_stiffness_n_per_mm > 0 else []
    spec.add_key(name=HOME_KEY, qpos=[*robot.home_q.tolist(), 0.0, *pad])
    return spec


PAPER_PAD = "paper_pad"
_PAD_MASS_KG = 0.05


def _add_paper(world, cell: Cell) -> None:
    """The sheet: a body on a vertical spring (the underlay, ``paper_stiffness_n_per_mm``,
    critically damped, its weight compensated so that it rests at 0), whose box collides with
    the pen tip only."""
    cfg = cell.config
    rot = paper_rotation(cfg.paper_yaw_deg)
    w, h = (v / 1000.0 for v in cell.paper_size_mm)
    thick = cfg.paper_thickness_mm / 1000.0
    centre = np.array([cell.paper_centre_mm[0] / 1000.0, cell.paper_centre_mm[1] / 1000.0, 0.0])
    paper = world.add_body(name=PAPER, pos=centre, quat=_quat(rot), mass=_PAD_MASS_KG,
                           inertia=[1e-3, 1e-3, 1e-3], gravcomp=1.0)
    paper.explicitinertial = True
    stiffness = cfg.paper_stiffness_n_per_mm * 1000.0
    if stiffness > 0:
        paper.add_joint(name=PAPER_PAD, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0.0, 0.0, 1.0],
                        stiffness=[stiffness, 0.0, 0.0],
                        damping=[2.0 * np.sqrt(stiffness * _PAD_MASS_KG), 0.0, 0.0])
    # The collision box reaches 5 mm down into the table (which collides with nothing): a
    # sheet-thin box lets a pressed tip tunnel through it once the penetration exceeds the
    # thickness.
    paper.add_geom(
        name=PAPER,
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[w / 2, h / 2, _PAPER_DEPTH_M / 2],
        pos=[0.0, 0.0, thick - _PAPER_DEPTH_M / 2],
        rgba=[0.97, 0.97, 0.94, 1.0],
        **_pen_contact(cfg),
    )
    paper.add_site(name=PAPER_ORIGIN, pos=[-w / 2, -h / 2, thick], size=[0.003] * 3)


def _pen_contact(cfg: CellConfig) -> dict:
    """Collision settings shared by the pen tip and the paper, the only pair that touches."""
    return {
        "contype": PEN_COLLISION_BIT,
        "conaffinity": PEN_COLLISION_BIT,
        "condim": 3,
        "friction": [cfg.friction, 0.005, 0.0001],
        "solref": _contact_solref(cfg),
        "solimp": [*cfg.contact_solimp, 0.5, 2.0],
        # The contact exists from 0.5 mm away but pushes only on touching (margin - gap = 0):
        # on hard paper a tip resting at zero depth would otherwise lose its contact for a
        # step now and then and land again with a jolt (a force gap, then 1.3 N).
        "margin": CONTACT_MARGIN_M,
        "gap": CONTACT_MARGIN_M,
    }


def _contact_solref(cfg: CellConfig) -> list[float]:
    # MuJoCo docs: the solref time constant should be at least twice the time step.
    return [max(cfg.contact_timeconst, 2.0 * cfg.timestep), 1.0]


def _add_pen(flange: mujoco.MjsFrame, cfg: CellConfig, robot: RobotProfile) -> None:
    """Site ``flange``, the rigid holder, the sprung pen and ``pen_cam``, in the flange frame
    (z out of the flange)."""
    holder_m, shaft_m = robot.pen.holder_mm / 1000.0, robot.pen.shaft_mm / 1000.0
    flange.add_site(name="flange", pos=[0.0, 0.0, 0.0], size=[0.005] * 3)
    flange.add_geom(
        name="pen_holder",
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        fromto=[0, 0, 0, 0, 0, holder_m],
        size=[0.012, 0, 0],
        mass=0.1,
        rgba=[0.2, 0.2, 0.2, 1.0],
        contype=0,
        conaffinity=0,
    )
    cam_pos = [0.12, 0.0, 0.015]
    flange.add_camera(
        name=CAMERAS[2],
        pos=cam_pos,
        quat=_look_at(cam_pos, [0.0, 0.0, holder_m + shaft_m], up=(0.0, 0.0, -1.0)),
        fovy=50.0,
    )
    pen = flange.add_body(name="pen", pos=[0.0, 0.0, holder_m])
    travel = cfg.pen_travel_mm / 1000.0
    pen.add_joint(
        name=PEN_SLIDE,
        type=mujoco.mjtJoint.mjJNT_SLIDE,
        axis=[0.0, 0.0, -1.0],
        range=[0.0, travel],
        limited=mujoco.mjtLimited.mjLIMITED_TRUE,
        # Rigid stops at both ends (the stiffest a soft constraint may be at this time step).
        solref_limit=[2.0 * cfg.timestep, 1.0],
        solimp_limit=[0.99, 0.999, 0.0001, 0.5, 2.0],
        stiffness=[cfg.pen_stiffness_n_per_mm * 1000.0, 0.0, 0.0],
        # The spring's rest length lies beyond the outer stop: it holds the pen there with
        # ``pen_preload_n``.
        springref=-cfg.pen_preload_n / (cfg.pen_stiffness_n_per_mm * 1000.0),
        damping=[cfg.pen_damping_ns_per_mm * 1000.0, 0.0, 0.0],
        armature=0.03,
    )
    radius = cfg.pen_tip_radius_mm / 1000.0
    pen.add_geom(
        name="pen_shaft",
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        fromto=[0, 0, -0.02, 0, 0, shaft_m - radius],
        size=[0.005, 0, 0],
        mass=cfg.pen_mass_kg,
        rgba=[0.1, 0.2, 0.7, 1.0],
        contype=0,
        conaffinity=0,
    )
    pen.add_geom(
        name=PEN_TIP,
        type=mujoco.mjtGeom.mjGEOM_SPHERE,
        size=[radius, 0, 0],
        pos=[0.0, 0.0, shaft_m],
        mass=1e-4,
        rgba=[0.05, 0.05, 0.05, 1.0],
        **_pen_contact(cfg),
    )
    pen.add_site(name=PEN_TIP, pos=[0.0, 0.0, shaft_m + radius], size=[0.001] * 3)


def build_model(cell: Cell | None = None) -> mujoco.MjModel:
    """The compiled cell model. Call it twice to get a plant model and an independent
    kinematic model for the controller."""
    return build_spec(cell).compile()


def kinematic_model(cell: Cell | None = None,
                    calibration: CellCalibration | None = None) -> KinematicModel:
    """What a controller believes about ``cell``: its own compiled model and the facts the
    controller needs (page placement, home, pen spring and travel, nib friction). With a
    ``calibration``, the model has its geometry errors applied
    (:func:`inkarm.robots.geometry.apply_geometry`) and ``paper_map`` is its height map."""
    cell = cell or make_cell()
    model = build_model(cell)
    if calibration is not None and not calibration.geometry.is_zero:
        apply_geometry(model, cell.robot.joint_names, calibration.geometry, PEN_TIP)
    tip, paper = (mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in (PEN_TIP, PAPER))
    return KinematicModel(
        model=model,
        joint_names=cell.robot.joint_names,
        tip_site=PEN_TIP,
        placement=page_placement(model),
        home_q=cell.robot.home_q,
        pen_stiffness_n_per_mm=cell.config.pen_stiffness_n_per_mm,
        pen_travel_mm=cell.config.pen_travel_mm,
        # MuJoCo combines two geoms' friction by taking the larger.
        nib_friction=float(max(model.geom_friction[tip][0], model.geom_friction[paper][0])),
        pen_preload_n=cell.config.pen_preload_n,
        paper_stiffness_n_per_mm=cell.config.paper_stiffness_n_per_mm,
        paper_map=calibration.paper if calibration is not None else None,
    )


def page_placement(model: mujoco.MjModel) -> PagePlacement:
    """The placement of the sheet in a cell model: the pose of its corner site and the size of
    the paper box."""
    sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, PAPER_ORIGIN)
    gid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, PAPER)
    if sid < 0 or gid < 0:
        raise InputError(f"model has no site {PAPER_ORIGIN!r} or geom {PAPER!r} to place the "
                         "page from")
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    size = 2.0 * 1000.0 * model.geom_size[gid][:2]
    return PagePlacement(
        data.site_xpos[sid].copy(),
        data.site_xmat[sid].reshape(3, 3).copy(),
        (float(size[0]), float(size[1])),
    )


def joint_ranges(model: mujoco.MjModel, joint_names) -> np.ndarray:
    """Ranges (n, 2) in [rad], rows (lower, upper), of the joints ``joint_names``."""
    ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name) for name in joint_names]
    if min(ids) < 0:
        raise InputError(f"joint_ranges: the model lacks one of the joints {joint_names}")
    return model.jnt_range[ids].copy()
