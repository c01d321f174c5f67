"""The drawing cell's configuration, as data: :class:`CellConfig` (the ``[sim]`` table of a
scenario) and :class:`Cell` (a robot in that configuration). No MuJoCo here: a scenario reads
its ``[sim]`` table without importing the simulator, so that a plotter run or ``inkarm gcode``
never loads it; :mod:`inkarm.sim.cell` builds the model."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from inkarm.core.ranges import Range, check_ranges
from inkarm.errors import InputError

if TYPE_CHECKING:
    from inkarm.robots.profile import RobotProfile

# Plausible ranges: generous for a drawing cell, finite so that MuJoCo never sees absurd numbers.
CELL_RANGES = {
    "timestep": Range(1e-5, 0.01, "s"),
    "paper_size_mm": Range(1.0, 2000.0, "mm"),  # A0 is 841 x 1189 mm
    "paper_centre_mm": Range(-5000.0, 5000.0, "mm"),
    "paper_yaw_deg": Range(-360.0, 360.0, "deg"),
    "paper_thickness_mm": Range(0.0, 10.0, "mm", open_low=True),
    "pen_stiffness_n_per_mm": Range(1e-3, 1e3, "N/mm"),
    "pen_preload_n": Range(0.0, 100.0, "N"),
    "paper_stiffness_n_per_mm": Range(0.0, 1e3, "N/mm"),
    "pen_damping_ns_per_mm": Range(0.0, 10.0, "N s/mm"),
    "pen_travel_mm": Range(0.1, 100.0, "mm"),
    "pen_tip_radius_mm": Range(0.01, 10.0, "mm"),
    "pen_mass_kg": Range(1e-4, 1.0, "kg"),
    "friction": Range(0.0, 5.0),
    "contact_timeconst": Range(0.0, 1.0, "s", open_low=True),
}


@dataclass(frozen=True)
class CellConfig:
    """Everything that can change in the drawing cell. Lengths in [mm], times in [s].

    Attributes:
        timestep: Physics time step in [s].
        paper_size_mm: (width, height) of the sheet in [mm]; None: the robot profile's.
        paper_centre_mm: (x, y) of the sheet's centre in the robot base frame in [mm]; None:
            the robot profile's.
        paper_yaw_deg: Rotation of the sheet about the vertical in [deg]; 0 puts the page's y
            axis along the robot's x axis (away from the robot).
        paper_thickness_mm: Sheet thickness in [mm].
        pen_stiffness_n_per_mm: Pen spring rate in [N/mm] (0.3 N/mm = 300 N/m).
        pen_preload_n: Spring force [N] holding the pen against its outer stop: the tip does
            not move into the holder below this force.
        paper_stiffness_n_per_mm: Stiffness of the underlay the sheet lies on [N/mm] (a felt
            or blotter pad: 1 N sinks the sheet 1 / k mm); 0 for a sheet on the bare table.
        pen_damping_ns_per_mm: Pen slide damping in [N s/mm].
        pen_travel_mm: Pen slide travel in [mm].
        pen_tip_radius_mm: Radius of the tip sphere in [mm].
        pen_mass_kg: Mass of the sliding pen cartridge in [kg].
        friction: Tip-paper sliding friction coefficient.
        contact_timeconst: Contact solref time constant in [s]; raised to 2 * timestep if lower
            (MuJoCo's stability rule for soft constraints).
        contact_solimp: MuJoCo solimp (d0, d_width, width [m]) of the tip-paper contact: the
            softness of the paper's underlay (module docstring).
    """

    timestep: float = 0.002
    paper_size_mm: tuple[float, float] | None = None
    paper_centre_mm: tuple[float, float] | None = None
    paper_yaw_deg: float = 0.0
    paper_thickness_mm: float = 0.1
    pen_stiffness_n_per_mm: float = 0.3
    pen_preload_n: float = 0.3
    paper_stiffness_n_per_mm: float = 2.0
    pen_damping_ns_per_mm: float = 0.004
    pen_travel_mm: float = 6.0
    pen_tip_radius_mm: float = 0.5
    pen_mass_kg: float = 0.02
    friction: float = 0.3
    contact_timeconst: float = 0.01
    contact_solimp: tuple[float, float, float] = (0.1, 0.5, 0.001)

    def __post_init__(self) -> None:
        for name in ("paper_size_mm", "paper_centre_mm"):
            value = getattr(self, name)
            if value is not None and len(value) != 2:
                raise InputError(f"expected 2 numbers, got {len(value)}", key=name, value=value)
        check_ranges(self, CELL_RANGES)
        d0, d_width, width = self.contact_solimp
        if not (0 < d0 <= d_width < 1 and width > 0):
            raise InputError(
                "expected (d0, d_width, width) with 0 < d0 <= d_width < 1 and width > 0, got "
                f"{self.contact_solimp}", key="contact_solimp", value=self.contact_solimp)


@dataclass(frozen=True, eq=False)
class Cell:
    """A drawing cell: a robot (its profile) in a cell configuration."""

    config: CellConfig
    robot: RobotProfile

    @property
    def paper_size_mm(self) -> tuple[float, float]:
        return self.config.paper_size_mm or self.robot.paper_size_mm

    @property
    def paper_centre_mm(self) -> tuple[float, float]:
        return self.config.paper_centre_mm or self.robot.paper_centre_mm

    @property
    def paper_yaw_deg(self) -> float:
        return self.config.paper_yaw_deg

    @property
    def paper_thickness_mm(self) -> float:
        return self.config.paper_thickness_mm

    @property
    def pen_stiffness_n_per_mm(self) -> float:
        return self.config.pen_stiffness_n_per_mm


__all__ = ["CELL_RANGES", "Cell", "CellConfig"]
