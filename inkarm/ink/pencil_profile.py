"""A pencil's texture statistics (seed 002, Al-Meraj, ch. 4.1) and the file that stores them.

A profile holds what the thesis extracts from a scanned straight line of one pencil grade:

* ``mid_hist``: the histogram of the grey levels [0, 255] on the line's centre
  (the range [min_mid, max_mid] of sec. 4.1, first bullet),
* ``full_hist``: the histogram of the whole line's grey levels, paper excluded
  ([min_range, max_range], second bullet),
* ``glcm``: grey-level co-occurrence matrices (eq. 4.1), as probabilities, with the grey levels
  quantised to ``levels`` bins (level = grey * levels // 256) and counted both ways (symmetric).
  ``glcm[0]`` is the thesis's: the line vertical, each pixel and its neighbour one row along
  the line. ``glcm[1:]`` are the across-line and the two diagonal offsets, which the 3x3
  neighbourhood repair of the synthesis (sec. 4.2) compares as well (see :data:`OFFSETS`).

Grey levels are those of the scan with its paper normalised to white (255), so profiles from
scanners of different brightness compare.

File format (``.npz``, written by :func:`save_profile`, read by :func:`load_profile` without
pickles): ``format`` = "inkarm-pencil-profile", ``version`` = 1, ``name``, ``source`` (text),
``mid_hist`` and ``full_hist`` (256,) float, ``glcm`` (4, L, L) float, ``offsets`` (4, 2) int
(row, column), ``levels`` = L, ``width_mm`` (the line's mean width [mm]), ``px_per_mm`` (the
scan's resolution [px/mm]) and ``reference_force_n`` (the pressure the line was drawn with
[N], as far as it is known).

The shipped grades (:data:`GRADES`, in ``inkarm/data/pencils/``) are NOT extracted from real
scans: no public scans of pencil lines exist. They come from synthetic scans of a physically
motivated graphite model (:mod:`inkarm.ink.graphite`) put through the very extraction a real
scan goes through (``scripts/build_pencil_profiles.py``). Extract your own from a real scan with
``inkarm pencil extract SCAN.png --out PROFILE.npz``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from inkarm.core.npz import read_npz, scalar_int
from inkarm.errors import InputError, unknown_name

FORMAT = "inkarm-pencil-profile"
VERSION = 1
# The grades of the thesis (sec. 4.1), hardest to softest.
GRADES = ("2H", "H", "F", "HB", "B", "3B", "6B", "8B")
# (row, column) offsets of the co-occurrence matrices, the line running along the rows. The
# first is eq. 4.1's "(p, q+1)", the neighbour along the line; the matrices are symmetric, so
# each also covers the opposite neighbour, and the four cover a 3x3 neighbourhood.
OFFSETS = ((1, 0), (0, 1), (1, 1), (1, -1))
# The share of each histogram's mass left out at either end when its range is read off, so that
# one stray pixel of a scan does not set [min, max].
RANGE_TAIL = 0.005
# ... and of the mid-line's, whose top end is the boundary of the fill's dark and light bands
# (seed 002 sec. 4.2): the grain's white gaps on the centre line would put it at the paper's
# white, and leave the light band empty.
MID_TAIL = 0.05
_SHIPPED = Path(__file__).resolve().parent.parent / "data" / "pencils"


@dataclass(frozen=True, eq=False)
class PencilProfile:
    """Texture statistics of one pencil (see the module docstring).

    Attributes:
        name: The grade or a user's name for the pencil.
        mid_hist: (256,) probabilities of the grey levels on the line's centre.
        full_hist: (256,) probabilities of the grey levels of the whole line (paper excluded).
        glcm: (4, L, L) co-occurrence probabilities at :data:`OFFSETS`, each summing to 1.
        width_mm: The line's mean width in [mm] (line pixels per row).
        px_per_mm: Resolution of the scan in [px/mm].
        reference_force_n: Force the line was drawn with in [N].
        source: Where the statistics came from (a scan's file name, or the graphite model).
    """

    name: str
    mid_hist: np.ndarray
    full_hist: np.ndarray
    glcm: np.ndarray
    width_mm: float
    px_per_mm: float
    reference_force_n: float = 1.0
    source: str = ""

    def __post_init__(self) -> None:
        for key, hist in (("mid_hist", self.mid_hist), ("full_hist", self.full_hist)):
            if np.shape(hist) != (256,) or not _is_distribution(hist):
                raise InputError("a pencil profile expects 256 non-negative grey-level "
                                 "probabilities that sum to 1", key=key)
        glcm = np.asarray(self.glcm)
        if glcm.ndim != 3 or glcm.shape[0] != len(OFFSETS) or glcm.shape[1] != glcm.shape[2] \
                or not 2 <= glcm.shape[1] <= 256 or not all(_is_distribution(m) for m in glcm):
            raise InputError(f"a pencil profile expects {len(OFFSETS)} co-occurrence matrices "
                             f"of L x L probabilities (2 <= L <= 256), got shape {glcm.shape}",
                             key="glcm")
        # plausible ranges: a scan from 13 to 5080 dpi, a line up to 20 mm wide, a force up to
        # 100 N (past them a profile is damaged, and rendering at its resolution runs for ever)
        for key, low, high in (("width_mm", 0.0, 20.0), ("px_per_mm", 0.5, 200.0),
                               ("reference_force_n", 0.0, 100.0)):
            value = float(getattr(self, key))
            if not (low < value <= high and np.isfinite(value)) and not (
                    key == "px_per_mm" and value == low):
                raise InputError(f"a pencil profile expects {key} in ({low:g}, {high:g}], got "
                                 f"{value!r}", key=key, value=value)

    @property
    def levels(self) -> int:
        """Number of grey-level bins L of the co-occurrence matrices."""
        return int(self.glcm.shape[1])

    @property
    def mid_range(self) -> tuple[int, int]:
        """[min_mid, max_mid]: the grey levels of the line's centre (sec. 4.1)."""
        return grey_range(self.mid_hist, MID_TAIL)

    @property
    def full_range(self) -> tuple[int, int]:
        """[min_range, max_range]: the grey levels of the whole line (sec. 4.1)."""
        return grey_range(self.full_hist)


def grey_range(hist: np.ndarray, tail: float = RANGE_TAIL) -> tuple[int, int]:
    """The grey levels between which all but ``tail`` of the histogram's mass lies at each
    end (inclusive)."""
    cdf = np.cumsum(hist) / np.sum(hist)
    lo = int(np.searchsorted(cdf, tail, side="right"))
    hi = int(np.searchsorted(cdf, 1.0 - tail, side="left"))
    return lo, max(lo, min(hi, 255))


def _is_distribution(values) -> bool:
    values = np.asarray(values, dtype=float)
    return bool(np.all(np.isfinite(values)) and np.all(values >= 0)
                and abs(values.sum() - 1.0) < 1e-6)


def save_profile(profile: PencilProfile, path: str | Path) -> Path:
    """Write ``profile`` to ``path`` (``.npz``, see the module docstring) and return the path."""
    path = Path(path)
    with open(path, "wb") as f:  # np.savez would append ".npz" to any other name
        np.savez_compressed(
            f, format=np.array(FORMAT), version=np.array(VERSION), name=np.array(profile.name),
            source=np.array(profile.source), mid_hist=profile.mid_hist,
            full_hist=profile.full_hist, glcm=profile.glcm, offsets=np.array(OFFSETS),
            levels=np.array(profile.levels), width_mm=np.array(profile.width_mm),
            px_per_mm=np.array(profile.px_per_mm),
            reference_force_n=np.array(profile.reference_force_n))
    return path


def load_profile(path: str | Path) -> PencilProfile:
    """Read a profile written by :func:`save_profile`. Refuses (InputError naming the file) a
    file that is missing, not an npz, of another format or version, or whose arrays are not a
    profile's."""
    path = Path(path)
    arrays = read_npz(path, "a pencil profile")
    if str(arrays.get("format", "")) != FORMAT:
        raise InputError(f"not a pencil profile: expected format {FORMAT!r}", file=str(path))
    version = scalar_int(arrays, "version", path)
    if version != VERSION:
        raise InputError(f"pencil profile version {version}: this inkarm reads version "
                         f"{VERSION}", file=str(path), key="version", value=version)
    missing = [k for k in ("name", "mid_hist", "full_hist", "glcm", "offsets", "width_mm",
                           "px_per_mm", "reference_force_n") if k not in arrays]
    if missing:
        raise InputError(f"pencil profile lacks {', '.join(missing)}", file=str(path))
    if np.shape(arrays["offsets"]) != np.shape(OFFSETS) or \
            not np.array_equal(arrays["offsets"], OFFSETS):
        raise InputError(f"pencil profile's offsets are not {OFFSETS}", file=str(path),
                         key="offsets")
    try:
        return PencilProfile(
            name=str(arrays["name"]), mid_hist=arrays["mid_hist"].astype(float),
            full_hist=arrays["full_hist"].astype(float), glcm=arrays["glcm"].astype(float),
            width_mm=float(arrays["width_mm"]), px_per_mm=float(arrays["px_per_mm"]),
            reference_force_n=float(arrays["reference_force_n"]),
            source=str(arrays.get("source", "")))
    except InputError as e:
        raise e.within(file=str(path)) from None
    except (TypeError, ValueError) as e:
        raise InputError(f"pencil profile has malformed arrays: {e}", file=str(path)) from None


def shipped_profile_path(grade: str) -> Path:
    """The file of a shipped grade (one of :data:`GRADES`)."""
    if grade not in GRADES:
        raise unknown_name("pencil grade", grade, GRADES, key="grade")
    return _SHIPPED / f"{grade}.npz"


def resolve_profile(grade_or_path: str) -> PencilProfile:
    """The shipped grade called ``grade_or_path`` (in any case) or the profile in the file it
    names (a relative path is taken from the working directory); cached until the file
    changes."""
    name = str(grade_or_path)
    if name.upper() in GRADES:
        name = name.upper()
    try:
        stamp = Path(name).stat().st_mtime_ns if name not in GRADES else 0
    except OSError:
        stamp = -1
    return _resolve(name, stamp)


@functools.lru_cache(maxsize=32)
def _resolve(grade_or_path: str, stamp: int) -> PencilProfile:
    if grade_or_path in GRADES:
        return load_profile(shipped_profile_path(grade_or_path))
    if grade_or_path.endswith(".npz") or "/" in grade_or_path or "\\" in grade_or_path:
        return load_profile(grade_or_path)
    raise unknown_name("pencil grade", grade_or_path, GRADES, key="grade")
