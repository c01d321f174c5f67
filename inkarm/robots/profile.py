"""Robot profiles: everything that differs between machines, as data.

A profile is a TOML file (the built-in ones are in ``inkarm/robots/data/``; a user's own works
the same way, ``inkarm draw --robot my_arm.toml``)::

    name = "iiwa14"
    description = "KUKA LBR iiwa 14 R820, built in code"
    control_period_s = 0.006          # the period the gains below were tuned at [s]

    [model]                           # the kinematic model: one of
    builder = "iiwa14"                #   an arm built in code (inkarm.robots.arms.<builder>)
    # menagerie = "kuka_iiwa_14/iiwa14.xml"   a MuJoCo Menagerie file under $MENAGERIE_ROOT
    # flange_site = "attachment_site"         its site where the pen holder goes

    [pen]
    holder_mm = 100.0                 # flange -> pen body (rigid holder) [mm]
    shaft_mm = 35.0                   # pen body -> tip sphere centre [mm]

    [paper]                           # where this robot's sheet lies by default
    centre_mm = [600.0, 0.0]          # robot base frame [mm]
    size_mm = [210.0, 297.0]

    [[joints]]                        # one table per joint, base outwards
    name = "joint1"
    range_deg = [-170.0, 170.0]       # optional for Menagerie models (then the model's)
    speed_deg_s = 85.0                # datasheet speed limit [deg/s]
    torque_nm = 320.0                 # motor saturation [N m]
    home_rad = 0.0                    # home pose, pen down above the paper [rad]

    [gains]                           # joint PID at control_period_s, one number or one per joint
    kp = [...]                        # [N m/rad]; also ki [N m/(rad s)], kd [N m s/rad],
                                      # integral_limit [N m]; torque_limit defaults to torque_nm

    [drive]                           # optional: the joint drives' PID at the physics step
    kp = [...]                        # (position commands); the [gains] when absent

    [backends.dynamixel]              # what a hardware backend needs (servo ids, models, ...)

Units in the file are in the key names; the profile object holds SI (rad, rad/s, N m, m) except
the paper and pen, which are millimetres like every page quantity.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from inkarm.errors import InputError
from inkarm.io.toml import TomlReader, load_toml
from inkarm.robots.arms import BUILDER_JOINTS, BUILDERS
from inkarm.robots.gains import PIDGains

TOP_KEYS = ("name", "description", "control_period_s", "model", "pen", "paper", "joints",
            "gains", "drive", "backends")
JOINT_NAME = re.compile(r"[A-Za-z0-9_.\-]{1,64}")
JOINT_KEYS = ("name", "range_deg", "speed_deg_s", "torque_nm", "home_rad")
GAIN_KEYS = ("kp", "ki", "kd", "torque_limit", "integral_limit")
MODEL_KEYS = ("builder", "menagerie", "flange_site", "armature", "damping")


@dataclass(frozen=True)
class Joint:
    """One actuated joint. SI: [rad], [rad/s], [N m]."""

    name: str
    speed_limit: float
    torque_limit: float
    home: float
    range: tuple[float, float] | None = None


@dataclass(frozen=True)
class PenMount:
    """The pen holder on the flange, in [mm]."""

    holder_mm: float = 100.0
    shaft_mm: float = 35.0


@dataclass(frozen=True)
class ModelSource:
    """Where the kinematic (and simulated) model comes from: a builder in
    :mod:`inkarm.robots.arms` or a Menagerie file; ``armature`` [kg m^2] and ``damping``
    [N m s/rad] fill in Menagerie joints that have none."""

    builder: str | None = None
    menagerie: str | None = None
    flange_site: str = "attachment_site"
    armature: tuple[float, ...] = ()
    damping: tuple[float, ...] = ()


@dataclass(frozen=True, eq=False)
class RobotProfile:
    """A robot, as data (module docstring). Build one with :func:`load_profile`."""

    name: str
    joints: tuple[Joint, ...]
    gains: PIDGains
    model: ModelSource
    control_period_s: float = 0.006
    pen: PenMount = PenMount()
    paper_centre_mm: tuple[float, float] = (600.0, 0.0)
    paper_size_mm: tuple[float, float] = (210.0, 297.0)
    description: str = ""
    source: str = ""
    backends: Mapping[str, Mapping] = field(default_factory=dict)  # read-only by convention
    drive_gains: PIDGains | None = None

    @property
    def drive(self) -> PIDGains:
        """The joint drives' gains at the physics step (position commands): ``[drive]``, else
        ``[gains]``."""
        return self.drive_gains if self.drive_gains is not None else self.gains

    @property
    def servo_firmware(self) -> bool:
        """Its joints are Dynamixel servos with position-loop registers
        (``[backends.dynamixel] position_p``): position goals go through their firmware."""
        return "position_p" in self.backends.get("dynamixel", {})

    @property
    def n(self) -> int:
        """Number of actuated joints."""
        return len(self.joints)

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    @property
    def home_q(self) -> np.ndarray:
        """Home pose [rad], (n,)."""
        return np.array([j.home for j in self.joints])

    @property
    def speed_limits(self) -> np.ndarray:
        """Joint speed limits [rad/s], (n,)."""
        return np.array([j.speed_limit for j in self.joints])

    @property
    def torque_limits(self) -> np.ndarray:
        """Motor saturation [N m], (n,)."""
        return np.array([j.torque_limit for j in self.joints])

    def with_gains(self, **gains) -> RobotProfile:
        """The same robot with some PID gain vectors replaced (checked by :class:`PIDGains`),
        in the joint loop wherever it runs: the host's ``[gains]`` and the drives' ``[drive]``."""
        try:
            new = dataclasses.replace(self.gains, **gains)
            drive = None if self.drive_gains is None else \
                dataclasses.replace(self.drive_gains, **gains)
        except InputError as e:
            raise e.within(key="gains") from None
        return dataclasses.replace(self, gains=new, drive_gains=drive)

    def __eq__(self, other) -> bool:
        if not isinstance(other, RobotProfile):
            return NotImplemented
        return self.source == other.source and self.name == other.name and all(
            np.array_equal(getattr(self.gains, k), getattr(other.gains, k))
            and np.array_equal(getattr(self.drive, k), getattr(other.drive, k)) for k in GAIN_KEYS
        ) and (self.joints, self.model, self.pen, self.control_period_s) == (
            other.joints, other.model, other.pen, other.control_period_s)

    __hash__ = None  # type: ignore[assignment]


def load_profile(path: str | Path) -> RobotProfile:
    """Read and check the robot profile at ``path``."""
    path = Path(path)
    return parse_profile(load_toml(path, "robot profile"), source=str(path))


MAX_GAIN = 1e7  # far above any joint gain in [N m/rad], [N m/(rad s)], [N m s/rad] or [N m]


def gain_vector(rd: TomlReader, value, key: str, n: int) -> np.ndarray:
    """A PID gain: one number in [0, MAX_GAIN] for every joint, or a list of ``n``."""
    if not isinstance(value, list):
        return np.full(n, rd.number(value, key, 0.0, maximum=MAX_GAIN))
    arr = rd.array(value, key, 1)
    if arr.shape != (n,):
        raise rd.error(key, f"expected one number or a list of {n} (one per joint), got "
                       f"{len(arr)}", value=value)
    if np.any(arr < 0) or np.any(arr > MAX_GAIN):
        raise rd.error(key, f"expected numbers in [0, {MAX_GAIN:g}], got {arr.tolist()}",
                       value=value)
    return arr


def _joint(rd: TomlReader, raw, i: int, menagerie: bool) -> Joint:
    key = f"joints[{i}]"
    table = rd.table(raw, key)
    rd.keys(table, JOINT_KEYS, key)
    required = ("name", "speed_deg_s", "torque_nm", "home_rad") + (() if menagerie else
                                                                    ("range_deg",))
    for name in required:
        if name not in table:
            raise rd.error(f"{key}.{name}", "required")
    joint_range = None
    if "range_deg" in table:
        lo, hi = _pair(rd, table["range_deg"], f"{key}.range_deg")
        if not (-3600.0 <= lo < hi <= 3600.0):
            raise rd.error(f"{key}.range_deg", f"expected [lower, upper] with -3600 <= lower < upper <= 3600, got "
                           f"{[lo, hi]}", value=table["range_deg"])
        joint_range = (float(np.deg2rad(lo)), float(np.deg2rad(hi)))
    home = rd.number(table["home_rad"], f"{key}.home_rad", -100.0, maximum=100.0)
    if joint_range is not None and not joint_range[0] <= home <= joint_range[1]:
        raise rd.error(f"{key}.home_rad", f"{home} rad is outside range_deg "
                       f"{np.rad2deg(joint_range).round(3).tolist()}", value=home)
    name = rd.text(table["name"], f"{key}.name")
    if not JOINT_NAME.fullmatch(name):  # MuJoCo finds joints by name: an empty one is none
        raise rd.error(f"{key}.name", f"expected a name of letters, digits, '_', '-' or '.', "
                       f"got {name!r}", value=name)
    return Joint(
        name=name,
        # the floors are where a profile stops describing an arm that can draw (a joint slower
        # than 0.1 deg/s, a motor weaker than 1 mN m): smaller values are typos, and break the
        # time scaling and MuJoCo's actuator limits downstream
        speed_limit=float(np.deg2rad(rd.number(table["speed_deg_s"], f"{key}.speed_deg_s", 0.1,
                                               maximum=36000.0))),
        torque_limit=rd.number(table["torque_nm"], f"{key}.torque_nm", 1e-3, maximum=1e5),
        home=home,
        range=joint_range,
    )


def _pair(rd: TomlReader, value, key: str) -> tuple[float, float]:
    arr = rd.array(value, key, 1)
    if arr.shape != (2,):
        raise rd.error(key, f"expected 2 numbers, got {len(arr)}", value=value)
    return float(arr[0]), float(arr[1])


def _model(rd: TomlReader, raw, n: int) -> ModelSource:
    table = rd.table(raw, "model")
    rd.keys(table, MODEL_KEYS, "model")
    if ("builder" in table) == ("menagerie" in table):
        raise rd.error("model", "give one of builder (an arm built in code: "
                       f"{', '.join(BUILDERS)}) and menagerie (a Menagerie model file)")
    kw = {}
    if "builder" in table:
        kw["builder"] = rd.choice(table["builder"], "model.builder", tuple(BUILDERS))
        if BUILDER_JOINTS[kw["builder"]] != n:
            raise rd.error("joints", f"the {kw['builder']} builder makes "
                           f"{BUILDER_JOINTS[kw['builder']]} joints; got {n} [[joints]] tables",
                           value=n)
    else:
        kw["menagerie"] = rd.text(table["menagerie"], "model.menagerie")
        if "flange_site" in table:
            kw["flange_site"] = rd.text(table["flange_site"], "model.flange_site")
    for name in ("armature", "damping"):
        if name in table:
            kw[name] = tuple(gain_vector(rd, table[name], f"model.{name}", n).tolist())
        elif "menagerie" in kw:
            kw[name] = (0.0,) * n
    return ModelSource(**kw)


def parse_profile(data: dict, source: str = "robot profile") -> RobotProfile:
    """Check parsed TOML ``data`` (module docstring); errors name ``source`` and the key."""
    rd = TomlReader(source)
    rd.keys(data, TOP_KEYS, "")
    for name in ("name", "model", "joints", "gains"):
        if name not in data:
            raise rd.error(name, "required")
    raw_joints = data["joints"]
    if not isinstance(raw_joints, list) or not raw_joints:
        raise rd.error("joints", "expected an array of [[joints]] tables, one per joint")
    n = len(raw_joints)
    model_table = rd.table(data["model"], "model")
    joints = tuple(_joint(rd, j, i, "menagerie" in model_table) for i, j in enumerate(raw_joints))
    names = [j.name for j in joints]
    if len(set(names)) != n:
        raise rd.error("joints", f"joint names repeat: {names}", value=names)
    model = _model(rd, model_table, n)  # before the gains: a joint count the builder cannot make
    pid = _gains(rd, data["gains"], "gains", joints, source)
    drive = _gains(rd, data["drive"], "drive", joints, source) if "drive" in data else None
    pen = rd.table(data.get("pen", {}), "pen")
    rd.keys(pen, ("holder_mm", "shaft_mm"), "pen")
    paper = rd.table(data.get("paper", {}), "paper")
    rd.keys(paper, ("centre_mm", "size_mm"), "paper")
    kw = {}
    if "centre_mm" in paper:
        kw["paper_centre_mm"] = _pair(rd, paper["centre_mm"], "paper.centre_mm")
    if "size_mm" in paper:
        w, h = _pair(rd, paper["size_mm"], "paper.size_mm")
        if not (1.0 <= w <= 2000.0 and 1.0 <= h <= 2000.0):
            raise rd.error("paper.size_mm", f"expected [width, height] in [1, 2000] mm, got "
                           f"{[w, h]}")
        kw["paper_size_mm"] = (w, h)
    backends = rd.table(data.get("backends", {}), "backends")
    return RobotProfile(
        name=rd.text(data["name"], "name"),
        description=rd.text(data.get("description", ""), "description"),
        joints=joints,
        gains=pid,
        model=model,
        control_period_s=rd.number(data.get("control_period_s", 0.006), "control_period_s", 1e-4,
                                   maximum=0.1),
        pen=PenMount(**{k: rd.number(v, f"pen.{k}", 1.0, maximum=1000.0)  # [mm]: MuJoCo needs
                        for k, v in pen.items()}),                    # a holder it can draw
        source=source,
        backends={k: dict(rd.table(v, f"backends.{k}")) for k, v in backends.items()},
        drive_gains=drive,
        **kw,
    )


def _gains(rd: TomlReader, raw, key: str, joints, source: str) -> PIDGains:
    """A ``[gains]`` or ``[drive]`` table: kp, ki, kd required; torque_limit defaults to the
    joints' torque_nm, integral_limit to a quarter of it."""
    table = rd.table(raw, key)
    rd.keys(table, GAIN_KEYS, key)
    for name in ("kp", "ki", "kd"):
        if name not in table:
            raise rd.error(f"{key}.{name}", "required")
    gains = {k: gain_vector(rd, v, f"{key}.{k}", len(joints)) for k, v in table.items()}
    gains.setdefault("torque_limit", np.array([j.torque_limit for j in joints]))
    gains.setdefault("integral_limit", 0.25 * gains["torque_limit"])
    try:
        return PIDGains(**gains)
    except InputError as e:
        raise e.within(file=source, key=key) from None
