"""A graphite pencil: a line whose darkness grows with the contact force, textured like a
scanned pencil line of a chosen grade (seed 002, Al-Meraj, ch. 4).

While the pen moves, the canvas lays the plain mark of :meth:`PencilInk.mark`, a line of the
grade's width whose opacity grows with the force and saturates,

    a(F) = a_max (1 - exp(-F / F0)).

When the pen lifts, :meth:`PencilInk.texture_stroke` replaces the stroke with the grade's
texture synthesized along its path (:mod:`inkarm.ink.pencil_synthesis`, ch. 4.2), driven by
the force along it: the strip has one row per pixel of arc length (positions and forces
interpolated along the path); a row's texture darkness is scaled by a(F) / a(F_ref), F_ref
the force the profile's scan was drawn with (so a stroke at F_ref has the profile's own
statistics, a lighter press a lighter line), and rows where a(F) = 0 stay blank. Each page
pixel the plain stroke covered takes the texel of the nearest path sample k at its signed
distance across the path, times the plain mark's anti-aliased edge there, c / a(F_k) (c the
plain coverage, clipped to [0, 1]: 1 inside the line, the pixel's area inside the capsule at
its edge). The thesis's final 3x3 Gaussian blur (Fig. 4.6) is the synthesis's step 3, in the
strip, where it keeps the repaired co-occurrence statistics
(:func:`inkarm.ink.pencil_synthesis.smooth`); blurring again on the page would undo them,
and the line's aliasing is filtered by that edge instead. The texture is synthesized once
per stroke, at the lift, not at every physics step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from inkarm.errors import InkarmError, InputError
from inkarm.ink.checks import FORCE_SCALE_RANGE_N, WIDTH_RANGE_MM, require_opacity, require_range
from inkarm.ink.pencil_profile import PencilProfile, resolve_profile
from inkarm.ink.pencil_synthesis import RepairConfig, initial_fill, repair, smooth


@dataclass(frozen=True)
class PencilInk:
    """A graphite pencil (see the module docstring).

    Attributes (each refused outside its range with an InputError keyed by the field):
        width_mm: Line width in [mm], in [0.01, 25]; None: the grade's (its profile's) width.
        max_opacity: Darkness at full load in (0, 1].
        f0_n: Force scale of the saturation in [N], in [0.001, 1000].
        grade: A shipped grade ("2H", "H", "F", "HB", "B", "3B", "6B", "8B") or the path of a
            profile file (``inkarm pencil extract``).
        texture: Whether strokes get the grade's texture at the lift (False: the plain
            force-dependent darkness only).
        seed: Seed of the texture's random draws (stroke k uses the seed and k).
    """

    width_mm: float | None = None
    max_opacity: float = 0.9
    f0_n: float = 0.7
    grade: str = "HB"
    texture: bool = True
    seed: int = 0

    def __post_init__(self) -> None:
        if self.width_mm is not None:
            require_range("PencilInk", "width_mm", self.width_mm, WIDTH_RANGE_MM, "a width [mm]")
        require_range("PencilInk", "f0_n", self.f0_n, FORCE_SCALE_RANGE_N, "a force scale [N]")
        require_opacity("PencilInk", "max_opacity", self.max_opacity)
        if not (float(self.seed).is_integer() and 0 <= self.seed < 2**63):
            raise InputError(f"PencilInk expects a seed that is an integer >= 0, got "
                             f"{self.seed!r}", key="seed", value=self.seed)
        try:
            profile = resolve_profile(self.grade)
        except InkarmError as e:
            if e.key is None:
                e.key = "grade"
            raise
        # held, not a field: mark() runs at every physics step, and resolving a file grade
        # stats the file
        object.__setattr__(self, "_profile", profile)

    @property
    def profile(self) -> PencilProfile:
        """The grade's texture statistics, resolved when the ink is made."""
        return self._profile

    @property
    def line_width_mm(self) -> float:
        """The line's width in [mm]: ``width_mm`` or the grade's."""
        return self.profile.width_mm if self.width_mm is None else float(self.width_mm)

    def opacity(self, force_n: float) -> float:
        """a(F) of the module docstring for a force in [N]."""
        return self.max_opacity * (1.0 - math.exp(-force_n / self.f0_n))

    def mark(self, force_n: float, speed_mm_s: float) -> tuple[float, float]:
        return self.line_width_mm, self.opacity(force_n)

    def texture_stroke(self, points_px: np.ndarray, forces_n: np.ndarray,
                       coverage: np.ndarray, origin: tuple[int, int], px_per_mm: float,
                       stroke_index: int) -> np.ndarray:
        """The textured darkness of one stroke on a box of the page.

        Args:
            points_px: (N, 2) pen positions (u, v) in pixel-index coordinates of the page
                (u along columns, v along rows, pixel centres at integers), in touch order.
            forces_n: (N,) contact forces in [N].
            coverage: (H, W) the plain stroke's darkness on the box; the texture lands on its
                inked pixels, faded by its anti-aliased edge.
            origin: (row, column) of the box's first pixel on the page.
            px_per_mm: Page resolution [px/mm].
            stroke_index: Which stroke of the page (seeds its draws).

        Returns:
            (H, W) darkness in [0, 1]; unchanged ``coverage`` when texture is off.
        """
        if not self.texture:
            return coverage
        profile = self.profile
        centres, forces, tangents = _resample(np.asarray(points_px, float),
                                              np.asarray(forces_n, float))
        plain = np.array([self.opacity(f) for f in forces])  # a(F) along the path
        gain = plain / self.opacity(profile.reference_force_n)
        widths = np.where(gain > 0, self.line_width_mm * px_per_mm, 0.0)
        rng = np.random.default_rng([int(self.seed), int(stroke_index)])
        grey, mask = initial_fill(profile, widths, rng)
        grey, _ = repair(grey, mask, profile, rng, RepairConfig())
        grey = smooth(grey, mask, profile)
        strip = np.where(mask, (1.0 - grey / 255.0) * gain[:, None], 0.0)
        out = np.zeros(coverage.shape)
        rows, cols = np.nonzero(coverage > 0)
        if rows.size:
            values, nearest = _texels(strip, centres, tangents,
                                      np.column_stack([cols + origin[1], rows + origin[0]]))
            edge = np.clip(coverage[rows, cols] / np.maximum(plain[nearest], 1e-12), 0.0, 1.0)
            out[rows, cols] = values * edge
        return np.clip(out, 0.0, 1.0)


def _resample(points: np.ndarray, forces: np.ndarray):
    """Path samples one pixel of arc length apart (or fewer, at most 1 px): centres (N, 2),
    forces (N,) and unit tangents (N, 2)."""
    step = np.r_[True, np.any(np.abs(np.diff(points, axis=0)) > 1e-9, axis=1)]
    points, forces = points[step], forces[step]
    if points.shape[0] == 1:
        return points.copy(), forces.copy(), np.array([[0.0, 1.0]])
    arc = np.r_[0.0, np.cumsum(np.hypot(*np.diff(points, axis=0).T))]
    s = np.linspace(0.0, arc[-1], math.ceil(arc[-1]) + 1)  # at least 2: the points differ
    centres = np.column_stack([np.interp(s, arc, points[:, 0]), np.interp(s, arc, points[:, 1])])
    tangents = np.gradient(centres, axis=0)
    norm = np.hypot(tangents[:, 0], tangents[:, 1])[:, None]
    tangents = np.where(norm > 1e-12, tangents / np.maximum(norm, 1e-12), [0.0, 1.0])
    return centres, np.interp(s, arc, forces), tangents


def _texels(strip: np.ndarray, centres: np.ndarray, tangents: np.ndarray,
            pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The strip's value for each page pixel (u, v): row = the nearest path sample, column =
    the pixel's signed distance across the path there, rounded (0 beyond the strip); and the
    index of that sample."""
    from scipy.spatial import cKDTree

    _, k = cKDTree(centres).query(pixels)
    d = pixels - centres[k]
    across = d[:, 0] * -tangents[k, 1] + d[:, 1] * tangents[k, 0]
    half = (strip.shape[1] - 1) // 2
    col = np.rint(across).astype(np.intp) + half
    inside = (col >= 0) & (col < strip.shape[1])
    values = np.zeros(len(pixels))
    values[inside] = strip[k[inside], col[inside]]
    return values, k
