"""The drawing cell, built in code with :class:`mujoco.MjSpec`: a 7-DOF arm with the published
KUKA LBR iiwa 14 kinematics, a spring-loaded pen on its flange, a table and a sheet of paper.

Kinematics (zero pose: arm straight up, every link frame aligned with the base frame), in [mm]:

    base -> joint 2 (shoulder)   d1 = 360     joint axes: 1 z, 2 y, 3 z, 4 -y, 5 z, 6 y, 7 z
    joint 2 -> joint 4 (elbow)   d3 = 420     (the DH twists -90, 90, 90, -90, -90, 90, 0 deg
    joint 4 -> joint 6 (wrist)   d5 = 400      of the iiwa datasheet give exactly these axes)
    joint 6 -> flange            d7 = 126

Joints 1, 3, 5 and 7 sit on the link axes, so where they are placed along them changes nothing
kinematically; they are placed as on the real links (157.5, 564.5, 964.5, 1261 mm above the
base). Masses and inertias are approximate (link masses of the public iiwa 14 URDF, inertias of
capsules); joint damping and armature are plausible values for harmonic-drive joints.

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
three-quarter view) and ``pen_cam`` (on link 7, looking at the pen tip).

Menagerie arms. With ``CellConfig.arm = "iiwa14"`` or ``"panda"`` the arm is read instead from
a local MuJoCo Menagerie copy named by the environment variable ``MENAGERIE_ROOT``
(``kuka_iiwa_14/iiwa14.xml``, ``franka_emika_panda/panda_nohand.xml``), meshes and all, and
fitted to the cell: its position actuators, keyframes and lights go, motors ``motor1..7`` with
the arm's torque limits drive its joints ``joint1..7`` (the Menagerie's own names), joints
without armature or damping get the built-in arm's, none of its geoms collides with anything,
and the pen is mounted on its ``attachment_site`` (the flange). The pen, paper, table, cameras
and names are the same as with the built-in arm. Menagerie's iiwa 14 has the kinematics of the
built-in arm (same joint placements and axes), so the same home pose serves both.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from inkarm.control.pid import PIDGains
from inkarm.errors import InputError

JOINT_NAMES = tuple(f"joint{i}" for i in range(1, 8))
ACTUATOR_NAMES = tuple(f"motor{i}" for i in range(1, 8))
JOINT_RANGES_DEG = (170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 175.0)
TORQUE_LIMITS_NM = (320.0, 320.0, 176.0, 176.0, 110.0, 40.0, 40.0)

# Body offsets along the parent link axis in [m] and joint axes, zero pose straight up.
_LINK_OFFSETS_M = (0.1575, 0.2025, 0.2045, 0.2155, 0.1845, 0.2155, 0.081)
_JOINT_AXES = ((0, 0, 1), (0, 1, 0), (0, 0, 1), (0, -1, 0), (0, 0, 1), (0, 1, 0), (0, 0, 1))
_FLANGE_OFFSET_M = 0.045  # link 7 joint -> flange; 0.081 + 0.045 = d7 = 0.126
# Capsule length along each link (to the next joint) and radius, in [m].
_LINK_LENGTHS_M = (0.2025, 0.2045, 0.2155, 0.1845, 0.2155, 0.081, 0.045)
_LINK_RADII_M = (0.075, 0.07, 0.07, 0.065, 0.06, 0.06, 0.045)
_LINK_MASSES_KG = (4.0, 4.0, 3.0, 2.7, 1.7, 1.8, 0.3)
_ARMATURE = (0.4, 0.4, 0.2, 0.2, 0.1, 0.05, 0.05)  # reflected rotor inertia [kg m^2]
_DAMPING = (0.5, 0.5, 0.3, 0.3, 0.2, 0.1, 0.1)  # viscous joint friction [N m s/rad]

# Home pose in [rad]: pen pointing down above the paper (pitch q2 - q4 + q6 = pi).
HOME_Q = (0.0, 0.45, 0.0, -1.75, 0.0, 0.94, 0.0)

ARMS = ("builtin", "iiwa14", "panda")
MENAGERIE_ROOT_VARIABLE = "MENAGERIE_ROOT"
# Model files inside a MuJoCo Menagerie checkout, and the site on their last link where a tool
# goes (the flange; its z axis points out of the flange).
MENAGERIE_MODELS = {
    "iiwa14": "kuka_iiwa_14/iiwa14.xml",
    "panda": "franka_emika_panda/panda_nohand.xml",
}
MENAGERIE_FLANGE_SITE = "attachment_site"
PANDA_TORQUE_LIMITS_NM = (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0)
ARM_TORQUE_LIMITS_NM = {
    "builtin": TORQUE_LIMITS_NM,
    "iiwa14": TORQUE_LIMITS_NM,
    "panda": PANDA_TORQUE_LIMITS_NM,
}
# Panda home in [rad]: the pen pointing down, its tip 150 mm above the default sheet's centre
# (solve_ik from the Panda's "ready" pose 0, 0, 0, -pi/2, 0, pi/2, -pi/4, rounded to mrad).
# Not the built-in arm's tip position: there the Panda's shoulder is nearly straight (q2 ~ 0),
# which lines up the axes of joints 1 and 3, and the joint PID then hunts on their coupled mode.
PANDA_HOME_Q = (0.0, 0.334, 0.0, -2.019, 0.0, 2.353, -0.785)
ARM_HOME_Q = {"builtin": HOME_Q, "iiwa14": HOME_Q, "panda": PANDA_HOME_Q}

PEN_COLLISION_BIT = 2
_PAPER_DEPTH_M = 0.005
_PEN_HOLDER_M = 0.10  # flange -> pen body (rigid holder)
_PEN_SHAFT_M = 0.035  # pen body -> tip sphere centre


@dataclass(frozen=True)
class CellConfig:
    """Everything that can change in the drawing cell. Lengths in [mm], times in [s].

    Attributes:
        timestep: Physics time step in [s].
        paper_size_mm: (width, height) of the sheet in [mm]; A4 by default.
        paper_centre_mm: (x, y) of the sheet's centre in the robot base frame in [mm].
        paper_yaw_deg: Rotation of the sheet about the vertical in [deg]; 0 puts the page's y
            axis along the robot's x axis (away from the robot).
        paper_thickness_mm: Sheet thickness in [mm].
        pen_stiffness_n_per_mm: Pen spring rate in [N/mm] (0.3 N/mm = 300 N/m).
        pen_damping_ns_per_mm: Pen slide damping in [N s/mm].
        pen_travel_mm: Pen slide travel in [mm].
        pen_tip_radius_mm: Radius of the tip sphere in [mm].
        pen_mass_kg: Mass of the sliding pen cartridge in [kg].
        friction: Tip-paper sliding friction coefficient.
        contact_timeconst: Contact solref time constant in [s]; raised to 2 * timestep if lower
            (MuJoCo's stability rule for soft constraints).
        contact_solimp: MuJoCo solimp (d0, d_width, width [m]) of the tip-paper contact: the
            softness of the paper's underlay (module docstring).
        home_q: Home pose of the arm joints in [rad] (the ``home`` keyframe); None: the arm's
            own (:data:`ARM_HOME_Q`). See :attr:`home`.
        arm: ``"builtin"`` (the procedural iiwa 14), or ``"iiwa14"`` or ``"panda"`` to load
            that arm from the MuJoCo Menagerie copy at ``$MENAGERIE_ROOT`` (module docstring).
    """

    timestep: float = 0.002
    paper_size_mm: tuple[float, float] = (210.0, 297.0)
    paper_centre_mm: tuple[float, float] = (600.0, 0.0)
    paper_yaw_deg: float = 0.0
    paper_thickness_mm: float = 0.1
    pen_stiffness_n_per_mm: float = 0.3
    pen_damping_ns_per_mm: float = 0.004
    pen_travel_mm: float = 6.0
    pen_tip_radius_mm: float = 0.5
    pen_mass_kg: float = 0.02
    friction: float = 0.3
    contact_timeconst: float = 0.01
    contact_solimp: tuple[float, float, float] = (0.1, 0.5, 0.001)
    home_q: tuple[float, ...] | None = None
    arm: str = "builtin"

    def __post_init__(self) -> None:
        positive = {
            "timestep": self.timestep,
            "paper_thickness_mm": self.paper_thickness_mm,
            "pen_stiffness_n_per_mm": self.pen_stiffness_n_per_mm,
            "pen_travel_mm": self.pen_travel_mm,
            "pen_tip_radius_mm": self.pen_tip_radius_mm,
            "pen_mass_kg": self.pen_mass_kg,
            "contact_timeconst": self.contact_timeconst,
        }
        for name, value in positive.items():
            if not (np.isfinite(value) and value > 0):
                raise InputError(f"CellConfig.{name}: expected a positive number, got {value}")
        w, h = self.paper_size_mm
        if not (np.isfinite(w) and np.isfinite(h) and w > 0 and h > 0):
            raise InputError(
                "CellConfig.paper_size_mm: expected positive (width, height), "
                f"got {self.paper_size_mm}"
            )
        for name in ("pen_damping_ns_per_mm", "friction"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise InputError(f"CellConfig.{name}: expected a number >= 0, got {value}")
        d0, d_width, width = self.contact_solimp
        if not (0 < d0 <= d_width < 1 and width > 0):
            raise InputError(
                "CellConfig.contact_solimp: expected (d0, d_width, width) with "
                f"0 < d0 <= d_width < 1 and width > 0, got {self.contact_solimp}"
            )
        if self.home_q is not None:
            home = np.atleast_1d(np.asarray(self.home_q, dtype=float))
            if home.shape != (7,):
                raise InputError(f"CellConfig.home_q: expected 7 joint angles, got {home.size}")
        if self.arm not in ARMS:
            raise InputError(
                f"CellConfig.arm: expected one of {', '.join(map(repr, ARMS))}, got {self.arm!r}"
            )

    @property
    def home(self) -> tuple[float, ...]:
        """Home pose of the arm joints in [rad]: ``home_q``, else the arm's own."""
        return tuple(self.home_q) if self.home_q is not None else ARM_HOME_Q[self.arm]


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


def build_spec(config: CellConfig | None = None) -> mujoco.MjSpec:
    """The cell as an editable :class:`mujoco.MjSpec` (compile it with ``.compile()``).

    Raises InputError when ``config.arm`` names a Menagerie arm and ``MENAGERIE_ROOT`` is
    unset, or the model file or one of its meshes is missing there."""
    cfg = config or CellConfig()
    if cfg.arm == "builtin":
        spec = mujoco.MjSpec()
    else:  # fitted before the cell is added, which the fitting must leave alone
        spec = _menagerie_spec(cfg.arm)
        flange = _fit_menagerie_arm(spec, cfg.arm)
    spec.modelname = "inkarm_cell"
    spec.compiler.degree = False
    spec.option.timestep = cfg.timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    # The contact was tuned with MuJoCo's default impratio; Menagerie's Panda raises it to 10
    # for grasping, which would stiffen the nib's friction.
    spec.option.impratio = 1.0
    spec.visual.global_.offwidth = 1280
    spec.visual.global_.offheight = 960
    world = spec.worldbody

    world.add_light(name="sun", pos=[0.3, 0.0, 2.5], dir=[0.0, 0.0, -1.0], diffuse=[0.8] * 3)
    world.add_geom(
        name="table",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[0.65, 0.6, 0.02],
        pos=[0.35, 0.0, -0.02],
        rgba=[0.55, 0.45, 0.35, 1.0],
        contype=0,
        conaffinity=0,
    )
    _add_paper(world, cfg)
    if cfg.arm == "builtin":
        flange = _add_arm(spec, world)
    _add_pen(flange, cfg)

    centre = np.array([*cfg.paper_centre_mm, 0.0]) / 1000.0
    rot = paper_rotation(cfg.paper_yaw_deg)
    height = 0.6
    half = 0.55 * max(cfg.paper_size_mm) / 1000.0
    world.add_camera(
        name="paper_top",
        pos=centre + [0.0, 0.0, height],
        quat=_quat(rot),
        fovy=float(np.rad2deg(2.0 * np.arctan(half / height))),
    )
    world.add_camera(
        name="overview",
        pos=[1.7, -1.3, 1.2],
        quat=_look_at([1.7, -1.3, 1.2], [0.45, 0.0, 0.45]),
        fovy=45.0,
    )
    spec.add_key(name="home", qpos=[*cfg.home, 0.0])
    return spec


def _add_paper(world, cfg: CellConfig) -> None:
    rot = paper_rotation(cfg.paper_yaw_deg)
    w, h = (v / 1000.0 for v in cfg.paper_size_mm)
    thick = cfg.paper_thickness_mm / 1000.0
    centre = np.array([cfg.paper_centre_mm[0] / 1000.0, cfg.paper_centre_mm[1] / 1000.0, 0.0])
    paper = world.add_body(name="paper", pos=centre, quat=_quat(rot))
    # The collision box reaches 5 mm down into the table (which collides with nothing): a
    # sheet-thin box lets a pressed tip tunnel through it once the penetration exceeds the
    # thickness.
    paper.add_geom(
        name="paper",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[w / 2, h / 2, _PAPER_DEPTH_M / 2],
        pos=[0.0, 0.0, thick - _PAPER_DEPTH_M / 2],
        rgba=[0.97, 0.97, 0.94, 1.0],
        **_pen_contact(cfg),
    )
    paper.add_site(name="paper_origin", pos=[-w / 2, -h / 2, thick], size=[0.003] * 3)


def _pen_contact(cfg: CellConfig) -> dict:
    """Collision settings shared by the pen tip and the paper, the only pair that touches."""
    return {
        "contype": PEN_COLLISION_BIT,
        "conaffinity": PEN_COLLISION_BIT,
        "condim": 3,
        "friction": [cfg.friction, 0.005, 0.0001],
        "solref": _contact_solref(cfg),
        "solimp": [*cfg.contact_solimp, 0.5, 2.0],
    }


def _contact_solref(cfg: CellConfig) -> list[float]:
    # MuJoCo docs: the solref time constant should be at least twice the time step.
    return [max(cfg.contact_timeconst, 2.0 * cfg.timestep), 1.0]


def _add_arm(spec: mujoco.MjSpec, world) -> mujoco.MjsFrame:
    """The procedural iiwa 14; returns its flange frame (on link 7)."""
    grey, orange = [0.85, 0.85, 0.85, 1.0], [1.0, 0.45, 0.05, 1.0]
    world.add_geom(
        name="base",
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[0.1, _LINK_OFFSETS_M[0] / 2, 0],
        pos=[0.0, 0.0, _LINK_OFFSETS_M[0] / 2],
        rgba=grey,
        contype=0,
        conaffinity=0,
    )
    parent = world
    for i in range(7):
        body = parent.add_body(name=f"link{i + 1}", pos=[0.0, 0.0, _LINK_OFFSETS_M[i]])
        limit = np.deg2rad(JOINT_RANGES_DEG[i])
        body.add_joint(
            name=JOINT_NAMES[i],
            type=mujoco.mjtJoint.mjJNT_HINGE,
            axis=_JOINT_AXES[i],
            range=[-limit, limit],
            limited=mujoco.mjtLimited.mjLIMITED_TRUE,
            armature=_ARMATURE[i],
            damping=[_DAMPING[i], 0.0, 0.0],
        )
        body.add_geom(
            name=f"link{i + 1}",
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=[0, 0, 0, 0, 0, _LINK_LENGTHS_M[i]],
            size=[_LINK_RADII_M[i], 0, 0],
            mass=_LINK_MASSES_KG[i],
            rgba=orange if i % 2 else grey,
            contype=0,
            conaffinity=0,
        )
        _add_motor(spec, i, TORQUE_LIMITS_NM[i])
        parent = body
    return parent.add_frame(pos=[0.0, 0.0, _FLANGE_OFFSET_M])


def _add_motor(spec: mujoco.MjSpec, i: int, torque_limit_nm: float) -> None:
    """Torque motor ``motor{i+1}`` on ``joint{i+1}``, saturating at +-``torque_limit_nm``."""
    act = spec.add_actuator(name=ACTUATOR_NAMES[i], target=JOINT_NAMES[i])
    act.set_to_motor()
    act.trntype = mujoco.mjtTrn.mjTRN_JOINT
    act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act.ctrlrange = [-torque_limit_nm, torque_limit_nm]


def menagerie_model_path(arm: str) -> Path:
    """The Menagerie model file of ``arm`` under ``$MENAGERIE_ROOT``; InputError when the
    variable is unset or the file is missing."""
    if arm not in MENAGERIE_MODELS:
        raise InputError(
            f"CellConfig.arm: {arm!r} is not a Menagerie arm; expected one of "
            f"{', '.join(map(repr, MENAGERIE_MODELS))}"
        )
    relative = MENAGERIE_MODELS[arm]
    root = os.environ.get(MENAGERIE_ROOT_VARIABLE, "")
    if not root:
        raise InputError(
            f"CellConfig.arm = {arm!r} loads a MuJoCo Menagerie model: set the environment "
            f"variable {MENAGERIE_ROOT_VARIABLE} to a local copy of mujoco_menagerie "
            f"(expected ${MENAGERIE_ROOT_VARIABLE}/{relative})"
        )
    path = Path(root).expanduser() / relative
    if not path.is_file():
        raise InputError(
            f"CellConfig.arm = {arm!r}: no file {path} ({MENAGERIE_ROOT_VARIABLE}={root!r}; "
            f"expected ${MENAGERIE_ROOT_VARIABLE}/{relative} from mujoco_menagerie)"
        )
    return path


def _menagerie_spec(arm: str) -> mujoco.MjSpec:
    path = menagerie_model_path(arm)
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except ValueError as e:
        raise InputError(f"CellConfig.arm = {arm!r}: cannot read {path}: {e}") from None
    # A copy without its meshes (a sparse checkout, an interrupted download) fails at compile
    # time with a terse message: name the first missing file here instead.
    mesh_dir = Path(spec.modelfiledir) / spec.meshdir
    for mesh in spec.meshes:
        if mesh.file and not (mesh_dir / mesh.file).is_file():
            raise InputError(
                f"CellConfig.arm = {arm!r}: {path} needs the mesh {mesh_dir / mesh.file}, "
                f"which is missing (an incomplete copy of mujoco_menagerie?)"
            )
    return spec


def _fit_menagerie_arm(spec: mujoco.MjSpec, arm: str) -> mujoco.MjsFrame:
    """Fit a Menagerie arm, freshly loaded, to the cell (module docstring); returns its flange
    frame."""
    where = f"CellConfig.arm = {arm!r}: {MENAGERIE_MODELS[arm]}"
    # inkarm's controller commands torques, Menagerie's models have position servos; their
    # keyframes carry their controls and no pen slide, and the cell brings its own light.
    for element in [*spec.actuators, *spec.keys, *spec.lights, *spec.pairs]:
        spec.delete(element)
    for geom in spec.geoms:  # only the pen tip and the paper may touch
        geom.contype = 0
        geom.conaffinity = 0
    joints = {joint.name: joint for joint in spec.joints}
    missing = [name for name in JOINT_NAMES if name not in joints]
    extra = sorted(set(joints) - set(JOINT_NAMES))
    if missing or extra:
        raise InputError(
            f"{where}: expected exactly the hinge joints {', '.join(JOINT_NAMES)}; "
            f"missing {missing}, unexpected {extra}"
        )
    for i, name in enumerate(JOINT_NAMES):
        joint = joints[name]
        if joint.type != mujoco.mjtJoint.mjJNT_HINGE:
            raise InputError(f"{where}: joint {name!r} is not a hinge")
        # The joint PID relies on reflected rotor inertia and some viscous friction, which
        # Menagerie's iiwa 14 leaves out: borrow the built-in arm's where the model has none.
        if joint.armature == 0.0:
            joint.armature = _ARMATURE[i]
        if joint.damping[0] == 0.0:
            joint.damping = [_DAMPING[i], *joint.damping[1:]]
        _add_motor(spec, i, ARM_TORQUE_LIMITS_NM[arm][i])
    site = spec.site(MENAGERIE_FLANGE_SITE)
    if site is None:
        raise InputError(f"{where}: no site {MENAGERIE_FLANGE_SITE!r} to mount the pen on")
    flange = site.parent.add_frame(pos=site.pos, quat=site.quat)
    flange.alt = site.alt  # the site's orientation, if given as euler, axisangle, ...
    return flange


def _add_pen(flange: mujoco.MjsFrame, cfg: CellConfig) -> None:
    """Site ``flange``, the rigid holder, the sprung pen and ``pen_cam``, in the flange frame
    (z out of the flange)."""
    flange.add_site(name="flange", pos=[0.0, 0.0, 0.0], size=[0.005] * 3)
    flange.add_geom(
        name="pen_holder",
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        fromto=[0, 0, 0, 0, 0, _PEN_HOLDER_M],
        size=[0.012, 0, 0],
        mass=0.1,
        rgba=[0.2, 0.2, 0.2, 1.0],
        contype=0,
        conaffinity=0,
    )
    cam_pos = [0.12, 0.0, 0.015]
    flange.add_camera(
        name="pen_cam",
        pos=cam_pos,
        quat=_look_at(cam_pos, [0.0, 0.0, _PEN_HOLDER_M + _PEN_SHAFT_M], up=(0.0, 0.0, -1.0)),
        fovy=50.0,
    )
    pen = flange.add_body(name="pen", pos=[0.0, 0.0, _PEN_HOLDER_M])
    travel = cfg.pen_travel_mm / 1000.0
    pen.add_joint(
        name="pen_slide",
        type=mujoco.mjtJoint.mjJNT_SLIDE,
        axis=[0.0, 0.0, -1.0],
        range=[0.0, travel],
        limited=mujoco.mjtLimited.mjLIMITED_TRUE,
        stiffness=[cfg.pen_stiffness_n_per_mm * 1000.0, 0.0, 0.0],
        springref=0.0,
        damping=[cfg.pen_damping_ns_per_mm * 1000.0, 0.0, 0.0],
        armature=0.03,
    )
    radius = cfg.pen_tip_radius_mm / 1000.0
    pen.add_geom(
        name="pen_shaft",
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        fromto=[0, 0, -0.02, 0, 0, _PEN_SHAFT_M - radius],
        size=[0.005, 0, 0],
        mass=cfg.pen_mass_kg,
        rgba=[0.1, 0.2, 0.7, 1.0],
        contype=0,
        conaffinity=0,
    )
    pen.add_geom(
        name="pen_tip",
        type=mujoco.mjtGeom.mjGEOM_SPHERE,
        size=[radius, 0, 0],
        pos=[0.0, 0.0, _PEN_SHAFT_M],
        mass=1e-4,
        rgba=[0.05, 0.05, 0.05, 1.0],
        **_pen_contact(cfg),
    )
    pen.add_site(name="pen_tip", pos=[0.0, 0.0, _PEN_SHAFT_M + radius], size=[0.001] * 3)


def build_model(config: CellConfig | None = None) -> mujoco.MjModel:
    """The compiled cell model. Call it twice to get a plant model and an independent
    kinematic model for the controller."""
    return build_spec(config).compile()


def default_gains(arm: str = "builtin") -> PIDGains:
    """Joint PID gains for ``arm`` (:data:`ARMS`) at a control period of 2 to 6 ms: 40 to 75
    rad/s of closed-loop bandwidth, integral time 0.1 s, saturation at the arm's torque limits.

    The limit is the sampled derivative term on the lightest coupled mode (joints 1 and 3
    turning against each other, their inertias coupled by M_13 ~ M_33): T max eig(M^-1 K_d)
    must stay well below about 2 (explicit damping). Over the sheet it is at most 1.04 at
    T = 6 ms and 0.70 at 4 ms, hence the low K_d of joints 1 and 3; the gains still draw when
    doubled at 6 ms.

    The Panda (Menagerie's link inertias, 0.1 kg m^2 of armature per joint) couples joints 1
    and 3 more tightly: with the iiwa's gains its sampled loop (PID every 6 ms on the linearised
    arm, M from the home pose and 16 poses over the sheet) has a pole at 2.2, outside the unit
    circle. Halving K_p and K_d of joints 1 and 3 and slowing the integral (K_i = 2 K_p, 0.5 s)
    brings every pole inside (largest 0.988, the slow integral pole; the iiwa's is 0.966). Both
    arms saturate at their own torque limits, the integral term at a quarter of them at most."""
    if arm not in ARMS:
        raise InputError(f"default_gains: expected an arm in {ARMS}, got {arm!r}")
    kp = np.array([4000.0, 4000.0, 1500.0, 1500.0, 250.0, 150.0, 100.0])
    kd = np.array([120.0, 160.0, 30.0, 60.0, 10.0, 6.0, 4.0])
    ki = 10.0 * kp
    if arm == "panda":
        kp *= [0.5, 1.0, 0.5, 1.0, 1.0, 1.0, 1.0]
        kd *= [0.5, 1.0, 0.5, 1.0, 1.0, 1.0, 1.0]
        ki = 2.0 * kp
    torque_limit = np.array(ARM_TORQUE_LIMITS_NM[arm])
    integral_limit = np.minimum([30.0, 30.0, 15.0, 15.0, 8.0, 4.0, 4.0], 0.25 * torque_limit)
    return PIDGains(kp=kp, ki=ki, kd=kd, torque_limit=torque_limit, integral_limit=integral_limit)


def joint_ranges(model: mujoco.MjModel) -> np.ndarray:
    """Ranges (7, 2) in [rad], rows (lower, upper), of the arm joints ``joint1..joint7``."""
    ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name) for name in JOINT_NAMES]
    if min(ids) < 0:
        raise InputError(f"joint_ranges: the model lacks one of the joints {JOINT_NAMES}")
    return model.jnt_range[ids].copy()
