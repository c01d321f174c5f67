"""The real sheet's relief: its height above the sheet the controller believes, as a field on
the page.

The relief of a :class:`~inkarm.sim.imperfections.PlantTruth` is the sum of

- a wave ``h = a sin(2 pi (x cos(theta) + y sin(theta)) / wavelength + phase)``
  (``relief_wave_mm``, ``relief_wavelength_mm``, ``relief_wave_direction_deg``,
  ``relief_wave_phase_deg``);
- a Gaussian bump ``h = b exp(-r^2 / (2 sigma^2))``, ``sigma = w / (2 sqrt(2 ln 2))`` for the full
  width ``w`` at half height, ``r`` the distance from its centre (``relief_bump_mm``,
  ``relief_bump_width_mm``, ``relief_bump_x_mm``, ``relief_bump_y_mm``; the sheet's centre when
  those are None);
- a height map from a file, bilinear between its grid points (``relief_file``,
  ``relief_cell_mm``): CSV, one row of heights per grid line from the bottom of the page up,
  columns from left to right, the first point at the page origin (the sheet's lower-left
  corner), covering the whole sheet.

All in the page frame [mm], the height along the sheet's normal (up +), on top of the sheet's
height and tilt. :func:`relief_grid` samples it on a grid, spacing at most 1 mm, 1/20 of the
wavelength, 1/6 of the bump's width and the file's own spacing, and :class:`ReliefField` looks up
the height and its slopes there (bilinear; central differences are within 1.6 % of a wave's
slope at 20 points per wavelength) for the plant's contact patch
(:class:`inkarm.sim.perturb.ReliefFollower`). No MuJoCo here.
"""

from __future__ import annotations

import csv
import math
from array import array
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from inkarm.core.ranges import Range
from inkarm.errors import InputError
from inkarm.robots.calibration import HeightMap
from inkarm.sim.imperfections import PlantTruth

MAX_SPACING_MM = 1.0
WAVE_SAMPLES = 20  # grid points per wavelength, at least
BUMP_SAMPLES = 6  # grid points per bump width, at least
MAX_GRID_POINTS = 4_000_000  # a 2000 x 2000 grid: 16 MB of float32 in the model
FILE_HEIGHTS = Range(-20.0, 20.0, "mm")
FWHM_TO_SIGMA = 1.0 / (2.0 * math.sqrt(2.0 * math.log(2.0)))


def has_relief(truth: PlantTruth) -> bool:
    """True when ``truth`` gives the sheet a relief (a wave, a bump or a file)."""
    return truth.relief_wave_mm != 0.0 or truth.relief_bump_mm != 0.0 or \
        truth.relief_file is not None


def read_relief_file(path: str | Path, cell_mm: float, size_mm: tuple[float, float]
                     ) -> HeightMap:
    """The height map in ``path`` (module docstring), checked: numbers in every cell, rows of
    one length, heights in [-20, 20] mm, and a grid that covers a sheet of ``size_mm``
    (width, height) [mm] with points ``cell_mm`` apart. Errors name ``relief_file``."""
    path = Path(path)
    key = "relief_file"
    if not path.is_file():
        raise InputError(f"no such file: {path} (a CSV of heights in mm)", key=key,
                         value=str(path))
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as e:
        raise InputError(f"{path}: not a text file (byte {e.start} is not UTF-8): expected a "
                         "CSV of heights in mm", key=key, value=str(path)) from None
    rows = []
    for n, row in enumerate(csv.reader(text.splitlines()), start=1):
        cells = [c.strip() for c in row]
        if not any(cells) or cells[0].startswith("#"):
            continue
        try:
            values = [float(c) for c in cells]
        except ValueError:
            bad = next(c for c in cells if not _is_number(c))
            raise InputError(f"{path}: line {n}, column {cells.index(bad) + 1}: expected a "
                             f"height in mm, got {bad!r}", key=key, value=str(path)) from None
        if rows and len(values) != len(rows[0]):
            raise InputError(f"{path}: line {n} has {len(values)} heights, expected "
                             f"{len(rows[0])} as in the first row (every row one grid line "
                             "across the page)", key=key, value=str(path))
        rows.append(values)
    if not rows:
        raise InputError(f"{path}: no heights (expected CSV rows of heights in mm)", key=key,
                         value=str(path))
    z = np.array(rows, dtype=float)
    bad = ~np.isfinite(z) | (z < FILE_HEIGHTS.low) | (z > FILE_HEIGHTS.high)
    if bad.any():
        j, i = np.argwhere(bad)[0]
        raise InputError(f"{path}: row {j + 1}, column {i + 1}: expected a height in "
                         f"{FILE_HEIGHTS}, got {z[j, i]}", key=key, value=str(path))
    ny, nx = z.shape
    width, height = size_mm
    need_x = math.ceil(width / cell_mm - 1e-9) + 1
    need_y = math.ceil(height / cell_mm - 1e-9) + 1
    if nx < need_x or ny < need_y:
        raise InputError(
            f"{path}: {ny} rows x {nx} columns {cell_mm:g} mm apart cover "
            f"{(nx - 1) * cell_mm:g} x {(ny - 1) * cell_mm:g} mm; expected the whole sheet, "
            f"{width:g} x {height:g} mm: at least {need_y} rows x {need_x} columns "
            "(relief_cell_mm sets the spacing)", key=key, value=str(path))
    # (the calibration's bilinear height map: a file is the same kind of map, on a grid)
    return HeightMap(np.arange(nx) * float(cell_mm), np.arange(ny) * float(cell_mm), z)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def relief_height(truth: PlantTruth, x_mm, y_mm, size_mm: tuple[float, float],
                  file_map: HeightMap | None = None) -> np.ndarray:
    """The relief [mm] at page points (``x_mm``, ``y_mm``: arrays of one shape) of a sheet of
    ``size_mm``; ``file_map``: the truth's file, read already (read here when None)."""
    x, y = np.asarray(x_mm, dtype=float), np.asarray(y_mm, dtype=float)
    z = np.zeros(np.broadcast_shapes(x.shape, y.shape))
    if truth.relief_wave_mm != 0.0:
        theta = math.radians(truth.relief_wave_direction_deg)
        along = x * math.cos(theta) + y * math.sin(theta)
        z = z + truth.relief_wave_mm * np.sin(2.0 * math.pi * along / truth.relief_wavelength_mm
                                              + math.radians(truth.relief_wave_phase_deg))
    if truth.relief_bump_mm != 0.0:
        cx, cy = bump_centre(truth, size_mm)
        sigma = truth.relief_bump_width_mm * FWHM_TO_SIGMA
        z = z + truth.relief_bump_mm * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / (2 * sigma**2))
    if truth.relief_file is not None:
        if file_map is None:
            file_map = read_relief_file(truth.relief_file, truth.relief_cell_mm, size_mm)
        z = z + file_map.height(x, y)
    return z


def bump_centre(truth: PlantTruth, size_mm: tuple[float, float]) -> tuple[float, float]:
    """The bump's centre in page [mm]: the given one, else the sheet's centre."""
    x = truth.relief_bump_x_mm if truth.relief_bump_x_mm is not None else size_mm[0] / 2
    y = truth.relief_bump_y_mm if truth.relief_bump_y_mm is not None else size_mm[1] / 2
    return float(x), float(y)


def grid_spacing(truth: PlantTruth) -> float:
    """The largest grid spacing [mm] that resolves the relief: min(1 mm, wavelength / 20, bump
    width / 6, the file's spacing) over the parts present."""
    spacing = MAX_SPACING_MM
    if truth.relief_wave_mm != 0.0:
        spacing = min(spacing, truth.relief_wavelength_mm / WAVE_SAMPLES)
    if truth.relief_bump_mm != 0.0:
        spacing = min(spacing, truth.relief_bump_width_mm / BUMP_SAMPLES)
    if truth.relief_file is not None:
        spacing = min(spacing, truth.relief_cell_mm)
    return spacing


def check_relief(truth: PlantTruth, size_mm: tuple[float, float]) -> tuple[int, int]:
    """Refuse a relief that cannot be built (its file, read and checked; a grid of more than 4
    million points); returns the grid's (nx, ny)."""
    if truth.relief_file is not None:
        read_relief_file(truth.relief_file, truth.relief_cell_mm, size_mm)
    spacing = grid_spacing(truth)
    nx, ny = (math.ceil(s / spacing - 1e-9) + 1 for s in size_mm)
    if nx * ny > MAX_GRID_POINTS:
        raise InputError(
            f"the relief needs a {nx} x {ny} grid ({spacing:.3g} mm apart) over the "
            f"{size_mm[0]:g} x {size_mm[1]:g} mm sheet, more than {MAX_GRID_POINTS} points; "
            "expected a longer relief_wavelength_mm, a wider relief_bump_width_mm or a coarser "
            "relief_cell_mm", key="relief_wavelength_mm", value=truth.relief_wavelength_mm)
    return nx, ny


def relief_grid(truth: PlantTruth, size_mm: tuple[float, float]
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The relief sampled over the whole sheet: ``x_mm`` (nx,) from 0 to the width, ``y_mm``
    (ny,) from 0 to the height, evenly spaced at most :func:`grid_spacing` apart, and ``z_mm``
    (ny, nx), ``z_mm[j, i]`` at ``(x_mm[i], y_mm[j])``. Raises InputError as
    :func:`check_relief` does."""
    nx, ny = check_relief(truth, size_mm)
    x = np.linspace(0.0, size_mm[0], nx)
    y = np.linspace(0.0, size_mm[1], ny)
    return x, y, relief_height(truth, x[None, :], y[:, None], size_mm)


@dataclass(frozen=True, eq=False)
class ReliefField:
    """The relief on a grid, with its slopes, for looking up the tangent plane under the tip at
    every physics step: ``z_mm`` (ny, nx) at ``(i dx_mm, j dy_mm)``, ``zx``, ``zy`` its slopes
    (central differences, one-sided at the edges) [mm/mm]. :meth:`at` interpolates all three
    bilinearly (slopes continuous across cells) and holds the edges beyond the sheet."""

    z_mm: np.ndarray
    zx: np.ndarray
    zy: np.ndarray
    dx_mm: float
    dy_mm: float

    def __post_init__(self) -> None:
        # (height, slope x, slope y) per grid point, row by row, in a flat array of doubles: a
        # per-step look-up on it gives Python floats, several times cheaper than numpy scalars
        flat = array("d", np.stack([self.z_mm, self.zx, self.zy], axis=-1).ravel().tolist())
        object.__setattr__(self, "_flat", flat)

    def at(self, x_mm: float, y_mm: float) -> tuple[float, float, float]:
        """(height [mm], dh/dx, dh/dy) at one page point, on Python floats (cheap per step)."""
        ny, nx = self.z_mm.shape
        u = min(max(x_mm / self.dx_mm, 0.0), nx - 1.0)
        v = min(max(y_mm / self.dy_mm, 0.0), ny - 1.0)
        i, j = min(int(u), nx - 2), min(int(v), ny - 2)
        fu, fv = u - i, v - j
        w00, w10, w01, w11 = (1 - fu) * (1 - fv), fu * (1 - fv), (1 - fu) * fv, fu * fv
        f = self._flat
        a = 3 * (j * nx + i)  # (i, j), then (i + 1, j), (i, j + 1), (i + 1, j + 1)
        c = a + 3 * nx
        return (w00 * f[a] + w10 * f[a + 3] + w01 * f[c] + w11 * f[c + 3],
                w00 * f[a + 1] + w10 * f[a + 4] + w01 * f[c + 1] + w11 * f[c + 4],
                w00 * f[a + 2] + w10 * f[a + 5] + w01 * f[c + 2] + w11 * f[c + 5])


def relief_field(truth: PlantTruth, size_mm: tuple[float, float]) -> ReliefField:
    """:func:`relief_grid` of ``truth`` with its slopes."""
    x, y, z = relief_grid(truth, size_mm)
    dx, dy = float(x[1] - x[0]), float(y[1] - y[0])
    zy, zx = np.gradient(z, dy, dx)
    return ReliefField(z, np.ascontiguousarray(zx), np.ascontiguousarray(zy), dx, dy)


__all__ = ["ReliefField", "bump_centre", "check_relief", "grid_spacing", "has_relief", "read_relief_file",
           "relief_field", "relief_grid", "relief_height"]
