"""The plant's truth apart from the controller's belief: how the simulated world differs from
the model the controller was given.

A :class:`PlantTruth` changes only the plant. :func:`inkarm.sim.perturb.plant_model` applies the
model-level differences (paper pose, stiffness and relief, link masses, inertias and centres of
mass, a payload, link lengths, joint offsets, the pen tip's length and offset, a tilted base,
joint friction, contact) to the plant's model; :class:`MujocoPlant` applies the rest at run time
(series elasticity and backlash between motor and link, stiction, encoder resolution and noise,
velocity as the device reports it, force-sensor noise and bias, sensing and actuation delays and
read-out jitter, torque limits; the relief's contact patch follows the tip). The controller keeps
:func:`inkarm.sim.cell.kinematic_model` of the nominal cell. :meth:`PlantTruth.geometry` gives the
arm's geometric errors as :class:`inkarm.robots.geometry.GeometryErrors`, what a calibration
should find.

Every scalar field can instead be drawn at random, uniformly within a range, from a seed:
``PlantTruth(random={"mass_scale": (0.8, 1.2)}).realised(seed)`` (in a scenario, the
``[plant.random]`` table). Directions (a centre of mass's offset, a link's length error) come
from the same seed, so a truth with a seed is one definite plant.

Units: [mm], [deg], [ms], [N], [N m], [kg] as the field names say.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, fields

import numpy as np

from inkarm.core.ranges import Range, check_ranges
from inkarm.errors import InputError, closest
from inkarm.robots.geometry import GeometryErrors
from inkarm.robots.servo import velocity_units_to_rad_s

VELOCITY_MODES = ("exact", "differences", "servo")
SERVO_VELOCITY_UNIT = float(velocity_units_to_rad_s(1))  # Present Velocity's unit [rad/s]
PerJoint = float | tuple[float, ...]

RANGES = {
    "paper_height_mm": Range(-50.0, 50.0, "mm"),
    "paper_tilt_deg": Range(-20.0, 20.0, "deg"),
    "paper_tilt_axis_deg": Range(-360.0, 360.0, "deg"),
    "paper_shift_x_mm": Range(-100.0, 100.0, "mm"),
    "paper_shift_y_mm": Range(-100.0, 100.0, "mm"),
    "paper_yaw_deg": Range(-45.0, 45.0, "deg"),
    "paper_stiffness_n_per_mm": Range(0.0, 1e6, "N/mm"),
    "paper_timeconst_s": Range(0.0, 1.0, "s"),
    "nib_friction": Range(-1.0, 5.0),
    "mass_scale": Range(0.1, 10.0),
    "inertia_scale": Range(0.1, 10.0),
    "com_offset_mm": Range(0.0, 200.0, "mm"),
    "payload_kg": Range(0.0, 50.0, "kg"),
    "link_length_error_mm": Range(-50.0, 50.0, "mm"),
    "coulomb_nm": Range(0.0, 500.0, "N m"),
    "viscous_nms": Range(0.0, 500.0, "N m s/rad"),
    "elasticity_nm_per_rad": Range(0.0, 1e7, "N m/rad"),
    "backlash_deg": Range(0.0, 10.0, "deg"),
    "encoder_ticks_per_rev": Range(0.0, 1e9),
    "q_noise_rad": Range(0.0, 0.1, "rad"),
    "force_noise_n": Range(0.0, 100.0, "N"),
    "force_bias_n": Range(-100.0, 100.0, "N"),
    "sensing_delay_ms": Range(0.0, 1000.0, "ms"),
    "actuation_delay_ms": Range(0.0, 1000.0, "ms"),
    "torque_limit_scale": Range(0.0, 10.0, open_low=True),
    "relief_wave_mm": Range(0.0, 20.0, "mm"),
    "relief_wavelength_mm": Range(5.0, 2000.0, "mm"),
    "relief_wave_direction_deg": Range(-360.0, 360.0, "deg"),
    "relief_wave_phase_deg": Range(-360.0, 360.0, "deg"),
    "relief_bump_mm": Range(-20.0, 20.0, "mm"),
    "relief_bump_width_mm": Range(1.0, 2000.0, "mm"),
    "relief_bump_x_mm": Range(-2000.0, 2000.0, "mm"),
    "relief_bump_y_mm": Range(-2000.0, 2000.0, "mm"),
    "relief_cell_mm": Range(0.1, 100.0, "mm"),
    "pen_length_error_mm": Range(-50.0, 50.0, "mm"),
    "pen_offset_mm": Range(0.0, 50.0, "mm"),
    "pen_offset_direction_deg": Range(-360.0, 360.0, "deg"),
    "joint_offset_error_deg": Range(-10.0, 10.0, "deg"),
    "base_tilt_deg": Range(-30.0, 30.0, "deg"),
    "base_tilt_axis_deg": Range(-360.0, 360.0, "deg"),
    "stiction_nm": Range(0.0, 500.0, "N m"),
    "readout_jitter_ms": Range(0.0, 1000.0, "ms"),
}
# A scalar of these is the largest error (>= 0), each joint's drawn from the seed; a list gives
# each joint's signed error exactly.
MAGNITUDES = ("link_length_error_mm", "joint_offset_error_deg")


@dataclass(frozen=True)
class PlantTruth:
    """What the plant is, where it differs from the controller's model. Defaults: no difference.

    Attributes:
        paper_height_mm: Sheet surface above (+) or below (-) where the controller believes it.
        paper_tilt_deg: Tilt of the sheet about an axis in its plane [deg].
        paper_tilt_axis_deg: Direction of that axis from the page x axis [deg].
        paper_shift_x_mm, paper_shift_y_mm: Sheet displaced along the page axes [mm].
        paper_yaw_deg: Sheet turned about the vertical [deg].
        paper_stiffness_n_per_mm: Underlay stiffness [N/mm]; None: the cell's; 0: rigid.
        paper_timeconst_s: Tip-paper contact time constant [s] (hard paper: 0.002); None: the
            cell's.
        nib_friction: Tip-paper friction coefficient; None: the cell's.
        mass_scale: Every link's mass times this.
        inertia_scale: Every link's rotational inertia times this (on top of ``mass_scale``).
        com_offset_mm: Every link's centre of mass moved this far, in a seeded direction.
        payload_kg: A point mass at the flange [kg].
        link_length_error_mm: Every link's length changed by up to this [mm], seeded sign and
            size; a list: the change of each joint's link (from the previous joint to this one)
            exactly, one number per joint, the first 0 (no link before joint 0).
        joint_offset_error_deg: Each joint's link sits at q + offset when the controller believes
            q [deg]: a scalar is the largest offset (seeded sign and size), a list each joint's.
        coulomb_nm: Joint dry friction [N m] (one number for all joints, or one per joint),
            replacing the cell's nominal friction.
        viscous_nms: Extra viscous joint friction [N m s/rad].
        elasticity_nm_per_rad: Series stiffness between motor and link [N m/rad]; 0: rigid.
        backlash_deg: Total free play between motor and link [deg].
        encoder_ticks_per_rev: Encoder resolution [ticks/rev]; 0: exact.
        q_noise_rad: Standard deviation of white noise on measured joint positions [rad].
        velocity: "exact" (the simulator's), "differences" (of successive measured positions,
            as a device without a velocity sensor reports it) or "servo" (in whole units of a
            Dynamixel's Present Velocity, 0.229 rev/min).
        force_noise_n, force_bias_n: On the sensed pen force [N].
        sensing_delay_ms: Age of every reading [ms].
        actuation_delay_ms: Time before a command reaches the joints [ms].
        torque_limit_scale: The joints' torque limits times this.
        relief_wave_mm: Amplitude of a sinusoidal relief of the sheet [mm]; 0: none. The relief
            is the real sheet's height above the believed one along its normal, on top of
            ``paper_height_mm`` and the tilt: h = a sin(2 pi (p . u) / wavelength + phase), p the
            page point, u the unit vector at ``relief_wave_direction_deg`` from page x.
        relief_wavelength_mm: The wave's wavelength [mm].
        relief_wave_direction_deg: Direction of the wave vector from the page x axis [deg].
        relief_wave_phase_deg: The wave's phase at the page origin [deg].
        relief_bump_mm: Height of a Gaussian bump [mm] (negative: a dip); 0: none.
        relief_bump_width_mm: The bump's full width at half height [mm].
        relief_bump_x_mm, relief_bump_y_mm: The bump's centre in page [mm]; None: the sheet's
            centre.
        relief_file: A height map [mm] as CSV: rows from the bottom of the page up, columns from
            left to right, the first at the page origin, ``relief_cell_mm`` apart; it must
            cover the sheet. Added to the wave and the bump.
        relief_cell_mm: The file's grid spacing [mm].
        pen_length_error_mm: The real pen tip lies this much further along the pen than believed
            [mm] (a longer pen: +).
        pen_offset_mm: The real tip lies this far off the holder's axis [mm] ...
        pen_offset_direction_deg: ... in this direction in the flange's x-y plane, from its x
            axis [deg].
        base_tilt_deg: The table and the robot's base tilted together by this [deg]: in the base
            frame, gravity is rotated by this angle about the axis ...
        base_tilt_axis_deg: ... in the base's x-y plane at this direction from its x axis [deg].
        stiction_nm: Breakaway torque above Coulomb friction while a joint is stuck [N m] (one
            number, or one per joint).
        readout_jitter_ms: Each reading's age is ``sensing_delay_ms`` plus uniform(0, this) [ms].
        seed: Seed of the random draws and directions.
        random: Field name -> (low, high): drawn uniformly by :meth:`realised`.
    """

    paper_height_mm: float = 0.0
    paper_tilt_deg: float = 0.0
    paper_tilt_axis_deg: float = 0.0
    paper_shift_x_mm: float = 0.0
    paper_shift_y_mm: float = 0.0
    paper_yaw_deg: float = 0.0
    paper_stiffness_n_per_mm: float | None = None
    paper_timeconst_s: float | None = None
    nib_friction: float | None = None
    mass_scale: float = 1.0
    inertia_scale: float = 1.0
    com_offset_mm: float = 0.0
    payload_kg: float = 0.0
    link_length_error_mm: PerJoint = 0.0
    joint_offset_error_deg: PerJoint = 0.0
    coulomb_nm: PerJoint | None = None
    viscous_nms: PerJoint = 0.0
    elasticity_nm_per_rad: PerJoint = 0.0
    backlash_deg: PerJoint = 0.0
    encoder_ticks_per_rev: float = 0.0
    q_noise_rad: float = 0.0
    velocity: str = "exact"
    force_noise_n: float = 0.0
    force_bias_n: float = 0.0
    sensing_delay_ms: float = 0.0
    actuation_delay_ms: float = 0.0
    torque_limit_scale: float = 1.0
    relief_wave_mm: float = 0.0
    relief_wavelength_mm: float = 30.0
    relief_wave_direction_deg: float = 0.0
    relief_wave_phase_deg: float = 0.0
    relief_bump_mm: float = 0.0
    relief_bump_width_mm: float = 8.0
    relief_bump_x_mm: float | None = None
    relief_bump_y_mm: float | None = None
    relief_file: str | None = None
    relief_cell_mm: float = 1.0
    pen_length_error_mm: float = 0.0
    pen_offset_mm: float = 0.0
    pen_offset_direction_deg: float = 0.0
    base_tilt_deg: float = 0.0
    base_tilt_axis_deg: float = 0.0
    stiction_nm: PerJoint = 0.0
    readout_jitter_ms: float = 0.0
    seed: int = 0
    random: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if float(self.seed) != int(self.seed) or not 0 <= int(self.seed) < 2**63:
            raise InputError(f"expected a whole number >= 0, got {self.seed}", key="seed",
                             value=self.seed)
        object.__setattr__(self, "seed", int(self.seed))
        if self.velocity not in VELOCITY_MODES:
            raise InputError(f"expected one of {', '.join(VELOCITY_MODES)}, got "
                             f"{self.velocity!r}", key="velocity", value=self.velocity,
                             choices=VELOCITY_MODES)
        for name, value in vars(self).items():
            if isinstance(value, tuple) and not all(np.isfinite(value)):
                raise InputError("expected finite numbers", key=name, value=value)
            if isinstance(value, float) and not math.isfinite(value):
                raise InputError(f"expected a finite number, got {value}", key=name, value=value)
        check_ranges(self, RANGES)
        for name in MAGNITUDES:
            value = getattr(self, name)
            if np.ndim(value) == 0 and value < 0:
                raise InputError(f"expected a number >= 0 (the largest error; a list gives each "
                                 f"joint's signed error), got {value}", key=name, value=value)
        if self.relief_file is not None and not isinstance(self.relief_file, str):
            raise InputError(f"expected a file name, got {self.relief_file!r}",
                             key="relief_file", value=self.relief_file)
        scalar = {f.name for f in fields(self) if f.name in RANGES}
        for name, bounds in self.random.items():
            if name not in scalar:
                hint = closest(name, scalar)
                raise InputError(f"{name!r} cannot be drawn at random"
                                 + (f" (did you mean {hint!r}?)" if hint else ""),
                                 key=f"random.{name}", value=name, choices=sorted(scalar))
            within = RANGES[name]
            if name in MAGNITUDES:
                within = dataclasses.replace(within, low=0.0)
            for v in _pair(bounds, f"random.{name}"):
                if not within.contains(v):
                    raise InputError(f"expected a range within {within}, got {bounds}",
                                     key=f"random.{name}", value=bounds)

    @property
    def is_nominal(self) -> bool:
        """True when the plant is the controller's model."""
        return self == PlantTruth(seed=self.seed)

    def realised(self, seed: int | None = None) -> PlantTruth:
        """A definite truth: every field of :attr:`random` drawn uniformly from its range with
        ``seed`` (this truth's own seed when None)."""
        seed = self.seed if seed is None else int(seed)
        rng = np.random.default_rng([seed, 0x1A4B])
        drawn = {name: float(rng.uniform(*_pair(b, name))) for name, b in sorted(self.random.items())}
        return dataclasses.replace(self, random={}, seed=seed, **drawn)

    def per_joint(self, name: str, n: int) -> np.ndarray:
        """Field ``name`` as (n,) values (one number repeats; a list must have n)."""
        value = getattr(self, name)
        out = np.broadcast_to(np.asarray(value, dtype=float), (n,)) if np.ndim(value) == 0 \
            else np.asarray(value, dtype=float)
        if out.shape != (n,):
            raise InputError(f"expected 1 or {n} numbers (one per joint), got {len(value)}",
                             key=name, value=value)
        return out.copy()

    def directions(self, n_links: int) -> tuple[np.ndarray, np.ndarray]:
        """Seeded unit vectors (n_links, 3) for centre-of-mass offsets, and signed fractions
        in [-1, 1] (n_links,) for link-length errors."""
        rng = np.random.default_rng([self.seed, 0xC0A])
        v = rng.normal(size=(n_links, 3))
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        return v, rng.uniform(-1.0, 1.0, n_links)

    def geometry(self, joints: Sequence[str] | int) -> GeometryErrors:
        """The realised link-length, joint-offset and pen-tip errors of this truth (drawn first
        when it has random fields), for ``joints`` (their names, or their number): what a
        calibration should find.

        Link lengths: a scalar ``e`` gives joint i > 0 ``e f_i`` [mm], ``f`` the seeded fractions
        of :meth:`directions`; a list is taken as it is. Joint offsets likewise, from their own
        seeded fractions. The tip: ``(o cos(phi), o sin(phi), pen_length_error_mm)`` [mm] with
        ``o = pen_offset_mm``, ``phi = pen_offset_direction_deg``."""
        truth = self.realised() if self.random else self
        n = joints if isinstance(joints, int) else len(joints)
        lengths = truth._magnitudes("link_length_error_mm", n, truth.directions(n)[1])
        if lengths[0] != 0.0 and np.ndim(truth.link_length_error_mm) > 0:
            raise InputError(f"expected 0 first (there is no link before joint 0), got "
                             f"{lengths[0]}", key="link_length_error_mm",
                             value=truth.link_length_error_mm)
        lengths[0] = 0.0
        rng = np.random.default_rng([truth.seed, 0x0FF5])
        offsets = truth._magnitudes("joint_offset_error_deg", n, rng.uniform(-1.0, 1.0, n))
        phi = math.radians(truth.pen_offset_direction_deg)
        tip = (truth.pen_offset_mm * math.cos(phi), truth.pen_offset_mm * math.sin(phi),
               truth.pen_length_error_mm)
        return GeometryErrors(link_length_mm=tuple(lengths) if any(lengths) else (),
                              joint_offset_deg=tuple(offsets) if any(offsets) else (),
                              tip_offset_mm=tip)

    def _magnitudes(self, name: str, n: int, fractions: np.ndarray) -> np.ndarray:
        """A scalar field times the seeded ``fractions``, or its list (n,) as given."""
        value = getattr(self, name)
        if np.ndim(value) == 0:
            return float(value) * fractions
        return self.per_joint(name, n)


def _pair(bounds, key: str) -> tuple[float, float]:
    try:
        lo, hi = (float(b) for b in bounds)
    except (TypeError, ValueError):
        raise InputError(f"expected [low, high], got {bounds!r}", key=key, value=bounds) from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
        raise InputError(f"expected finite low <= high, got [{lo}, {hi}]", key=key, value=bounds)
    return lo, hi


__all__ = ["VELOCITY_MODES", "PlantTruth"]
