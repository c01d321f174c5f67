"""A physically motivated model of a graphite pencil line on paper, rendered as a greyscale
scan: the stand-in for the scans that seed 002 (ch. 4.1) extracts its pencil profiles from and
that no one has published. The shipped grades (``inkarm/data/pencils/``) are extracted from
these synthetic scans, not from real pencils.

Model, in the page plane, the line running along y (rows) at a constant force F:

* Paper grain: a height field h(x, y), zero mean and unit variance, the sum of three Gaussian-
  filtered white noises: fibres (0.02 mm across), fibre bundles stretched along the paper's
  grain (0.08 x 0.03 mm) and the formation's clouds (0.25 mm).
* Contact: the lead's worn face presses on the grain with a Hertz-like pressure across the
  line, p(n) = sqrt(1 - (2 n / W)^2) for |n| < W / 2, where the contact width
  W = W_g (F / F_ref)^(1/3) grows with the force as a Hertz contact does.
* Engagement: the lead reaches grain down to the level z(n) = z_top - depth (c + s_g) p(n)
  (F / F_ref)^(2/3): deeper where it presses harder, and deeper for a soft lead (softness
  s_g in (0, 1]) that deforms into the valleys.
* Deposit (Archard's wear law: worn volume proportional to load over hardness):
  d = p(n) (h - z)_+ + smear s_g^2 p(n), the second term the graphite a soft lead's flat
  face smears into the valleys, all modulated by the lead's own ridges, which drag along the
  stroke (a noise correlated over 0.6 mm along the line and 0.03 mm across).
* Optics and scan: darkness D_g (1 - exp(-kappa d)) (a soft lead's blacker graphite: D_g),
  grey = paper (1 - darkness) plus scanner noise, quantised to 8 bits.

The constants are chosen so that the grades order as real ones do (2H thin and light, 8B wide
and dark, grain showing through on hard leads); they are not fitted to measurements. D_g is
spaced so that the extracted profiles' mean darkness grows strictly and by at least 0.05 a
grade (0.19, 0.25, 0.35, 0.45, 0.51, 0.65, 0.74, 0.83 from 2H to 8B; a wider line holds more
of its light edge, so an evenly spaced D_g left H, F and HB within 0.03), wider than the
synthesis's drift from its profile (up to 0.04).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkarm.errors import InputError, unknown_name
from inkarm.ink.pencil_extract import SCAN_PX_PER_MM


@dataclass(frozen=True)
class GraphiteGrade:
    """One pencil grade of the model.

    Attributes:
        name: The grade ("HB").
        softness: s_g in (0, 1]: how much graphite the lead gives and how far into the grain.
        lead_width_mm: Contact width W_g at the reference force in [mm].
        max_darkness: D_g, the darkness of a thick graphite layer, in (0, 1].
    """

    name: str
    softness: float
    lead_width_mm: float
    max_darkness: float


GRAPHITE_GRADES = {g.name: g for g in (
    GraphiteGrade("2H", 0.15, 0.30, 0.34),
    GraphiteGrade("H", 0.22, 0.33, 0.41),
    GraphiteGrade("F", 0.34, 0.34, 0.70),
    GraphiteGrade("HB", 0.38, 0.38, 0.80),
    GraphiteGrade("B", 0.48, 0.45, 0.85),
    GraphiteGrade("3B", 0.62, 0.55, 0.89),
    GraphiteGrade("6B", 0.82, 0.70, 0.92),
    GraphiteGrade("8B", 1.00, 0.80, 0.95),
)}
REFERENCE_FORCE_N = 1.0
_Z_TOP = 1.0
_DEPTH = 3.0
_HARD_REACH = 0.3  # c: how far even the hardest lead reaches
_SMEAR = 0.6
_KAPPA = 1.5
_RIDGES = 0.35
_PAPER_GREY = 246.0
_SCANNER_NOISE = 1.2
_MARGIN_MM = 1.0


def paper_height(shape: tuple[int, int], px_per_mm: float,
                 rng: np.random.Generator) -> np.ndarray:
    """Paper grain heights (rows, cols), zero mean, unit standard deviation (see the module
    docstring); rows run along the paper's grain."""
    from scipy.ndimage import gaussian_filter

    def noise(sigma_rows_mm: float, sigma_cols_mm: float) -> np.ndarray:
        field = gaussian_filter(rng.standard_normal(shape),
                                (sigma_rows_mm * px_per_mm, sigma_cols_mm * px_per_mm),
                                mode="wrap")
        return (field - field.mean()) / (field.std() + 1e-12)

    height = 0.6 * noise(0.02, 0.02) + 0.8 * noise(0.08, 0.03) + 0.4 * noise(0.25, 0.25)
    return (height - height.mean()) / height.std()


def render_scan(grade: str | GraphiteGrade, *, length_mm: float = 40.0,
                force_n: float = REFERENCE_FORCE_N, px_per_mm: float = SCAN_PX_PER_MM,
                rng: np.random.Generator | None = None) -> np.ndarray:
    """An 8-bit grey scan (rows, cols) of a straight vertical line of ``length_mm`` [mm] drawn
    with ``grade`` (a name of :data:`GRAPHITE_GRADES` or a GraphiteGrade) at ``force_n`` [N],
    at ``px_per_mm`` [px/mm], with 1 mm of paper either side (see the module docstring)."""
    from scipy.ndimage import gaussian_filter

    if isinstance(grade, str):
        if grade not in GRAPHITE_GRADES:
            raise unknown_name("pencil grade", grade, GRAPHITE_GRADES, key="grade")
        grade = GRAPHITE_GRADES[grade]
    if not (force_n > 0 and np.isfinite(force_n)):
        raise InputError(f"expected a positive force [N], got {force_n!r}", key="force_n")
    if not (0 < length_mm <= 1000 and 1 <= px_per_mm <= 200):
        raise InputError(f"expected a length in (0, 1000] mm and 1 to 200 px/mm, got "
                         f"{length_mm!r} mm, {px_per_mm!r} px/mm")
    rng = np.random.default_rng(0) if rng is None else rng
    load = force_n / REFERENCE_FORCE_N
    width_mm = grade.lead_width_mm * load ** (1.0 / 3.0)
    n_rows = round(length_mm * px_per_mm)
    n_cols = round((width_mm + 2 * _MARGIN_MM) * px_per_mm)
    height = paper_height((n_rows, n_cols), px_per_mm, rng)
    across_mm = (np.arange(n_cols) + 0.5) / px_per_mm - 0.5 * n_cols / px_per_mm
    pressure = np.sqrt(np.clip(1.0 - (2.0 * across_mm / width_mm) ** 2, 0.0, None))[None, :]
    level = _Z_TOP - _DEPTH * (_HARD_REACH + grade.softness) * pressure * load ** (2.0 / 3.0)
    deposit = pressure * np.clip(height - level, 0.0, None) \
        + _SMEAR * grade.softness**2 * pressure
    ridges = gaussian_filter(rng.standard_normal((n_rows, n_cols)),
                             (0.6 * px_per_mm, 0.03 * px_per_mm), mode="wrap")
    ridges /= ridges.std() + 1e-12
    deposit *= np.clip(1.0 + _RIDGES * ridges, 0.0, None)
    darkness = grade.max_darkness * (1.0 - np.exp(-_KAPPA * deposit))
    grey = _PAPER_GREY * (1.0 - darkness) + _SCANNER_NOISE * rng.standard_normal(darkness.shape)
    return np.clip(np.round(grey), 0, 255).astype(np.uint8)


def reference_scan(grade: str, length_mm: float = 40.0) -> np.ndarray:
    """The synthetic scan the shipped profile of ``grade`` is extracted from
    (``scripts/build_pencil_profiles.py``): ``length_mm`` [mm] at the reference force, 600
    dpi, its draws seeded by the grade's place in :data:`GRAPHITE_GRADES` (the shipped files
    use 40 mm; a shorter scan is another line of the same statistics)."""
    if grade not in GRAPHITE_GRADES:
        raise unknown_name("pencil grade", grade, GRAPHITE_GRADES, key="grade")
    index = list(GRAPHITE_GRADES).index(grade)
    return render_scan(GRAPHITE_GRADES[grade], length_mm=length_mm, force_n=REFERENCE_FORCE_N,
                       px_per_mm=SCAN_PX_PER_MM, rng=np.random.default_rng(1000 + index))
