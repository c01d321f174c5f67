"""Human-likeness of a drawing: its kinematic statistics against the ranges of human
handwriting (issue 25, part 2).

Every stroke is first low-passed (:func:`inkarm.analysis.kinematics.lowpass`: Butterworth,
order 2, zero phase, :data:`SMOOTHING_HZ`), human recording and synthetic trace alike, so
that tablet noise does not count as speed peaks and both are measured the same way. Then,
per stroke:

* **beta, r2**: the speed-curvature power law v = k r^beta (r = 1/|kappa| the radius of
  curvature [mm]; beta = 1/3 is the "two-thirds power law" A = k C^(2/3) of angular speed A
  and curvature C, the same exponent since A = v C), by least squares of log v on log r
  (:func:`~inkarm.analysis.kinematics.power_law_fit`) over the samples moving faster than
  :data:`MIN_SPEED` of the stroke's top speed and curved more than 1 / :data:`MAX_RADIUS_MM`.
  Regressing on log r or on log kappa gives the same beta (log r = -log kappa); the
  exclusions are what matter.
* **peaks**: speed maxima above :data:`PEAK_THRESHOLD` of the top speed; peaks per second
  over the stroke's duration.
* **jerk per peak**: the normalised jerk sqrt(1/2 integral |jerk|^2 dt T^5 / L^2)
  (:func:`~inkarm.analysis.kinematics.normalised_jerk`) divided by the number of peaks.
  Independent of size and pace, not of the number of pulses: n minimum-jerk movements one
  after the other, each stopping, have sqrt(360) n^2, so sqrt(360) n per peak.
* **asymmetry**: per speed pulse (minimum to minimum around a peak), (t_peak - t_start) /
  (t_end - t_start), averaged over the stroke's pulses.
* **lognormal SNR**: the signal-to-noise ratio [dB] of a sigma-lognormal fit of the speed
  (:mod:`inkarm.analysis.lognormal`), one lognormal per pulse.

Pooled over a drawing's strokes: beta and r2 of one fit over the kept samples of every
stroke; peaks per second = all peaks / all pen-down time; peaks per stroke, jerk per peak,
asymmetry and SNR are the medians over the strokes (SNR, jerk) or the mean over all pulses
(asymmetry) and strokes (peaks).

On LASA (26 shapes x 7 demonstrations, ``scripts/human_ranges.py``) these choices give the
human column of issue 25 (beta 0.15 [0.11, 0.19], 3.0 peaks/s, jerk per peak 44, asymmetry
0.49): beta 0.163 [0.120, 0.196], 2.87 [2.21, 3.36] peaks/s, jerk per peak 42.7 [36.5,
52.3], asymmetry 0.48 [0.45, 0.51], lognormal SNR 33.4 [30.0, 36.0] dB (median [IQR]). Without
the low-pass LASA's sampling noise gives 4.8 peaks/s and 71 per peak; the power-law exclusions
(v > 0.1 v_max, r < 1 m) move beta most: v > 0.05 v_max gives 0.20. The ranges are data,
``inkarm/data/human_ranges.toml``.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from inkarm.analysis import kinematics as kin
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError, unknown_name

SMOOTHING_HZ = 10.0
"""Cut-off of the low-pass applied to every stroke before measuring, in [Hz]."""
PEAK_THRESHOLD = 0.1
"""Speed peaks below this fraction of the stroke's top speed are not counted."""
MIN_SPEED = 0.1
"""Power-law samples slower than this fraction of the stroke's top speed are left out."""
MAX_RADIUS_MM = 1e3
"""Power-law samples with a radius of curvature above this [mm] (near straight) are left out."""
MIN_SAMPLES = 12
"""Strokes with fewer samples are skipped (too short to smooth and differentiate)."""
MIN_PATH_MM = 1e-3
"""Strokes whose path is shorter [mm] are skipped: the pen rests, and the low-pass's rounding
noise (1e-14 mm) would count as speed peaks (the peak threshold is relative)."""
RANGES_FILE = Path(__file__).parents[1] / "data" / "human_ranges.toml"
"""The human ranges shipped with inkarm (made by ``scripts/human_ranges.py`` from LASA)."""

MEASURES = ("beta", "r2", "peaks_per_stroke", "peaks_per_second", "jerk_per_peak",
            "asymmetry", "lognormal_snr_db")
"""The pooled measures of :class:`HumanStats` that ranges may bound."""


@dataclass(frozen=True)
class StrokeStats:
    """The statistics of one stroke (module docstring); NaN where undefined (no peak, too
    few curved samples, lognormal fit not asked for).

    Attributes:
        duration_s: [s]. length_mm: path length [mm]. beta, r2: power law. peaks: count.
        peaks_per_second: [1/s]. normalised_jerk: dimensionless. jerk_per_peak: that / peaks.
        asymmetry: mean over pulses. lognormal_snr_db: [dB].
    """

    duration_s: float
    length_mm: float
    beta: float
    r2: float
    peaks: int
    peaks_per_second: float
    normalised_jerk: float
    jerk_per_peak: float
    asymmetry: float
    lognormal_snr_db: float


@dataclass(frozen=True)
class HumanStats:
    """Per-stroke and pooled statistics of a drawing (module docstring).

    Attributes:
        strokes: One :class:`StrokeStats` per measured stroke.
        skipped: Indices of the strokes too short to measure (fewer than MIN_SAMPLES samples
            or no movement).
        beta, r2, peaks_per_stroke, peaks_per_second, jerk_per_peak, asymmetry,
        lognormal_snr_db: The pooled values (NaN where no stroke defines them).
    """

    strokes: tuple[StrokeStats, ...]
    skipped: tuple[int, ...]
    beta: float
    r2: float
    peaks_per_stroke: float
    peaks_per_second: float
    jerk_per_peak: float
    asymmetry: float
    lognormal_snr_db: float

    def measures(self) -> dict[str, float]:
        """The pooled measures by name (:data:`MEASURES`)."""
        return {name: getattr(self, name) for name in MEASURES}


def _smoothed(traj: Trajectory, smoothing_hz: float | None) -> Trajectory:
    return traj if smoothing_hz is None else kin.lowpass(traj, smoothing_hz)


def _power_law(traj: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    try:
        return kin.power_law_samples(traj, MIN_SPEED, MAX_RADIUS_MM)
    except InputError:  # still throughout: no speed, no curvature
        return np.zeros(0), np.zeros(0)


def _fit(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    try:
        fit = kin.fit_log_log(x, y)
    except InputError:  # too few curved samples, or a constant radius
        return math.nan, math.nan
    return fit.beta, fit.r2


def _stroke(traj: Trajectory, lognormal: bool) -> tuple[StrokeStats, list[float], tuple]:
    """A stroke's statistics, the asymmetry of each of its pulses and its power-law samples."""
    duration = float(traj.t[-1] - traj.t[0])
    pulses = kin.speed_pulses(traj, PEAK_THRESHOLD)
    peaks = len(pulses)
    asym = [p.asymmetry(traj.t) for p in pulses]
    nj = kin.normalised_jerk(traj)
    samples = _power_law(traj)
    beta, r2 = _fit(*samples)
    snr = math.nan
    if lognormal and peaks:
        from inkarm.analysis.lognormal import fit_sigma_lognormal

        snr = fit_sigma_lognormal(traj, PEAK_THRESHOLD).snr_db
    stats = StrokeStats(
        duration_s=duration, length_mm=kin.path_length(traj), beta=beta, r2=r2, peaks=peaks,
        peaks_per_second=peaks / duration, normalised_jerk=nj,
        jerk_per_peak=nj / peaks if peaks else math.nan,
        asymmetry=float(np.mean(asym)) if asym else math.nan, lognormal_snr_db=snr,
    )
    return stats, asym, samples


def unmeasurable(traj: Trajectory) -> str | None:
    """Why ``traj`` cannot be measured (fewer than :data:`MIN_SAMPLES` samples, a path shorter
    than :data:`MIN_PATH_MM`: rounding noise would count as speed peaks, or not 2-D/3-D);
    None when it can."""
    if traj.n < MIN_SAMPLES:
        return f"{traj.n} samples, fewer than {MIN_SAMPLES}"
    if traj.dim not in (2, 3):
        return f"{traj.dim} coordinates, not 2 or 3"
    if kin.path_length(traj) < MIN_PATH_MM:
        return f"a path shorter than {MIN_PATH_MM:g} mm: the pen does not move"
    return None


def stroke_stats(traj: Trajectory, lognormal: bool = True,
                 smoothing_hz: float | None = SMOOTHING_HZ) -> StrokeStats:
    """The statistics of one stroke, low-passed at ``smoothing_hz`` [Hz] first (None: as
    it is); ``lognormal=False`` skips the sigma-lognormal fit (its SNR is then NaN).

    Raises:
        InputError: the stroke cannot be measured (:func:`unmeasurable` says why)."""
    why = unmeasurable(traj)
    if why is not None:
        raise InputError(f"stroke_stats: cannot measure a stroke of {why}", value=traj.n)
    return _stroke(_smoothed(traj, smoothing_hz), lognormal)[0]


def _median(values: list[float]) -> float:
    finite = [v for v in values if math.isfinite(v)]
    return float(np.median(finite)) if finite else math.nan


def human_stats(drawing: Drawing | Trajectory, lognormal: bool = True,
                smoothing_hz: float | None = SMOOTHING_HZ) -> HumanStats:
    """Per-stroke and pooled statistics of ``drawing`` (module docstring).

    Raises:
        InputError: no stroke long enough to measure.
    """
    strokes = (drawing,) if isinstance(drawing, Trajectory) else drawing.strokes
    measured, skipped, asym, xs, ys = [], [], [], [], []
    for i, traj in enumerate(strokes):
        if unmeasurable(traj) is not None:
            skipped.append(i)
            continue
        stats, pulse_asym, (x, y) = _stroke(_smoothed(traj, smoothing_hz), lognormal)
        measured.append(stats)
        asym += pulse_asym
        xs.append(x)
        ys.append(y)
    if not measured:
        raise InputError(f"human_stats: no stroke to measure: each of the {len(strokes)} needs "
                         f"at least {MIN_SAMPLES} samples and a path of at least {MIN_PATH_MM:g} mm")
    beta, r2 = _fit(np.concatenate(xs), np.concatenate(ys))
    time = sum(s.duration_s for s in measured)
    peaks = sum(s.peaks for s in measured)
    return HumanStats(
        strokes=tuple(measured), skipped=tuple(skipped), beta=beta, r2=r2,
        peaks_per_stroke=peaks / len(measured), peaks_per_second=peaks / time,
        jerk_per_peak=_median([s.jerk_per_peak for s in measured]),
        asymmetry=float(np.mean(asym)) if asym else math.nan,
        lognormal_snr_db=_median([s.lognormal_snr_db for s in measured]),
    )


# -- the human ranges and the verdict ------------------------------------------------------------


@dataclass(frozen=True)
class HumanRange:
    """The human median and interquartile range [q25, q75] of one measure; ``judged``
    measures decide the overall verdict, the others are reported only."""

    median: float
    q25: float
    q75: float
    judged: bool = True


@dataclass(frozen=True)
class HumanRanges:
    """The human ranges by measure name, and where they come from (``source``: one line)."""

    measures: dict[str, HumanRange]
    source: str = ""


def load_human_ranges(path: str | Path = RANGES_FILE) -> HumanRanges:
    """Read human ranges from TOML: ``source = "..."`` and one table ``[measures.NAME]``
    per measure with ``median``, ``q25``, ``q75`` (q25 <= median <= q75) and optionally
    ``judged`` (default true); NAME one of :data:`MEASURES`."""
    path = Path(path)
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError("no such file", file=str(path)) from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise InputError(f"not TOML: {e}", file=str(path)) from None
    table = doc.get("measures")
    if not isinstance(table, dict) or not table:
        raise InputError("expected a table [measures.NAME] per measure", file=str(path),
                         key="measures")
    ranges = {}
    for name, entry in table.items():
        if name not in MEASURES:
            raise unknown_name("measure", name, MEASURES, key=f"measures.{name}", file=str(path))
        ranges[name] = _range(entry, f"measures.{name}", path)
    return HumanRanges(ranges, str(doc.get("source", "")))


def _range(entry, key: str, path: Path) -> HumanRange:
    if not isinstance(entry, dict):
        raise InputError("expected a table with median, q25, q75", file=str(path), key=key)
    allowed = {f.name for f in fields(HumanRange)}
    for name in entry:
        if name not in allowed:
            raise unknown_name("field", name, sorted(allowed), key=f"{key}.{name}",
                               file=str(path))
    values = {}
    for name in ("median", "q25", "q75"):
        value = entry.get(name)
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not math.isfinite(value):
            raise InputError(f"expected a finite number, got {value!r}", file=str(path),
                             key=f"{key}.{name}", value=value)
        values[name] = float(value)
    if not values["q25"] <= values["median"] <= values["q75"]:
        raise InputError(f"expected q25 <= median <= q75, got {values['q25']:g}, "
                         f"{values['median']:g}, {values['q75']:g}", file=str(path), key=key)
    judged = entry.get("judged", True)
    if not isinstance(judged, bool):
        raise InputError(f"expected true or false, got {judged!r}", file=str(path),
                         key=f"{key}.judged", value=judged)
    return HumanRange(**values, judged=judged)


HUMAN_RANGES = load_human_ranges() if RANGES_FILE.is_file() else HumanRanges({})
"""The ranges shipped in ``inkarm/data/human_ranges.toml`` (LASA, 26 shapes x 7 demos)."""


@dataclass(frozen=True)
class Verdict:
    """Where each measure of a drawing falls against the human ranges.

    Attributes:
        inside: Per measure: True inside [q25, q75], False outside, None when the measure is
            undefined for the drawing (NaN).
        human_like: True when every judged measure is inside its range.
    """

    inside: dict[str, bool | None]
    human_like: bool


def human_likeness(stats: HumanStats, ranges: HumanRanges = HUMAN_RANGES) -> Verdict:
    """Each measure of ``stats`` inside or outside its human interquartile range, and the
    overall verdict (human-like when every judged measure is inside; an undefined judged
    measure counts as outside)."""
    if not ranges.measures:
        raise InputError("human_likeness: no human ranges (inkarm/data/human_ranges.toml is "
                         "missing; make it with scripts/human_ranges.py)")
    values = stats.measures()
    inside: dict[str, bool | None] = {}
    for name, r in ranges.measures.items():
        value = values[name]
        inside[name] = None if not math.isfinite(value) else bool(r.q25 <= value <= r.q75)
    judged = [inside[name] is True for name, r in ranges.measures.items() if r.judged]
    return Verdict(inside, all(judged))
