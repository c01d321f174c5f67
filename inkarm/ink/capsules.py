"""Anti-aliased capsules max-composited into a raster, many in one numpy pass (the canvas's ink).

A capsule is the set of points within a radius of a segment, the radius varying linearly along
it. The canvas (:class:`inkarm.ink.canvas.Canvas`) queues them as rows (x0, y0, w0, x1, y1, w1,
opacity): end points in page [mm] (origin at the page's lower-left corner, y up), widths in [mm],
opacity in [0, 1]. In pixel-index coordinates (pixel centres at integers, row 0 at the top of a
raster of n_rows rows, at ppm [px/mm])

    u = x ppm - 1/2,    v = n_rows - y ppm - 1/2,    r = w ppm / 2.                    (1)

Coverage of pixel centre p by the capsule from a to b with radii r_a, r_b:

    s = clip((p - a) . (b - a) / |b - a|^2, 0, 1)           (the segment's nearest point)
    c = clip(r_a + s (r_b - r_a) + 1/2 - |p - a - s (b - a)|, 0, 1) * opacity,              (2)

the coverage ramping over one pixel across the edge (about the pixel's area inside). A capsule
shorter than 1e-6 px is a disc of the larger radius. Within a stroke the coverages combine by
their maximum, which does not depend on the order: a batch computes (2) on (K, H, W) arrays
padded to its largest box and scatters the maxima, the very pixels one capsule at a time gives.
"""

from __future__ import annotations

import numpy as np

CAPSULE_FIELDS = 7  # x0, y0, w0, x1, y1, w1, opacity


def rasterise(
    stroke: np.ndarray, caps: np.ndarray, px_per_mm: float, batch: int, max_pixels: int
) -> tuple[list[int] | None, int]:
    """Max-composite the capsules ``caps`` (K, 7) (module docstring) into ``stroke`` (float32,
    C-contiguous, row 0 at the top) by (2), ``batch`` at a time and at most ``max_pixels``
    padded pixels at a time.

    Returns the pixel box [r0, r1, c0, c1) they touch and how many lie on the page with a
    positive opacity (the others are dropped); (None, 0) when none does."""
    if not stroke.flags.c_contiguous:  # (its flat view is where the maxima are scattered)
        raise ValueError("rasterise: the stroke raster must be C-contiguous")
    n_rows, n_cols = stroke.shape
    x0, y0, w0, x1, y1, w1, opacity = caps.T
    u0, u1 = x0 * px_per_mm - 0.5, x1 * px_per_mm - 0.5  # (1)
    v0, v1 = n_rows - y0 * px_per_mm - 0.5, n_rows - y1 * px_per_mm - 0.5
    rad0, rad1 = 0.5 * w0 * px_per_mm, 0.5 * w1 * px_per_mm
    reach = np.maximum(rad0, rad1) + 1.0  # the box: the capsule and its one-pixel ramp
    c0 = np.maximum(np.floor(np.minimum(u0, u1) - reach), 0.0)
    c1 = np.minimum(np.ceil(np.maximum(u0, u1) + reach) + 1.0, n_cols)
    r0 = np.maximum(np.floor(np.minimum(v0, v1) - reach), 0.0)
    r1 = np.minimum(np.ceil(np.maximum(v0, v1) + reach) + 1.0, n_rows)
    keep = (c0 < c1) & (r0 < r1) & (opacity > 0.0)
    if not keep.all():
        u0, v0, u1, v1, rad0, rad1, opacity, r0, r1, c0, c1 = (
            a[keep] for a in (u0, v0, u1, v1, rad0, rad1, opacity, r0, r1, c0, c1))
    count = len(u0)
    if count == 0:
        return None, 0
    r0, r1, c0, c1 = (a.astype(np.intp) for a in (r0, r1, c0, c1))
    box = [int(r0.min()), int(r1.max()), int(c0.min()), int(c1.max())]
    # batches of alike boxes (by height + width), so that little of each padded box is waste
    order = np.argsort((r1 - r0) + (c1 - c0), kind="stable")
    flat = stroke.reshape(-1)
    heights, widths = r1 - r0, c1 - c0
    i = 0
    while i < count:
        part = order[i : i + batch]
        pixels = int(heights[part].max()) * int(widths[part].max())
        part = part[: max(1, max_pixels // pixels)]
        i += len(part)
        _max_into(flat, n_cols, u0[part], v0[part], u1[part], v1[part], rad0[part], rad1[part],
                  opacity[part], r0[part], r1[part], c0[part], c1[part])
    return box, count


def _max_into(flat, n_cols, u0, v0, u1, v1, rad0, rad1, opacity, r0, r1, c0, c1) -> None:
    """(2) for a batch of capsules in pixel units (1), their boxes [r0, r1) x [c0, c1), and the
    maximum scattered into the raster ``flat`` (row-major, ``n_cols`` columns)."""
    du, dv = u1 - u0, v1 - v0
    length2 = du * du + dv * dv
    segment = length2 > 1e-12
    safe2 = np.where(segment, length2, 1.0)
    along_u = np.where(segment, du / safe2, 0.0)
    along_v = np.where(segment, dv / safe2, 0.0)
    slope = np.where(segment, rad1 - rad0, 0.0)
    base = np.where(segment, rad0, np.maximum(rad0, rad1)) + 0.5

    def column(values: np.ndarray) -> np.ndarray:
        return values.astype(np.float32)[:, None, None]

    # pixel centres relative to the capsule's start: (K, 1, W) and (K, H, 1)
    heights, widths = r1 - r0, c1 - c0
    height, width = int(heights.max()), int(widths.max())
    pu = _offsets(c0 - u0, width)[:, None, :]
    pv = _offsets(r0 - v0, height)[:, :, None]
    s = pu * column(along_u) + pv * column(along_v)
    np.clip(s, 0.0, 1.0, out=s)
    ex, ey = pu - s * column(du), pv - s * column(dv)
    coverage = s * column(slope)
    coverage += column(base)
    coverage -= np.sqrt(ex * ex + ey * ey)
    np.clip(coverage, 0.0, 1.0, out=coverage)
    coverage *= column(opacity)
    # The inked pixels (a zero leaves the maximum of a non-negative raster as it is). Past a
    # box's far edge the coverage is 0 (at least r + 1 px from the segment) unless the page
    # cut the box there: then its own box bounds it too (the padding would wrap a row).
    inked = coverage > 0.0
    cut = (r0 + height > len(flat) // n_cols) | (c0 + width > n_cols)
    if cut.any():
        inked &= np.arange(height)[:, None] < heights[:, None, None]
        inked &= np.arange(width) < widths[:, None, None]
    kind = np.int32 if len(flat) <= np.iinfo(np.int32).max else np.intp
    index = (r0 * n_cols + c0).astype(kind)[:, None, None] + (
        np.arange(height, dtype=kind) * kind(n_cols))[:, None]
    index = index + np.arange(width, dtype=kind)
    np.maximum.at(flat, index[inked], coverage[inked])


def _offsets(starts: np.ndarray, n: int) -> np.ndarray:
    """Rows ``starts[k] + j`` for j < n in float32, (K, n), each exactly as
    ``np.arange(starts[k], starts[k] + n, dtype=np.float32)`` computes it (first two values
    rounded from double, then first + j * (second - first) in float32), so that the batched
    capsules give the very pixels one capsule at a time would."""
    first = starts.astype(np.float32)[:, None]
    second = (starts + 1.0).astype(np.float32)[:, None]
    rows = first + np.arange(n, dtype=np.float32) * (second - first)
    rows[:, :1] = first
    rows[:, 1:2] = second
    return rows
