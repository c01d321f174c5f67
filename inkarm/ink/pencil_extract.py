"""Extraction of a pencil's texture statistics from a scanned straight line (seed 002, ch. 4.1).

Steps, after the thesis's three bullets and eq. 4.1:

1. Read the scan as 8-bit grey (:func:`read_scan`); normalise its paper to white: the paper's
   grey is the image's median (most of a scan of a line is paper), and every grey level is
   scaled by 255 / paper.
2. Line pixels are those darker than white by more than ``ink_margin`` grey levels. The line
   is turned upright ("each image scan is rotated so that the line is approximately
   vertical"): the principal axis of the line pixels gives its angle, and the scan is rotated
   by it with nearest-neighbour sampling (scikit-image's ``rotate``), which keeps the grey
   levels of the scan. Line pixels farther from the fitted centre line than three times the
   line's half width (specks of dust, a signature) are left out.
3. ``mid_hist``: the grey levels of the pixel nearest the centre line in each row that the
   line crosses; ``full_hist``: those of every line pixel (white excluded, as in the thesis).
4. ``glcm``: the co-occurrence matrices at :data:`inkarm.ink.pencil_profile.OFFSETS` (eq. 4.1)
   computed by scikit-image's ``graycomatrix`` on grey levels quantised to ``levels`` bins,
   with the paper as one extra level that is dropped afterwards, so that only pairs of line
   pixels count. Symmetric, normalised to probabilities.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from inkarm.errors import InputError
from inkarm.ink.pencil_profile import PencilProfile

# Defaults: a 600 dpi scan; 32 grey-level bins keep the matrices well filled by the few
# thousand pixel pairs of a scanned line (256 bins, as in the thesis, leave most cells at a
# count of 0 or 1, and the repair of the synthesis would act on noise).
SCAN_PX_PER_MM = 600.0 / 25.4
LEVELS = 32
INK_MARGIN = 8
# Least line pixels and rows that make a line.
MIN_LINE_PIXELS = 50
MIN_LINE_ROWS = 10
# skimage.feature.graycomatrix angles [rad] of OFFSETS: with symmetric counts, pi/2 pairs the
# offset (1, 0), 0 pairs (0, 1), pi/4 pairs (1, 1) and 3 pi/4 pairs (1, -1) (checked against
# brute-force counting in tests/ink/test_pencil_extract.py).
GLCM_ANGLES = (math.pi / 2, 0.0, math.pi / 4, 3 * math.pi / 4)


MAX_SCAN_PIXELS = 50_000_000  # an A4 page at 600 dpi is 35 M: more is not a scan of a line

def read_scan(path: str | Path) -> np.ndarray:
    """The scan at ``path`` as an 8-bit grey image (rows, cols).

    Accepts greyscale images (8 or 16 bits) and colour images whose channels are equal (a grey
    scan saved as RGB); refuses with an InputError naming the file: a missing or unreadable
    file, a colour image, and an image without pixels."""
    from PIL import Image, UnidentifiedImageError

    path = Path(path)
    if not path.is_file():
        raise InputError("no such scan file", file=str(path))
    try:
        with Image.open(path) as image:
            width, height = image.size
            if width * height > MAX_SCAN_PIXELS:  # checked from the header, before decoding
                raise InputError(f"a {width} x {height} pixel image: more than the "
                                 f"{MAX_SCAN_PIXELS:,} pixels a scan of a line may have (crop "
                                 f"it to the line, or scan at a lower resolution)",
                                 file=str(path))
            image.load()
            mode = image.mode
            array = np.asarray(image)
    except Image.DecompressionBombError as e:  # Pillow's own guard, past 179 M pixels
        raise InputError(f"{str(e).split(',')[0]}: more than the {MAX_SCAN_PIXELS:,} pixels a "
                         "scan of a line may have (crop it to the line, or scan at a lower "
                         "resolution)", file=str(path)) from None
    except (UnidentifiedImageError, OSError) as e:
        raise InputError(f"cannot read the scan as an image: {e}", file=str(path)) from None
    except ValueError as e:
        if isinstance(e, InputError):
            raise
        raise InputError(f"cannot read the scan as an image: {e}", file=str(path)) from None
    if array.size == 0:
        raise InputError("the scan has no pixels", file=str(path))
    if mode in ("I;16", "I;16B", "I;16L", "I") or array.dtype == np.uint16:
        array = (array.astype(np.float64) * (255.0 / 65535.0)).round()
    elif mode == "F":
        raise InputError("a floating-point image: expected an 8- or 16-bit grey scan",
                         file=str(path))
    if array.ndim == 3 and array.shape[-1] == 2:  # grey and alpha (LA): the grey is the scan
        array = array[..., 0]
    if array.ndim == 3:
        channels = array[..., :3].astype(np.int32)
        if mode in ("P", "PA") or not (np.array_equal(channels[..., 0], channels[..., 1])
                                       and np.array_equal(channels[..., 0], channels[..., 2])):
            raise InputError(f"a colour image (mode {mode}): expected a greyscale scan of a "
                             "pencil line (convert it to grey first)", file=str(path))
        array = channels[..., 0]
    elif mode == "P":
        raise InputError("a palette image: expected a greyscale scan of a pencil line",
                         file=str(path))
    elif mode == "1":
        raise InputError("a black-and-white (1-bit) image: a pencil's texture needs grey "
                         "levels; scan in greyscale", file=str(path))
    return np.clip(array, 0, 255).astype(np.uint8)


def extract_profile(
    grey: np.ndarray,
    *,
    name: str = "scan",
    px_per_mm: float = SCAN_PX_PER_MM,
    levels: int = LEVELS,
    reference_force_n: float = 1.0,
    ink_margin: int = INK_MARGIN,
    source: str = "",
) -> PencilProfile:
    """The texture statistics of the straight pencil line in the 8-bit grey image ``grey``
    (see the module docstring), scanned at ``px_per_mm`` [px/mm] and drawn with
    ``reference_force_n`` [N]. Refuses (InputError) an image that is not 2-D, a page darker
    than mid-grey, and one without a line."""
    grey = np.asarray(grey)
    if grey.ndim != 2 or min(grey.shape) < 1:
        raise InputError(f"expected a 2-D grey image, got shape {grey.shape}")
    if not 2 <= levels <= 256:
        raise InputError(f"expected 2 to 256 grey-level bins, got {levels}", key="levels",
                         value=levels)
    if not (px_per_mm > 0 and math.isfinite(px_per_mm)):
        raise InputError(f"expected a positive resolution [px/mm], got {px_per_mm!r}",
                         key="px_per_mm", value=px_per_mm)
    norm = upright_line(grey, ink_margin)
    line = _line_mask(norm < 255 - ink_margin)
    if line.sum() < MIN_LINE_PIXELS or np.count_nonzero(line.any(axis=1)) < MIN_LINE_ROWS:
        raise InputError(f"no pencil line found: {int(line.sum())} pixels darker than the "
                         f"paper by more than {ink_margin} grey levels (expected a line of at "
                         f"least {MIN_LINE_ROWS} rows and {MIN_LINE_PIXELS} pixels)")
    rows = np.flatnonzero(line.any(axis=1))
    centre = _centre_columns(norm, line)
    mid = norm[rows, centre[rows]][line[rows, centre[rows]]]
    full = norm[line]
    widths = line[rows].sum(axis=1)
    return PencilProfile(
        name=name,
        mid_hist=_histogram(mid if mid.size else full),
        full_hist=_histogram(full),
        glcm=line_glcm(norm, line, levels),
        width_mm=float(np.mean(widths)) / px_per_mm,
        px_per_mm=float(px_per_mm),
        reference_force_n=float(reference_force_n),
        source=source,
    )


def upright_line(grey: np.ndarray, ink_margin: int = INK_MARGIN) -> np.ndarray:
    """Steps 1 and 2 of the module docstring: the 8-bit scan ``grey`` with its paper
    normalised to white and turned so that its line runs along the rows. Refuses (InputError)
    a page darker than mid-grey."""
    grey = np.asarray(grey)
    paper = float(np.median(grey))
    if paper < 128:
        raise InputError(f"the page is dark (median grey {paper:.0f} of 255): expected a dark "
                         "pencil line on light paper")
    norm = np.clip(np.round(grey.astype(np.float64) * (255.0 / paper)), 0, 255).astype(np.uint8)
    return _upright(norm, norm < 255 - ink_margin)


def line_glcm(grey: np.ndarray, line: np.ndarray, levels: int, *,
              require_pairs: bool = True) -> np.ndarray:
    """(4, L, L) symmetric co-occurrence probabilities at OFFSETS of the grey levels
    (quantised to ``levels`` bins) of the pixel pairs that both lie in the mask ``line``. An
    offset without a pair is refused (InputError), or left all zero if not
    ``require_pairs``."""
    counts = pair_counts(grey.astype(np.intp) * levels // 256, line, levels)
    totals = counts.sum(axis=(1, 2), keepdims=True)
    if require_pairs and np.any(totals == 0):
        raise InputError("the line is too thin or broken to pair its pixels along every "
                         "offset of the co-occurrence matrices")
    return counts / np.maximum(totals, 1.0)


def pair_counts(level: np.ndarray, mask: np.ndarray, levels: int) -> np.ndarray:
    """(4, L, L) symmetric counts of the pairs of levels (0..L-1) of the pixels in ``mask`` at
    OFFSETS (eq. 4.1, unnormalised), by scikit-image's ``graycomatrix``: the pixels off the
    mask are one extra level, whose row and column are dropped."""
    from skimage.feature import graycomatrix

    quantised = np.where(mask, level, levels).astype(np.uint16)
    counts = graycomatrix(quantised, distances=[1], angles=list(GLCM_ANGLES),
                          levels=levels + 1, symmetric=True, normed=False)
    return np.moveaxis(counts[:levels, :levels, 0, :], -1, 0).astype(np.float64)


def _histogram(values: np.ndarray) -> np.ndarray:
    counts = np.bincount(values.astype(np.intp).ravel(), minlength=256)[:256].astype(np.float64)
    return counts / counts.sum()


def _upright(grey: np.ndarray, ink: np.ndarray) -> np.ndarray:
    """The image rotated so that the principal axis of its ink pixels runs along the rows."""
    rows, cols = np.nonzero(ink)
    if rows.size < 2:
        return grey
    darkness = 255.0 - grey[rows, cols]
    weights = darkness / darkness.sum()
    r0, c0 = weights @ rows, weights @ cols
    dr, dc = rows - r0, cols - c0
    cov = np.array([[weights @ (dr * dr), weights @ (dr * dc)],
                    [weights @ (dr * dc), weights @ (dc * dc)]])
    _, vectors = np.linalg.eigh(cov)
    vr, vc = vectors[:, 1]  # the principal axis (row, column)
    angle = math.degrees(math.atan2(vc, vr))  # from the row axis, counter-clockwise on screen
    angle = (angle + 90.0) % 180.0 - 90.0
    if abs(angle) < 1.0:
        return grey
    from skimage.transform import rotate

    # order=0: nearest neighbour, the scan's own grey levels; paper fills the corners
    turned = rotate(grey, -angle, resize=True, order=0, mode="constant", cval=255,
                    preserve_range=True)
    return np.round(turned).astype(np.uint8)


def _line_mask(ink: np.ndarray) -> np.ndarray:
    """The ink pixels within three half widths of the straight centre line fitted to them."""
    rows = np.flatnonzero(ink.any(axis=1))
    if rows.size < 2:
        return ink
    counts = ink[rows].sum(axis=1)
    centres = np.array([np.flatnonzero(ink[r]).mean() for r in rows])
    slope, intercept = np.polyfit(rows, centres, 1)
    reach = max(3.0 * 0.5 * float(np.median(counts)), 3.0)
    r, c = np.indices(ink.shape)
    return ink & (np.abs(c - (slope * r + intercept)) <= reach)


def _centre_columns(grey: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Per row, the column of the darkness-weighted centre of its line pixels (0 where none)."""
    darkness = np.where(line, 255.0 - grey, 0.0)
    total = darkness.sum(axis=1)
    cols = np.arange(grey.shape[1], dtype=float)
    centre = np.divide(darkness @ cols, total, out=np.zeros_like(total), where=total > 0)
    return np.round(centre).astype(np.intp)
