"""Where the paper really is, learnt while drawing.

The force loop's correction z (how far beyond the model's paper the pen had to go for F = F*,
along the normal) is a measurement of the surface wherever the force has settled. A sheet is a
plane, so the loop fits

    z(x, y) = a + b (x - x0) + c (y - y0)

by least squares to those measurements (page x, y in [m]; ridge weight ``prior`` on the slopes
b, c, so that a few collinear samples do not tilt it) and feeds the plane's height at the next
reference point forward. The force integrator is left with the residual: on a tilted sheet it
no longer has to chase the slope (at 60 mm/s over 2 deg, 2 mm/s of climb, a 0.05 N lag with
k_F = 40 mm/(N s), and more at every stroke's start).

The plane is P, one part of the surface the force loop feeds forward (:mod:`inkarm.control.force`):
relief beyond a plane is the calibrated map, the field learnt where the pen has been
(:mod:`inkarm.control.heightmap`) and the measured lead.
"""

from __future__ import annotations

import numpy as np


class SurfaceEstimate:
    """Least-squares plane through (x, y, z) samples, page [m]; ``height(x, y)`` is 0 until a
    sample arrives.

    Args:
        prior: Ridge weight on the slopes [m^2] per sample-equivalent (larger: stiffer).
        refit_every: Samples between two solves of the 3 x 3 normal equations.
    """

    def __init__(self, prior: float = 1e-3, refit_every: int = 10):
        # The sums of the normal equations, on Python floats (add() runs every control period
        # while drawing): sum 1, u, v, u^2, u v, v^2 and sum z, z u, z v, with (u, v) = (x - x0,
        # y - y0).
        self._sums = [0.0] * 9
        self.prior = prior
        self.refit_every = refit_every
        self.count = 0
        self.coef = (0.0, 0.0, 0.0)
        self.origin: tuple[float, float] | None = None

    def add(self, x: float, y: float, z: float) -> None:
        if self.origin is None:
            self.origin = (x, y)
        u, v = x - self.origin[0], y - self.origin[1]
        s = self._sums
        s[0] += 1.0
        s[1] += u
        s[2] += v
        s[3] += u * u
        s[4] += u * v
        s[5] += v * v
        s[6] += z
        s[7] += z * u
        s[8] += z * v
        self.count += 1
        if self.count == 1 or self.count % self.refit_every == 0:
            self.coef = self.plane(s, self.prior)

    def restore(self, sums: list[float], count: int, coef: tuple[float, float, float],
                origin: tuple[float, float] | None) -> None:
        """Go on from a state kept elsewhere (the member's compiled period hands its own back):
        the nine sums, the sample count, the plane's coefficients and the sums' origin [mm]."""
        self._sums, self.count, self.coef, self.origin = list(sums), count, coef, origin

    @staticmethod
    def plane(sums: list[float], prior: float) -> tuple[float, float, float]:
        """(a, b, c) [m, 1, 1] from the normal equations' ``sums`` (sum 1, u, v, u^2, u v, v^2,
        z, z u, z v) with the ridge ``prior`` on the slopes (also the compiled member period's
        solve: :mod:`inkarm.control.member_lane`)."""
        n, su, sv, suu, suv, svv = sums[:6]
        normal = np.array([[n, su, sv], [su, suu, suv], [sv, suv, svv]])
        ridge = normal + np.diag([0.0, prior, prior])
        # (Python floats: height() runs every control period.)
        return tuple(np.linalg.solve(ridge + 1e-12 * np.eye(3), sums[6:]).tolist())

    def describe(self) -> str:
        """The plane in words (:func:`describe_plane`)."""
        return describe_plane(self.coef, self.count)

    def height(self, x: float, y: float) -> float:
        if self.origin is None:
            return 0.0
        a, b, c = self.coef
        x0, y0 = self.origin
        return a + b * (x - x0) + c * (y - y0)


def describe_plane(coef: tuple[float, float, float], samples: int) -> str:
    """A plane z = a + b u + c v [m] fitted to ``samples`` in words: the pen's depth beyond the
    model's sheet at the first sample (the sheet's height and the arm's sag together: what the
    commands need) and its tilt."""
    if samples == 0:
        return "no sample of the paper"
    a, b, c = coef
    return (f"the pen pressed {1000.0 * a:+.2f} mm along the normal beyond where the model "
            f"puts the sheet, on a plane tilted {np.degrees(np.arctan(np.hypot(b, c))):.2f} "
            f"deg ({samples} samples)")


__all__ = ["SurfaceEstimate", "describe_plane"]
