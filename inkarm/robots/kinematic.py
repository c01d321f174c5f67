"""What a controller knows about its cell: the kinematic model and the facts around it.

The kinematic model is a MuJoCo model of the robot, pen and sheet used for kinematics and rigid-
body dynamics only, also when the plant is hardware. The controller is handed this object (built
by :func:`inkarm.sim.cell.kinematic_model` from its *beliefs*: the nominal cell and robot), never
the plant's own model, so a plant that differs from it tests the controller honestly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from inkarm.core.frames import PagePlacement

if TYPE_CHECKING:
    from inkarm.robots.calibration import HeightMap


@dataclass(frozen=True, eq=False)
class KinematicModel:
    """The controller's model of the cell.

    Attributes:
        model: MuJoCo model of arm, pen and sheet (SI).
        joint_names: The actuated joints, in command order.
        tip_site: Site at the pen tip.
        placement: Where the page lies in the robot base frame.
        home_q: Home pose [rad], (n,).
        pen_stiffness_n_per_mm: Pen spring rate [N/mm].
        pen_travel_mm: Pen slide travel [mm].
        nib_friction: Nib-paper sliding friction coefficient.
        pen_preload_n: Force [N] below which the pen does not move into its holder.
        paper_stiffness_n_per_mm: Stiffness of the sheet's underlay [N/mm]; 0: rigid.
        paper_map: The calibrated height of the real sheet above the model's sheet (page frame,
            [mm]; :class:`inkarm.robots.calibration.HeightMap`), the force loop's prior of the
            surface; None: the sheet is believed flat.
    """

    model: mujoco.MjModel
    joint_names: tuple[str, ...]
    tip_site: str
    placement: PagePlacement
    home_q: np.ndarray
    pen_stiffness_n_per_mm: float
    pen_travel_mm: float
    nib_friction: float
    pen_preload_n: float = 0.0
    paper_stiffness_n_per_mm: float = 0.0
    paper_map: HeightMap | None = None

    @property
    def n(self) -> int:
        return len(self.joint_names)
