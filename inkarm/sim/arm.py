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
"""

from __future__ import annotations

from dataclasses import dataclass, field

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
        home_q: Home pose of the arm joints in [rad] (the ``home`` keyframe).
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
    home_q: tuple[float, ...] = field(default=HOME_Q)

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
        if len(self.home_q) != 7:
            raise InputError(f"CellConfig.home_q: expected 7 joint angles, got {len(self.home_q)}")


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
    """The cell as an editable :class:`mujoco.MjSpec` (compile it with ``.compile()``)."""
    cfg = config or CellConfig()
    spec = mujoco.MjSpec()
    spec.modelname = "inkarm_cell"
    spec.compiler.degree = False
    spec.option.timestep = cfg.timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
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
    _add_arm(spec, world, cfg)

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
    spec.add_key(name="home", qpos=[*cfg.home_q, 0.0])
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
        contype=PEN_COLLISION_BIT,
        conaffinity=PEN_COLLISION_BIT,
        condim=3,
        friction=[cfg.friction, 0.005, 0.0001],
        solref=_contact_solref(cfg),
        solimp=[*cfg.contact_solimp, 0.5, 2.0],
    )
    paper.add_site(name="paper_origin", pos=[-w / 2, -h / 2, thick], size=[0.003] * 3)


def _contact_solref(cfg: CellConfig) -> list[float]:
    # MuJoCo docs: the solref time constant should be at least twice the time step.
    return [max(cfg.contact_timeconst, 2.0 * cfg.timestep), 1.0]


def _add_arm(spec: mujoco.MjSpec, world, cfg: CellConfig) -> None:
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
        act = spec.add_actuator(name=ACTUATOR_NAMES[i], target=JOINT_NAMES[i])
        act.set_to_motor()
        act.trntype = mujoco.mjtTrn.mjTRN_JOINT
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.ctrlrange = [-TORQUE_LIMITS_NM[i], TORQUE_LIMITS_NM[i]]
        parent = body
    _add_pen(parent, cfg)


def _add_pen(link7, cfg: CellConfig) -> None:
    link7.add_site(name="flange", pos=[0.0, 0.0, _FLANGE_OFFSET_M], size=[0.005] * 3)
    holder_top = _FLANGE_OFFSET_M
    link7.add_geom(
        name="pen_holder",
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        fromto=[0, 0, holder_top, 0, 0, holder_top + _PEN_HOLDER_M],
        size=[0.012, 0, 0],
        mass=0.1,
        rgba=[0.2, 0.2, 0.2, 1.0],
        contype=0,
        conaffinity=0,
    )
    link7.add_camera(
        name="pen_cam",
        pos=[0.12, 0.0, 0.06],
        quat=_look_at(
            [0.12, 0.0, 0.06],
            [0.0, 0.0, holder_top + _PEN_HOLDER_M + _PEN_SHAFT_M],
            up=(0.0, 0.0, -1.0),
        ),
        fovy=50.0,
    )
    pen = link7.add_body(name="pen", pos=[0.0, 0.0, holder_top + _PEN_HOLDER_M])
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
        contype=PEN_COLLISION_BIT,
        conaffinity=PEN_COLLISION_BIT,
        condim=3,
        friction=[cfg.friction, 0.005, 0.0001],
        solref=_contact_solref(cfg),
        solimp=[*cfg.contact_solimp, 0.5, 2.0],
    )
    pen.add_site(name="pen_tip", pos=[0.0, 0.0, _PEN_SHAFT_M + radius], size=[0.001] * 3)


def build_model(config: CellConfig | None = None) -> mujoco.MjModel:
    """The compiled cell model. Call it twice to get a plant model and an independent
    kinematic model for the controller."""
    return build_spec(config).compile()


def default_gains() -> PIDGains:
    """Joint PID gains for this arm at a control period of 2 to 6 ms: 40 to 75 rad/s of
    closed-loop bandwidth, integral time 0.1 s, saturation at the iiwa 14 torque limits.

    The limit is the sampled derivative term on the lightest coupled mode (joints 1 and 3
    turning against each other, their inertias coupled by M_13 ~ M_33): T max eig(M^-1 K_d)
    must stay well below about 2 (explicit damping). Over the sheet it is at most 1.04 at
    T = 6 ms and 0.70 at 4 ms, hence the low K_d of joints 1 and 3; the gains still draw when
    doubled at 6 ms."""
    kp = np.array([4000.0, 4000.0, 1500.0, 1500.0, 250.0, 150.0, 100.0])
    return PIDGains(
        kp=kp,
        ki=10.0 * kp,
        kd=np.array([120.0, 160.0, 30.0, 60.0, 10.0, 6.0, 4.0]),
        torque_limit=np.array(TORQUE_LIMITS_NM),
        integral_limit=np.array([30.0, 30.0, 15.0, 15.0, 8.0, 4.0, 4.0]),
    )


def joint_ranges(model: mujoco.MjModel) -> np.ndarray:
    """Ranges (7, 2) in [rad], rows (lower, upper), of the arm joints ``joint1..joint7``."""
    ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name) for name in JOINT_NAMES]
    if min(ids) < 0:
        raise InputError(f"joint_ranges: the model lacks one of the joints {JOINT_NAMES}")
    return model.jnt_range[ids].copy()
