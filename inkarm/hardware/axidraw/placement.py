"""Where the page lies in an AxiDraw's machine frame, and the travel check.

Machine frame (:mod:`.geometry`): origin at home, the carriage parked against the upper-left
stops as seen from the front, x to the right, y towards the user, in [mm]; the carriage reaches
[0, travel_x] x [0, travel_y]. The AxiDraw convention is a sheet whose upper-left corner lies at
home. The page frame has its origin at the sheet's lower-left corner, y up, so with the sheet's
upper-left corner at machine ``origin`` (ox, oy)::

    machine x = ox + page x,        machine y = oy + (sheet height - page y).

(The emulated EBB inks its sheet by the same rule, :mod:`.ebb_machine`.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkarm.errors import InputError

TOLERANCE_MM = 1e-6


@dataclass(frozen=True)
class SheetPlacement:
    """A sheet of ``size_mm`` (width, height) with its upper-left corner at machine
    ``origin_mm``, on a machine of ``travel_mm``; ``model`` names the machine in messages."""

    size_mm: tuple[float, float]
    origin_mm: tuple[float, float] = (0.0, 0.0)
    travel_mm: tuple[float, float] = (299.974, 217.932)
    model: str = "V3"

    def to_machine(self, page_mm) -> np.ndarray:
        """Page (x, y) [mm], (..., 2) -> machine (x, y) [mm]."""
        p = np.asarray(page_mm, dtype=float)
        out = np.empty(p.shape[:-1] + (2,))
        out[..., 0] = self.origin_mm[0] + p[..., 0]
        out[..., 1] = self.origin_mm[1] + self.size_mm[1] - p[..., 1]
        return out

    def to_page(self, machine_mm) -> np.ndarray:
        """Machine (x, y) [mm] -> page (x, y) [mm]."""
        m = np.asarray(machine_mm, dtype=float)
        out = np.empty(m.shape[:-1] + (2,))
        out[..., 0] = m[..., 0] - self.origin_mm[0]
        out[..., 1] = self.size_mm[1] - (m[..., 1] - self.origin_mm[1])
        return out

    def travel_text(self) -> str:
        return (f"the AxiDraw {self.model}'s travel, x 0 to {self.travel_mm[0]:g} mm and y 0 to "
                f"{self.travel_mm[1]:g} mm from home")

    def check_strokes(self, strokes) -> None:
        """Refuse the first point of ``strokes`` (page (x, y) polylines, (N, >=2) each) that
        the carriage cannot reach, naming it and the travel."""
        for k, pts in enumerate(strokes):
            m = self.to_machine(np.asarray(pts, dtype=float)[:, :2])
            bad = ~inside(m, self.travel_mm)
            if bad.any():
                i = int(np.argmax(bad))
                p = np.asarray(pts, dtype=float)[i]
                raise InputError(
                    f"stroke {k + 1} point {i + 1} at page ({p[0]:.2f}, {p[1]:.2f}) mm is machine "
                    f"({m[i, 0]:.2f}, {m[i, 1]:.2f}) mm, beyond {self.travel_text()} (the sheet's "
                    f"upper-left corner at machine ({self.origin_mm[0]:g}, "
                    f"{self.origin_mm[1]:g}) mm; see the profile's page_origin)"
                    + self.hint(), key="placement", value=(float(p[0]), float(p[1])))

    def hint(self) -> str:
        """What to do when the sheet itself does not fit the travel."""
        (w, h), (tx, ty) = self.size_mm, self.travel_mm
        if w <= tx + TOLERANCE_MM and h <= ty + TOLERANCE_MM:
            return ""
        turn = " lay it out in landscape ([placement] landscape = true), or" \
            if h > w and h <= tx + TOLERANCE_MM and w <= ty + TOLERANCE_MM else ""
        return (f"; the {w:g} x {h:g} mm sheet is larger than the travel:{turn} draw within "
                "the travel, or use a larger machine's profile (--profile v3_a3)")

    def check_machine(self, machine_mm) -> None:
        """Refuse a machine point beyond the travel (a command the plant was given)."""
        x, y = float(machine_mm[0]), float(machine_mm[1])
        (tx, ty), tol = self.travel_mm, TOLERANCE_MM
        if not (-tol <= x <= tx + tol and -tol <= y <= ty + tol):
            raise InputError(f"machine ({x:.2f}, {y:.2f}) mm is beyond {self.travel_text()}",
                             key="placement", value=(x, y))


def inside(machine_mm: np.ndarray, travel_mm) -> np.ndarray:
    """Per point (N, 2), whether it lies in [0, travel_x] x [0, travel_y] (to 1e-6 mm)."""
    t = np.asarray(travel_mm, dtype=float)
    return np.all((machine_mm >= -TOLERANCE_MM) & (machine_mm <= t + TOLERANCE_MM), axis=-1)


__all__ = ["SheetPlacement", "inside"]
