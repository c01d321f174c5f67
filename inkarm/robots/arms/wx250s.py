"""The Trossen/Interbotix WidowX 250 6DOF ("wx250s"), built in code with :class:`mujoco.MjSpec`.

A desktop arm of DYNAMIXEL X-series servos with a pen in its gripper. Everything here comes
from published sources:

* Kinematics, link masses and inertials, position limits: the Interbotix URDF
  ``interbotix_ros_xsarms/interbotix_xsarm_descriptions/urdf/wx250s.urdf.xacro``
  (Interbotix/interbotix_ros_manipulators); the limits are also the "Default Joint Limits" table
  and the zero-pose product-of-exponentials (M, Slist) of the Trossen docs page
  ``docs/specifications/wx250s.rst`` (TrossenRobotics/interbotix_xsarms_docs).
* Which servo drives which joint: ``docs/_data/servos_wx250s.csv`` of those docs and
  ``interbotix_xsarm_control/config/wx250s.yaml`` (IDs, shadows, velocity limits): XM430-W350 on
  the waist, shoulder (two, ID 2 + shadow 3), elbow (two, ID 4 + shadow 5), forearm roll and
  wrist angle; XL430-W250 on the wrist rotate (and the gripper).
* Servo figures at 12 V: ROBOTIS e-Manual, ``docs/en/dxl/x/xm430-w350.md`` and
  ``docs/en/dxl/x/xl430-w250.md`` (ROBOTIS-GIT/emanual).

Zero pose (every joint 0): the upper arm stands up, the forearm and the gripper point forward
(+x); all link frames are aligned with the base frame. Joint origins in the parent link [mm]:

    base -> waist (z)            0      0   72
    -> shoulder (y)              0      0   38.65      (shoulder axis 110.65 above the base)
    -> elbow (y)                49.75   0  250         (elbow axis at x 49.75, z 360.65)
    -> forearm_roll (x)        175      0    0
    -> wrist_angle (y)          75      0    0
    -> wrist_rotate (x)         65      0    0         (at x 364.75, z 360.65)
    -> gripper face (ee_arm)    43      0    0         (the flange: x 407.75)
    -> finger centre (ee_gripper) 23 + 27.575          (x 458.325 = the published PoE M)

Positive shoulder leans the arm forward, positive elbow and wrist_angle pitch the forearm and
the gripper down; the gripper points straight down when shoulder + elbow + wrist_angle = pi/2.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np


@dataclass(frozen=True)
class Servo:
    """Datasheet figures of a DYNAMIXEL servo at 12.0 V (ROBOTIS e-Manual) and an estimate of
    its rotor inertia, which ROBOTIS does not publish.

    Attributes:
        stall_torque_nm: Stall torque at 12.0 V [N m].
        no_load_rpm: No-load speed at 12.0 V [rev/min].
        gear_ratio: Gear reduction (motor turns per output turn).
        rotor_inertia_kg_m2: Motor rotor inertia, motor side [kg m^2] (estimate).
        frictionloss_nm: Dry (Coulomb) friction of the gear train at the output [N m] (estimate).
        damping_nms: Viscous friction of the gear train at the output [N m s/rad] (estimate).
    """

    stall_torque_nm: float
    no_load_rpm: float
    gear_ratio: float
    rotor_inertia_kg_m2: float
    frictionloss_nm: float
    damping_nms: float

    @property
    def armature(self) -> float:
        """Reflected rotor inertia at the output, J_rotor * ratio^2 [kg m^2]."""
        return self.rotor_inertia_kg_m2 * self.gear_ratio**2

    @property
    def no_load_speed_rad_s(self) -> float:
        return self.no_load_rpm * 2.0 * math.pi / 60.0


# XM430-W350: 4.1 N m @ 12.0 V (2.3 A), 46 rev/min @ 12.0 V, 353.5 : 1, coreless motor.
# XL430-W250: 1.5 N m @ 12.0 V (1.4 A), 61 rev/min @ 12.0 V, 258.5 : 1, cored motor.
# Rotor inertia (estimate, not published): taking the XM430's coreless motor (in its 28.5 mm
# wide case) for a 16 mm class motor, whose catalogue rotor inertias are 0.5 to 1 g cm^2: 0.8 g cm^2 = 8e-8 kg m^2 gives
# 8e-8 * 353.5^2 = 0.010 kg m^2 at the output. Cross-check: system identification of the
# larger MX-64 (200 : 1) found 0.012 kg m^2 of armature (Rhoban/bam, bam/params/mx64/m1.json).
# The XL430's cored motor of about the same size: 1 g cm^2 -> 1e-7 * 258.5^2 = 0.0067 kg m^2.
# Both are good to a factor of about 2.
# Friction (estimate): the same identification found 0.09 N m of dry friction and 0.012 N m s/rad
# of viscous friction at the MX-64's output (0.10 and 0.035 for the MX-106); the XM430's higher
# ratio reflects more motor-side viscous friction (x (353.5/200)^2 ~ 3), hence 0.08 N m and
# 0.03 N m s/rad per XM430 and about half for the smaller XL430. In torque (current) control
# the servo's back-EMF damping is compensated by its current loop, so it is not modelled.
SERVO_SPECS = {
    "XM430-W350": Servo(4.1, 46.0, 353.5, 8.0e-8, 0.08, 0.03),
    "XL430-W250": Servo(1.5, 61.0, 258.5, 1.0e-7, 0.04, 0.015),
}

JOINT_NAMES: tuple[str, ...] = (
    "waist",
    "shoulder",
    "elbow",
    "forearm_roll",
    "wrist_angle",
    "wrist_rotate",
)
SERVOS: tuple[str, ...] = (
    "XM430-W350",
    "XM430-W350",
    "XM430-W350",
    "XM430-W350",
    "XM430-W350",
    "XL430-W250",
)
# Servos per joint: the shoulder and the elbow are each driven by two XM430-W350 (a master and
# a "shadow" that mirrors it, wx250s.yaml `shadows`), which doubles their torque, armature and
# gear-train friction.
SERVO_COUNT: tuple[int, ...] = (1, 2, 2, 1, 1, 1)

# Published position limits [deg] (URDF; Trossen "Default Joint Limits"; the firmware limits in
# wx250s.yaml, e.g. shoulder 819..3345 ticks = (819 - 2048) * 0.088 = -108 deg).
RANGES_DEG: tuple[tuple[float, float], ...] = (
    (-180.0, 180.0),
    (-108.0, 114.0),
    (-123.0, 92.0),
    (-180.0, 180.0),
    (-100.0, 123.0),
    (-180.0, 180.0),
)

# Stall torque at 12 V times the servos per joint [N m]: 4.1, 8.2, 8.2, 4.1, 4.1, 1.5.
TORQUE_LIMITS_NM: tuple[float, ...] = tuple(
    n * SERVO_SPECS[s].stall_torque_nm for s, n in zip(SERVOS, SERVO_COUNT)
)
# No-load speed at 12 V: XM430-W350 46 rpm = 4.82 rad/s, XL430-W250 61 rpm = 6.39 rad/s.
NO_LOAD_SPEEDS_RAD_S: tuple[float, ...] = tuple(SERVO_SPECS[s].no_load_speed_rad_s for s in SERVOS)
# Derated as Interbotix does: every servo's Velocity_Limit is 131 x 0.229 rpm = 30 rpm = pi rad/s
# (wx250s.yaml; the URDF's velocity="${pi}"), below both no-load speeds.
_INTERBOTIX_VELOCITY_LIMIT_RAD_S = 131 * 0.229 * 2.0 * math.pi / 60.0
SPEED_LIMITS_RAD_S: tuple[float, ...] = tuple(
    min(v, _INTERBOTIX_VELOCITY_LIMIT_RAD_S) for v in NO_LOAD_SPEEDS_RAD_S
)

ARMATURE: tuple[float, ...] = tuple(
    n * SERVO_SPECS[s].armature for s, n in zip(SERVOS, SERVO_COUNT)
)  # [kg m^2]: 0.010, 0.020, 0.020, 0.010, 0.010, 0.0067
DAMPING: tuple[float, ...] = tuple(
    n * SERVO_SPECS[s].damping_nms for s, n in zip(SERVOS, SERVO_COUNT)
)  # [N m s/rad]
FRICTIONLOSS: tuple[float, ...] = tuple(
    n * SERVO_SPECS[s].frictionloss_nm for s, n in zip(SERVOS, SERVO_COUNT)
)  # [N m]

# Joint origins in the parent link frame [m] and joint axes (URDF).
JOINT_ORIGINS_M = (
    (0.0, 0.0, 0.072),
    (0.0, 0.0, 0.03865),
    (0.04975, 0.0, 0.25),
    (0.175, 0.0, 0.0),
    (0.075, 0.0, 0.0),
    (0.065, 0.0, 0.0),
)
JOINT_AXES = ((0, 0, 1), (0, 1, 0), (0, 1, 0), (1, 0, 0), (0, 1, 0), (1, 0, 0))
LINK_NAMES = (
    "shoulder_link",
    "upper_arm_link",
    "upper_forearm_link",
    "lower_forearm_link",
    "wrist_link",
    "gripper_link",
)
# wrist_rotate axis -> gripper front face (URDF joint ee_arm): the flange where the gripper bar,
# fingers and pen holder sit.
FLANGE_OFFSET_M = 0.043
# Flange -> finger centre (URDF ee_bar 0.023 + ee_gripper 0.027575): where the fingers clamp the
# pen holder, so the pen body starts there. The pen tip is a further 0.035 m out (the cell's
# shaft): 0.1286 m from the wrist_rotate axis origin.
PEN_HOLDER_M: float = 0.023 + 0.027575

# URDF <inertial> of each link: mass [kg], origin xyz [m] and rpy [rad] (the frame the inertia
# tensor is given in), and (ixx, iyy, izz, ixy, ixz, iyz) [kg m^2].
_HALF_PI = math.pi / 2
_URDF_INERTIALS = {
    "shoulder_link": (
        0.480879,
        (0.0000223482, 0.0000414609, 0.0066287),
        (0.0, 0.0, _HALF_PI),
        (0.000379, 0.0005557, 0.0005889, 0.0000000022, -0.0000003561, 0.0000012245),
    ),
    "upper_arm_link": (
        0.430811,
        (0.0171605, 0.0000002725, 0.191323),
        (0.0, 0.0, _HALF_PI),
        (0.003463, 0.003587, 0.0004566, -0.0000000001, -0.0000000002, 0.0004272),
    ),
    "upper_forearm_link": (
        0.234589,
        (0.107963, 0.000115876, 0.0),
        (0.0, 0.0, 0.0),
        (0.00003971, 0.0008878, 0.000888, 0.0000023528, 0.0, 0.0),
    ),
    "lower_forearm_link": (
        0.220991,
        (0.0374395, 0.00522252, 0.0),
        (math.pi, 0.0, 0.0),
        (0.00006369, 0.0001677, 0.0001834, -0.00002292, 0.0, 0.0),
    ),
    "wrist_link": (
        0.084957,
        (0.04236, -0.000010663, 0.010577),
        (0.0, 0.0, _HALF_PI),
        (0.00003082, 0.00002822, 0.00003152, 0.0000000191, 0.0000000023, 0.0000025481),
    ),
    "gripper_link": (
        0.072885,
        (0.021631, 0.0000002516, 0.01141),
        (0.0, 0.0, _HALF_PI),
        (0.00002537, 0.00001836, 0.00001674, 0.0, 0.0, 0.000000434),
    ),
}
# Parts rigidly carried by the gripper link, lumped into it; their URDF inertials, with the
# part's frame origin in the gripper link frame [m] added first. The gripper horn (prop) turns
# with the gripper servo but is nearly round; the fingers are taken closed on the pen holder
# (finger slide at its 0.015 m limit, 30 mm apart).
_GRIPPER_PARTS = (
    (  # gripper_prop_link: ee_arm + 0.0055
        (FLANGE_OFFSET_M + 0.0055, 0.0, 0.0),
        0.00434,
        (0.000846, -0.0000016817, 0.000042),
        (0.0, 0.0, _HALF_PI),
        (0.0000005923, 0.0000011156, 0.0000005743, 0.0, 0.0000003195, -0.0000000004),
    ),
    (  # gripper_bar_link: at ee_arm
        (FLANGE_OFFSET_M, 0.0, 0.0),
        0.034199,
        (0.009687, 0.0000008177, 0.004962),
        (0.0, 0.0, _HALF_PI),
        (0.0000074125, 0.00002843, 0.0000286, -0.0000000008, -0.0000000006, -0.0000013889),
    ),
    (  # left_finger_link: fingers_link (ee_arm + 0.023) + 0.015 along y
        (FLANGE_OFFSET_M + 0.023, 0.015, 0.0),
        0.016246,
        (0.013816, 0.0, 0.0),
        (math.pi, math.pi, _HALF_PI),
        (0.000004731, 0.0000015506, 0.0000037467, -0.000000456, 0.0, 0.0),
    ),
    (  # right_finger_link: fingers_link - 0.015 along y
        (FLANGE_OFFSET_M + 0.023, -0.015, 0.0),
        0.016246,
        (0.013816, 0.0, 0.0),
        (0.0, math.pi, _HALF_PI),
        (0.000004731, 0.0000015506, 0.0000037467, 0.000000456, 0.0, 0.0),
    ),
)

# Sheet in the robot base frame [mm] (x forward), as the cell's CellConfig takes it: A4
# landscape, 297 mm across (robot y) by 210 mm deep (robot x), from x = 145 to 355 mm, 69 mm in
# front of the base (its front edge is at x = 76.5 mm). With the pen vertical on the paper (or
# 40 mm above it) every joint stays at least 29 deg inside its range over the whole sheet (the
# elbow, at the near edge), and gravity takes at most 38 % of the (doubled) shoulder's stall
# torque (at the far corners). The arm reaches much
# further (pen vertical on the table out to about x = 480 mm), but gravity load and the
# servos' heating grow with reach; Trossen advise working within half extension.
PAPER_CENTRE_MM: tuple[float, float] = (250.0, 0.0)
PAPER_SIZE_MM: tuple[float, float] = (297.0, 210.0)

# Home [rad]: the pen (flange +z) straight down, its tip 40 mm above the paper centre (the pen
# of the drawing cell: flange + PEN_HOLDER_M + 0.035 m), forearm_roll and wrist_rotate at 0.
# Solved with inkarm.control.ik.solve_ik and rounded to mrad (tip within 0.1 mm, pen within
# 0.02 deg of vertical); shoulder + elbow + wrist_angle = pi/2.
HOME_Q: tuple[float, ...] = (0.0, -0.054, 0.598, 0.0, 1.027, 0.0)

# Joint PID for a PD + gravity-compensation torque controller tracking a pen path at a 6 ms
# control period (derived at HOME_Q with the cell's 0.12 kg pen and holder):
#   J = diag M(HOME_Q), armature included = 0.049, 0.092, 0.070, 0.013, 0.014, 0.0068 kg m^2
#   kp = J w^2, kd = 2 zeta J w with w = 25 rad/s, zeta = 1 (two significant digits)
#   ki = kp / 0.2 s (integral zero at 5 rad/s, a fifth of the bandwidth)
#   integral_limit = a quarter of the torque limit (enough for the servos' dry friction and
#   gravity-model errors, small enough not to wind up into a stall)
# Over the sheet M's diagonal ranges 0.024..0.114 (waist) and 0.063..0.147 (shoulder) kg m^2,
# which moves those joints' bandwidth sqrt(kp/M_ii) to 16..36 and 20..30 rad/s. Sampled-loop
# check over HOME_Q and 18 poses on and 40 mm above the sheet: T max eig(M^-1 Kd) <= 0.68 < 1
# at T = 6 ms; the linearised loop (zero-order hold, PID every 6 ms) has every pole inside
# the unit circle, largest |z| 0.964, also with one period of delay (0.962).
# These are a first, soft tuning: they leave about 1 mm of tracking error, the gear trains' dry
# friction over kp. The profile (inkarm/robots/data/wx250s.toml) draws with stiffer gains, up to
# the XM430's own position loop at Position P Gain 2000, derived there.
SUGGESTED_GAINS = {
    "kp": (31.0, 57.0, 44.0, 8.2, 9.0, 4.2),  # [N m/rad]
    "ki": (160.0, 280.0, 220.0, 41.0, 45.0, 21.0),  # [N m/(rad s)]
    "kd": (2.5, 4.6, 3.5, 0.66, 0.72, 0.34),  # [N m s/rad]
    "integral_limit": (1.0, 2.0, 2.0, 1.0, 1.0, 0.375),  # [N m]
}


def _rpy_matrix(rpy: Sequence[float]) -> np.ndarray:
    """URDF fixed-axis roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), \
        math.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def _tensor(i6: Sequence[float]) -> np.ndarray:
    ixx, iyy, izz, ixy, ixz, iyz = i6
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])


def link_inertial(name: str) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass [kg], centre of mass (3,) [m], inertia about it (3, 3) [kg m^2]) of the moving link
    ``name`` in its own frame, from the URDF; the gripper link includes its bar, horn and
    fingers."""
    mass, com, rpy, i6 = _URDF_INERTIALS[name]
    rot = _rpy_matrix(rpy)
    parts = [(mass, np.array(com, float), rot @ _tensor(i6) @ rot.T)]
    if name == "gripper_link":
        for origin, m, c, r, i in _GRIPPER_PARTS:
            rot = _rpy_matrix(r)
            parts.append((m, np.add(origin, c), rot @ _tensor(i) @ rot.T))
    total = sum(m for m, _, _ in parts)
    centre = sum(m * c for m, c, _ in parts) / total
    inertia = np.zeros((3, 3))
    for m, c, i in parts:  # parallel-axis theorem about the common centre of mass
        d = c - centre
        inertia += i + m * (d @ d * np.eye(3) - np.outer(d, d))
    return total, centre, inertia


def _set_inertial(body, mass: float, com: np.ndarray, inertia: np.ndarray) -> None:
    body.explicitinertial = True
    body.mass = mass
    body.ipos = com.tolist()
    body.fullinertia = [
        inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]
    ]


def add_motor(spec: mujoco.MjSpec, joint: str, torque_limit_nm: float) -> None:
    """Torque motor ``motor_<joint>`` on ``joint``, saturating at +-``torque_limit_nm``."""
    act = spec.add_actuator(name=f"motor_{joint}", target=joint)
    act.set_to_motor()
    act.trntype = mujoco.mjtTrn.mjTRN_JOINT
    act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act.ctrlrange = [-torque_limit_nm, torque_limit_nm]


_BLACK = [0.12, 0.12, 0.12, 1.0]
_GREY = [0.45, 0.45, 0.48, 1.0]
_CAPSULE = mujoco.mjtGeom.mjGEOM_CAPSULE
_BOX = mujoco.mjtGeom.mjGEOM_BOX
_CYLINDER = mujoco.mjtGeom.mjGEOM_CYLINDER
# Visual stand-ins for the URDF meshes, sized from their bounding boxes (in the link frames):
# (type, fromto or None, size, pos or None). No mass (the links' inertials are the URDF's), no
# contacts.
_SHAPES = {
    "shoulder_link": [(_CYLINDER, None, (0.051, 0.026, 0), (0.0, 0.0, 0.023))],
    "upper_arm_link": [
        (_CAPSULE, (0, 0, 0, 0, 0, 0.22), (0.025, 0, 0), None),
        (_CAPSULE, (0, 0, 0.22, 0.04975, 0, 0.25), (0.025, 0, 0), None),
    ],
    "upper_forearm_link": [(_CAPSULE, (0, 0, 0, 0.175, 0, 0), (0.022, 0, 0), None)],
    "lower_forearm_link": [(_CAPSULE, (0, 0, 0, 0.075, 0, 0), (0.02, 0, 0), None)],
    "wrist_link": [(_CAPSULE, (0, 0, 0, 0.065, 0, 0), (0.018, 0, 0), None)],
    "gripper_link": [
        (_BOX, None, (0.0215, 0.02, 0.0275), (0.0215, 0.0, 0.0075)),  # gripper servo mount
        (_BOX, None, (0.014, 0.0517, 0.0245), (0.057, 0.0, 0.0105)),  # gripper bar
        (_BOX, None, (0.0275, 0.008, 0.0145), (0.0815, 0.012, 0.0)),  # fingers, closed
        (_BOX, None, (0.0275, 0.008, 0.0145), (0.0815, -0.012, 0.0)),
    ],
}


def add_arm(
    spec: mujoco.MjSpec,
    joint_names: Sequence[str] = JOINT_NAMES,
    torque_limits_nm: Sequence[float] = TORQUE_LIMITS_NM,
) -> mujoco.MjsFrame:
    """Add the wx250s under ``spec.worldbody``, base at the world origin (z up, x forward).

    Each moving link is a body with the URDF's mass, centre of mass and inertia (the gripper
    link with its bar, horn and closed fingers) and capsule/box geoms that are visual only
    (contype = conaffinity = 0, no mass). Hinge joints ``joint_names`` with the published
    ranges, the servos' reflected rotor inertia as armature, their gear-train viscous and dry
    friction, and a torque motor ``motor_<name>`` each saturating at ``torque_limits_nm``.

    The gripper link's inertial sits on a welded child body ``gripper_assembly``, so masses
    that the caller mounts on the returned frame add to the link (a body with an explicit
    inertial would ignore them). Sets ``spec.compiler.degree = False``: the ranges are given
    in radians.

    Returns the flange frame on the gripper link, at its front face (URDF ``ee_arm_link``), +z
    out of the flange along the gripper (the link's +x); the pen holder goes there.
    """
    names, limits = list(joint_names), list(torque_limits_nm)
    if len(names) != 6 or len(limits) != 6:
        raise ValueError(
            f"wx250s.add_arm: expected 6 joint names and 6 torque limits, got {len(names)} and "
            f"{len(limits)}"
        )
    spec.compiler.degree = False
    world = spec.worldbody
    # The base (fixed: its published 0.539 kg does not move), the URDF mesh's bounding box:
    # x -0.157..0.0765 (its front edge), y +-0.0765, z 0..0.0716.
    world.add_geom(
        name="wx250s_base",
        type=_BOX,
        size=[0.11675, 0.0765, 0.0358],
        pos=[-0.04025, 0.0, 0.0358],
        rgba=_BLACK,
        contype=0,
        conaffinity=0,
        density=0.0,
    )
    parent = world
    for i, (name, link) in enumerate(zip(names, LINK_NAMES)):
        body = parent.add_body(name=link, pos=list(JOINT_ORIGINS_M[i]))
        # (the last link's inertial on a welded child body: see the docstring)
        carrier = body if i < 5 else body.add_body(name="gripper_assembly")
        _set_inertial(carrier, *link_inertial(link))
        lo, hi = np.deg2rad(RANGES_DEG[i])
        body.add_joint(
            name=name,
            type=mujoco.mjtJoint.mjJNT_HINGE,
            axis=list(JOINT_AXES[i]),
            range=[float(lo), float(hi)],
            limited=mujoco.mjtLimited.mjLIMITED_TRUE,
            armature=ARMATURE[i],
            damping=[DAMPING[i], 0.0, 0.0],
            frictionloss=FRICTIONLOSS[i],
        )
        for k, (kind, fromto, size, pos) in enumerate(_SHAPES[link]):
            geom = body.add_geom(
                name=f"{link}_{k}",
                type=kind,
                size=list(size),
                rgba=_GREY if i % 2 else _BLACK,
                contype=0,
                conaffinity=0,
                density=0.0,
            )
            if fromto is not None:
                geom.fromto = list(fromto)
            if pos is not None:
                geom.pos = list(pos)
        add_motor(spec, name, float(limits[i]))
        parent = body
    # Flange frame: +z along the gripper link's +x (a +90 deg turn about y).
    half = math.sqrt(0.5)
    return parent.add_frame(pos=[FLANGE_OFFSET_M, 0.0, 0.0], quat=[half, 0.0, half, 0.0])
