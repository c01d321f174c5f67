"""Dot marks on a drawn sheet: where they are on the page [mm], and which planned dot made each.

Two sources of a sheet, the same blob finder:

* an ink raster (:class:`inkarm.ink.canvas.Canvas`, the simulated sheet): darkness in [0, 1],
  row 0 at the top, pixel (i, j) centred at page ``x = (j + 1/2) / px_per_mm``,
  ``y = (n_rows - i - 1/2) / px_per_mm`` [mm] (:func:`canvas_marks`);
* an image of a real sheet, scanned or photographed (:func:`image_marks`): read with Pillow as
  darkness ``1 - L / 255``, its paper's four corners given in pixels, mapped to the page by the
  homography ``H`` with ``[x, y, 1]^T ~ H [u, v, 1]^T`` found from the corners by the
  normalised direct linear transform (:func:`homography`).

Image pixel coordinates: ``u`` to the right, ``v`` down, pixel (row i, column j) covering
``[j, j + 1) x [i, i + 1)`` (its centre at ``(j + 1/2, i + 1/2)``), as image viewers report a
pointer's position. Corners are given in page order: lower-left, lower-right, upper-right,
upper-left of the sheet, i.e. page (0, 0), (w, 0), (w, h), (0, h) [mm].

A mark is a connected blob (8-neighbours, :func:`scipy.ndimage.label`) of pixels darker than
``threshold`` above the sheet's background (the median darkness), at least ``min_area_px``
pixels; its position is the ink-weighted centroid ``c = sum(w_p p) / sum(w_p)`` over its pixels,
with ``w_p`` the darkness above the background. In an image the centroid is found in pixels
and then mapped through ``H`` (the centroid of a projected dot differs from the projected
centroid by the second order of the dot's size over the perspective's depth: far below a pixel
for dots of a few mm).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from inkarm.errors import InputError

PAGE_CORNERS = ("lower-left", "lower-right", "upper-right", "upper-left")


@dataclass(frozen=True)
class Marks:
    """Blobs found on a sheet.

    Attributes:
        page_mm: (k, 2) ink-weighted centroids in the page frame [mm], sorted by y, then x.
        area_px: (k,) pixels in each blob.
        ink: (k,) summed darkness above the background of each blob [px].
    """

    page_mm: np.ndarray
    area_px: np.ndarray
    ink: np.ndarray

    def __len__(self) -> int:
        return int(self.page_mm.shape[0])


def find_blobs(darkness: np.ndarray, threshold: float = 0.25, min_area_px: int = 4,
               inside: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Blobs of a darkness raster (rows, cols): their ink-weighted centroids (k, 2) as
    (column, row) pixel indices (pixel centres at whole numbers), areas (k,) [px] and ink (k,).

    Pixels darker than the background (the median) by more than ``threshold`` form the blobs;
    blobs smaller than ``min_area_px`` (dust, noise) are left out. ``inside`` (a boolean mask
    of the raster's shape) limits both the background and the blobs to the sheet."""
    from scipy import ndimage

    image = np.asarray(darkness, dtype=float)
    if image.ndim != 2 or min(image.shape) < 1:
        raise InputError(f"marks: expected a 2-D darkness raster, got shape {image.shape}",
                         key="darkness")
    if not np.all(np.isfinite(image)):
        raise InputError("marks: the darkness raster has NaN or infinite pixels", key="darkness")
    if not 0.0 < threshold < 1.0:
        raise InputError(f"marks: expected a threshold in (0, 1), got {threshold}",
                         key="threshold", value=threshold)
    if inside is None:
        inside = np.ones(image.shape, dtype=bool)
    if not inside.any():
        raise InputError("marks: no pixel of the raster lies on the sheet", key="corners")
    weight = np.where(inside, np.clip(image - float(np.median(image[inside])), 0.0, None), 0.0)
    labels, count = ndimage.label(weight > threshold, structure=np.ones((3, 3), dtype=bool))
    if count == 0:
        empty = np.zeros((0, 2))
        return empty, np.zeros(0, dtype=int), np.zeros(0)
    index = np.arange(1, count + 1)
    area = np.asarray(ndimage.sum_labels(np.ones_like(weight), labels, index), dtype=int)
    ink = np.asarray(ndimage.sum_labels(weight, labels, index), dtype=float)
    rows_cols = np.asarray(ndimage.center_of_mass(weight, labels, index), dtype=float)
    keep = area >= min_area_px
    centres = rows_cols[keep][:, ::-1].reshape(-1, 2)
    return centres, area[keep], ink[keep]


def _sorted(page_mm: np.ndarray, area: np.ndarray, ink: np.ndarray) -> Marks:
    order = np.lexsort((page_mm[:, 0], page_mm[:, 1])) if len(page_mm) else np.zeros(0, int)
    return Marks(page_mm[order], area[order], ink[order])


def raster_marks(darkness: np.ndarray, px_per_mm: float, threshold: float = 0.25,
                 min_area_px: int = 4) -> Marks:
    """The marks of an ink raster in the canvas convention (module docstring) at
    ``px_per_mm`` [px/mm], in page [mm]."""
    if not (np.isfinite(px_per_mm) and px_per_mm > 0):
        raise InputError(f"marks: expected px_per_mm > 0, got {px_per_mm}", key="px_per_mm",
                         value=px_per_mm)
    centres, area, ink = find_blobs(darkness, threshold, min_area_px)
    n_rows = np.asarray(darkness).shape[0]
    page = np.column_stack(((centres[:, 0] + 0.5) / px_per_mm,
                            (n_rows - centres[:, 1] - 0.5) / px_per_mm))
    return _sorted(page, area, ink)


def canvas_marks(canvas, threshold: float = 0.25, min_area_px: int = 4) -> Marks:
    """The marks on a :class:`~inkarm.ink.canvas.Canvas` (its ``image`` and ``px_per_mm``)."""
    return raster_marks(np.array(canvas.image), canvas.px_per_mm, threshold, min_area_px)


def homography(src, dst) -> np.ndarray:
    """The (3, 3) homography ``H`` (``H[2, 2] = 1``) with ``dst ~ H src`` from k >= 4 point
    pairs (k, 2), by the direct linear transform on Hartley-normalised points (each set moved
    to its centroid and scaled to a mean distance sqrt(2)): the right singular vector of the
    smallest singular value of the stacked rows

        [-u, -v, -1, 0, 0, 0, x u, x v, x]  and  [0, 0, 0, -u, -v, -1, y u, y v, y].

    Raises InputError for fewer than 4 pairs, or points of which three lie on a line."""
    a, b = np.asarray(src, dtype=float), np.asarray(dst, dtype=float)
    if a.ndim != 2 or a.shape[1] != 2 or a.shape != b.shape or len(a) < 4:
        raise InputError(f"homography: expected two (k, 2) point sets, k >= 4, of the same "
                         f"shape, got {a.shape} and {b.shape}", key="corners")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise InputError("homography: the points must be finite", key="corners")
    for pts in (a, b):
        if len(pts) == 4 and _three_on_a_line(pts):
            raise InputError(f"homography: three of the corners {pts.tolist()} lie on a line "
                             "(a sheet's four corners must form a quadrilateral)",
                             key="corners", value=pts.tolist())
    ta, tb = _normaliser(a), _normaliser(b)
    pa, pb = _apply(ta, a), _apply(tb, b)
    rows = []
    for (u, v), (x, y) in zip(pa, pb, strict=True):
        rows.append([-u, -v, -1.0, 0.0, 0.0, 0.0, x * u, x * v, x])
        rows.append([0.0, 0.0, 0.0, -u, -v, -1.0, y * u, y * v, y])
    _, s, vt = np.linalg.svd(np.asarray(rows))
    if s[-2] < 1e-9 * s[0]:
        raise InputError("homography: the points do not determine a homography (degenerate)",
                         key="corners")
    h = np.linalg.inv(tb) @ vt[-1].reshape(3, 3) @ ta
    return h / h[2, 2]


def _three_on_a_line(pts: np.ndarray) -> bool:
    scale = float(np.ptp(pts, axis=0).max()) or 1.0
    for skip in range(4):
        p, q, r = np.delete(pts, skip, axis=0)
        area = abs((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]))
        if area < 1e-6 * scale * scale:
            return True
    return False


def _normaliser(pts: np.ndarray) -> np.ndarray:
    centre = pts.mean(axis=0)
    spread = float(np.mean(np.linalg.norm(pts - centre, axis=1))) or 1.0
    s = np.sqrt(2.0) / spread
    return np.array([[s, 0.0, -s * centre[0]], [0.0, s, -s * centre[1]], [0.0, 0.0, 1.0]])


def _apply(h: np.ndarray, pts: np.ndarray) -> np.ndarray:
    p = np.asarray(pts, dtype=float)
    w = p @ h[:, :2].T + h[:, 2]
    return w[:, :2] / w[:, 2:3]


def apply_homography(h: np.ndarray, pts) -> np.ndarray:
    """Points (k, 2) mapped by the homography ``h``: ``(x, y) = (H [u, v, 1])[:2] / (H [u, v,
    1])[2]``."""
    return _apply(np.asarray(h, dtype=float), np.atleast_2d(pts))


def sheet_homography(corners_px, page_size_mm: tuple[float, float]) -> np.ndarray:
    """The homography from image pixels (u right, v down) to page [mm] (x right, y up) of a
    sheet of ``page_size_mm`` whose corners lie at ``corners_px`` (4, 2), in the order
    :data:`PAGE_CORNERS`."""
    w, h = (float(v) for v in page_size_mm)
    if not (w > 0 and h > 0):
        raise InputError(f"marks: expected a positive page size [mm], got {page_size_mm}",
                         key="page_size_mm", value=page_size_mm)
    corners = np.asarray(corners_px, dtype=float)
    if corners.shape != (4, 2):
        raise InputError(f"marks: expected the sheet's 4 corners as (u, v) pixels in the order "
                         f"{', '.join(PAGE_CORNERS)}, got shape {corners.shape}",
                         key="corners", value=np.asarray(corners_px).tolist())
    page = np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]])
    return homography(corners, page)


def read_darkness(path: str | Path) -> np.ndarray:
    """An image file as darkness ``1 - L / 255`` (rows, cols), row 0 at the top (Pillow's
    greyscale "L" of any mode it reads)."""
    from PIL import Image, UnidentifiedImageError

    path = Path(path)
    if not path.is_file():
        raise InputError(f"no such image file: {path}", file=str(path))
    try:
        with Image.open(path) as im:
            grey = np.asarray(im.convert("L"), dtype=float)
    except (UnidentifiedImageError, OSError) as e:
        raise InputError(f"cannot read {path} as an image ({e})", file=str(path)) from None
    return 1.0 - grey / 255.0


def image_marks(image, corners_px, page_size_mm: tuple[float, float],
                threshold: float = 0.25, min_area_px: int = 4) -> Marks:
    """The marks of a scanned or photographed sheet (an image file, or a darkness raster), in
    page [mm]: blobs inside the sheet's corners ``corners_px`` (module docstring), their
    centroids mapped by :func:`sheet_homography`. Blobs whose centre falls off the sheet (the
    desk, the sheet's shadow) are left out."""
    darkness = read_darkness(image) if isinstance(image, str | Path) else np.asarray(image)
    h = sheet_homography(corners_px, page_size_mm)
    inside = _inside_quadrilateral(np.asarray(corners_px, dtype=float), darkness.shape[:2])
    centres, area, ink = find_blobs(darkness, threshold, min_area_px, inside)
    page = apply_homography(h, centres + 0.5) if len(centres) else np.zeros((0, 2))
    return _sorted(page, area, ink)


def _inside_quadrilateral(corners: np.ndarray, shape: tuple[int, ...],
                          inset_px: float = 1.5) -> np.ndarray:
    """Pixels whose centres lie inside the convex quadrilateral ``corners`` (u, v) by at least
    ``inset_px`` (the sheet's own edge is no mark)."""
    v = np.arange(shape[0])[:, None] + 0.5
    u = np.arange(shape[1])[None, :] + 0.5
    area = sum(corners[k - 1, 0] * corners[k, 1] - corners[k, 0] * corners[k - 1, 1]
               for k in range(4))
    sign = 1.0 if area > 0 else -1.0
    inside = np.ones(shape, dtype=bool)
    for k in range(4):
        (u0, v0), (u1, v1) = corners[k], corners[(k + 1) % 4]
        length = float(np.hypot(u1 - u0, v1 - v0))
        inside &= sign * ((u1 - u0) * (v - v0) - (v1 - v0) * (u - u0)) >= inset_px * length
    return inside


def rendered_mark(path_mm, force_n, time_s, ink, px_per_mm: float, threshold: float = 0.25,
                  min_area_px: int = 4) -> np.ndarray:
    """Where the mark of one dot should be found [mm] (2,): the pen's contact path
    ``path_mm`` (r, 2) [mm] with its forces ``force_n`` (r,) [N] at times ``time_s`` (r,) [s]
    inked with ``ink`` (an ink model, :mod:`inkarm.ink.inks`) on a patch of page at
    ``px_per_mm``, and its blob's centroid found as :func:`raster_marks` finds it (the largest
    blob, by ink).

    A pen that lands, settles and lifts slides a little (a few tenths of a mm as the arm takes
    up the force): its mark's centroid is not where it rested. Rendering the contact path as the
    controller's model puts it gives the mark's offset from the resting point. Raises
    InputError when the path lays no ink."""
    from inkarm.ink.canvas import Canvas

    path = np.asarray(path_mm, dtype=float).reshape(-1, 2)
    force = np.asarray(force_n, dtype=float).reshape(-1)
    times = np.asarray(time_s, dtype=float).reshape(-1)
    if not len(path) or path.shape[0] != force.shape[0] or force.shape != times.shape:
        raise InputError(f"rendered_mark: expected a path (r, 2) with r forces and times, r >= "
                         f"1, got {path.shape}, {force.shape}, {times.shape}", key="path_mm")
    pad = 5.0  # [mm]: wider than any pen's line
    lo = path.min(axis=0) - pad
    size = tuple(float(v) for v in path.max(axis=0) + pad - lo)
    canvas = Canvas(size_mm=size, px_per_mm=px_per_mm, ink=ink)
    for p, f, t in zip(path - lo, force, times, strict=True):
        canvas.touch(p, max(float(f), 0.0), float(t))
    canvas.lift()
    found = canvas_marks(canvas, threshold, min_area_px)
    if not len(found):
        raise InputError("rendered_mark: the contact path lays no ink (a force below the ink's "
                         "threshold?)", key="force_n")
    return found.page_mm[int(np.argmax(found.ink))] + lo


def common_shift(planned_mm, marks: Marks | np.ndarray, radius_mm: float,
                 max_shift_mm: float) -> np.ndarray:
    """The shift (2,) [mm] of the whole pattern of marks from the planned dots (k, 2) [mm]: an
    arm or pen not yet calibrated draws every dot a few mm off, and nearly the same few mm for
    dots close together.

    A consensus over the candidate shifts ``d_ij = m_j - p_i`` with ``|d_ij| <= max_shift_mm``:
    the one that brings the most planned dots within ``radius_mm`` of a mark wins (a tie: the
    smallest shift, so that a grid is not matched to its neighbours' marks), refined to the
    median of those dots' offsets to their nearest marks. (0, 0) when ``max_shift_mm`` is 0 or
    no candidate brings any dot within the radius."""
    planned = np.atleast_2d(np.asarray(planned_mm, dtype=float))
    found = marks.page_mm if isinstance(marks, Marks) else np.asarray(marks, dtype=float)
    found = found.reshape(-1, 2)
    if not (max_shift_mm > 0 and len(found) and len(planned)):
        return np.zeros(2)
    candidates = (found[None] - planned[:, None]).reshape(-1, 2)
    candidates = candidates[np.linalg.norm(candidates, axis=1) <= max_shift_mm]
    if not len(candidates):
        return np.zeros(2)
    # (c, k, m) distances of each shifted dot to each mark: the dots each shift brings near one
    moved = planned[None] + candidates[:, None]
    nearest = np.min(np.linalg.norm(moved[:, :, None] - found[None, None], axis=3), axis=2)
    inliers = np.sum(nearest <= radius_mm, axis=1)
    best = np.flatnonzero(inliers == inliers.max())
    shift = candidates[best[np.argmin(np.linalg.norm(candidates[best], axis=1))]]
    d = np.linalg.norm((planned + shift)[:, None] - found[None], axis=2)
    near = np.min(d, axis=1) <= radius_mm
    offsets = found[np.argmin(d, axis=1)] - planned
    return np.median(offsets[near], axis=0)


def match_marks(planned_mm, marks: Marks | np.ndarray, radius_mm: float,
                max_shift_mm: float = 0.0) -> np.ndarray:
    """For each planned dot (k, 2) [mm], the one mark within ``radius_mm`` of it: (k, 2) [mm].
    With ``max_shift_mm`` > 0, within ``radius_mm`` of it moved by the pattern's
    :func:`common_shift` (at most ``max_shift_mm``): marks that all landed a few mm off, as an
    arm not yet calibrated puts them, are still told apart at the dots' spacing.

    Raises InputError naming the dot when it has no mark within the radius (with the nearest
    mark's distance) or more than one (a smudge, or a radius wider than half the dots'
    spacing)."""
    planned = np.atleast_2d(np.asarray(planned_mm, dtype=float))
    found = marks.page_mm if isinstance(marks, Marks) else np.asarray(marks, dtype=float)
    found = found.reshape(-1, 2)
    if not radius_mm > 0:
        raise InputError(f"marks: expected radius_mm > 0, got {radius_mm}", key="radius_mm",
                         value=radius_mm)
    if not max_shift_mm >= 0:
        raise InputError(f"marks: expected max_shift_mm >= 0, got {max_shift_mm}",
                         key="max_shift_mm", value=max_shift_mm)
    shift = common_shift(planned, found, radius_mm, max_shift_mm)
    around = (f" of it moved by the marks' common shift ({shift[0]:+.2f}, {shift[1]:+.2f}) mm"
              if shift.any() else "")
    out = np.zeros_like(planned)
    for k, p in enumerate(planned):
        d = np.linalg.norm(found - p - shift, axis=1) if len(found) else np.zeros(0)
        near = np.flatnonzero(d <= radius_mm)
        where = f"planned dot {k} at ({p[0]:.2f}, {p[1]:.2f}) mm"
        if len(near) == 0:
            nearest = f"the nearest is {d.min():.2f} mm away" if len(d) else "no marks at all"
            raise InputError(f"{where}: no mark within {radius_mm:g} mm{around} ({nearest})",
                             key="marks", value=k)
        if len(near) > 1:
            spots = ", ".join(f"({found[i, 0]:.2f}, {found[i, 1]:.2f})" for i in near)
            raise InputError(f"{where}: {len(near)} marks within {radius_mm:g} mm{around} "
                             f"({spots} mm); expected one", key="marks", value=k)
        out[k] = found[near[0]]
    return out


__all__ = ["PAGE_CORNERS", "Marks", "apply_homography", "canvas_marks", "common_shift",
           "find_blobs", "homography", "image_marks", "match_marks", "raster_marks",
           "read_darkness", "rendered_mark", "sheet_homography"]
