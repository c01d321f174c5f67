"""The page-to-robot transform: the one place where page millimetres become robot metres.

A page point p (x, y[, z]) in [mm] (x right, y up the page, z height above the paper) maps to
the robot base frame as

    r = o + R p / 1000                                         in [m]

with o the page origin (the paper's lower-left corner, on its top surface) and R the rotation
whose columns are the page axes in the robot frame. The pen points into the paper: -R[:, 2].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkarm.errors import InputError

MM_PER_M = 1000.0


@dataclass(frozen=True)
class PagePlacement:
    """Where the page lies in the robot base frame.

    Attributes:
        origin_m: Page origin in the robot base frame in [m], shape (3,). (SI: this is the
            robot side of the transform.)
        rotation: (3, 3) rotation, columns = page x, y, z axes in the robot base frame.
        size_mm: (width, height) of the sheet in [mm].
    """

    origin_m: np.ndarray
    rotation: np.ndarray
    size_mm: tuple[float, float]

    def __post_init__(self) -> None:
        origin = np.asarray(self.origin_m, dtype=float)
        rot = np.asarray(self.rotation, dtype=float)
        if origin.shape != (3,) or not np.all(np.isfinite(origin)):
            raise InputError(f"PagePlacement.origin_m: expected 3 finite numbers, got {origin}")
        if (
            rot.shape != (3, 3)
            or not np.allclose(rot.T @ rot, np.eye(3), atol=1e-6)
            or (np.linalg.det(rot) < 0)
        ):
            raise InputError(
                f"PagePlacement.rotation: expected a (3, 3) rotation, got {rot.tolist()}"
            )
        w, h = (float(v) for v in self.size_mm)
        if not (w > 0 and h > 0):
            raise InputError(
                f"PagePlacement.size_mm: expected positive (width, height), got {self.size_mm}"
            )
        object.__setattr__(self, "origin_m", origin)
        object.__setattr__(self, "rotation", rot)
        object.__setattr__(self, "size_mm", (w, h))

    @property
    def normal(self) -> np.ndarray:
        """Unit normal out of the paper in the robot frame."""
        return self.rotation[:, 2].copy()

    @property
    def pen_axis(self) -> np.ndarray:
        """Direction the pen must point (into the paper) in the robot frame."""
        return -self.rotation[:, 2]

    def to_robot(self, p_mm) -> np.ndarray:
        """Page points (N, 2|3) or (2|3,) in [mm] -> robot points (N, 3) or (3,) in [m]."""
        p = np.asarray(p_mm, dtype=float)
        page3 = np.zeros(p.shape[:-1] + (3,))
        page3[..., : p.shape[-1]] = p
        return self.origin_m + page3 @ self.rotation.T / MM_PER_M

    def to_page(self, r_m) -> np.ndarray:
        """Robot points (N, 3) or (3,) in [m] -> page points (x, y, z) in [mm]."""
        r = np.asarray(r_m, dtype=float)
        return (r - self.origin_m) @ self.rotation * MM_PER_M

    def contains(self, p_mm, margin_mm: float = 0.0) -> np.ndarray:
        """Whether page points (N, 2+) lie on the sheet, at least ``margin_mm`` from its edges."""
        p = np.atleast_2d(np.asarray(p_mm, dtype=float))
        w, h = self.size_mm
        return (
            (p[:, 0] >= margin_mm)
            & (p[:, 0] <= w - margin_mm)
            & (p[:, 1] >= margin_mm)
            & (p[:, 1] <= h - margin_mm)
        )
