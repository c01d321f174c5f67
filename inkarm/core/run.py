"""What a run's verdict is made of: its :class:`Status`, its :class:`Metrics`, the
:class:`Bounds` a finished drawing must keep, and :func:`judge`, the one judge of every backend.

A run that finished is ``ok`` only when every bound holds; otherwise it is ``degraded`` and each
bound it missed is a :class:`Shortfall` naming the bound, the measured value and the limit. A
bound on a quantity the backend cannot sense (a Dynamixel arm senses no pen force; a plotter's
pen is up or down, with no force) is never passed silently: :func:`judge` lists it as unjudged,
with why (:class:`Senses`).

Units: lengths in page [mm], forces in [N], as the field names say.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass

from inkarm.core.ranges import Range, check_ranges
from inkarm.errors import InputError, unknown_name


class Status(enum.StrEnum):
    """How a run ended. A ``str``: ``Status.OK == "ok"`` and JSON writes ``"ok"``."""

    OK = "ok"                    # finished, every bound of the judge held
    DEGRADED = "degraded"        # finished, at least one bound missed (the shortfalls)
    FAILED = "failed"            # a watchdog or the device stopped it (the fault)
    INTERRUPTED = "interrupted"  # Ctrl-C

    def __repr__(self) -> str:  # reads as the string it is equal to
        return repr(self.value)

    @property
    def finished(self) -> bool:
        """The drawing was completed: its metrics describe all of it."""
        return self in (Status.OK, Status.DEGRADED)


@dataclass(frozen=True)
class Bounds:
    """The bounds a finished drawing must keep to be ``ok`` (a scenario's ``[judge]`` table).

    The defaults are the README's robustness bounds (tracking RMS <= 0.3 mm, ink chamfer <=
    0.3 mm, no gap, force within F* +- 0.1 N while drawing from its 1st to its 99th
    percentile) and two of this module's own: no drawing sample more than 1 mm off its
    reference (the shipped scenarios and robustness rows of the iiwa reach 0.79 mm at most),
    and the mean contact force within 0.05 N of its set point (they reach 0.01 N).

    Attributes:
        tracking_rms_mm: RMS distance [mm] of the pen from its reference while drawing.
        tracking_max_mm: Largest distance [mm] of the pen from its reference while drawing.
        ink_chamfer_mm: Ink-versus-plan chamfer distance [mm]
            (:func:`inkarm.analysis.metrics.ink_chamfer_mm`).
        gap_mm: Total length [mm] of the strokes drawn without contact.
        force_band_n: Half-width [N] of the band around the set point F* that holds the
            1st to the 99th percentile of the force over the drawing samples.
        force_error_n: Largest distance [N] of the mean contact force from F*.
    """

    tracking_rms_mm: float = 0.3
    tracking_max_mm: float = 1.0
    ink_chamfer_mm: float = 0.3
    gap_mm: float = 0.0
    force_band_n: float = 0.1
    force_error_n: float = 0.05

    def __post_init__(self) -> None:
        check_ranges(self, BOUND_RANGES)


# Generous but finite: a sheet is at most 2 m, a pen force at most 50 N.
BOUND_RANGES = {
    "tracking_rms_mm": Range(0.0, 2000.0, "mm"),
    "tracking_max_mm": Range(0.0, 2000.0, "mm"),
    "ink_chamfer_mm": Range(0.0, 2000.0, "mm"),
    "gap_mm": Range(0.0, 1e6, "mm"),
    "force_band_n": Range(0.0, 50.0, "N"),
    "force_error_n": Range(0.0, 50.0, "N"),
}

# What a backend may or may not sense, and the quantity each bound needs.
TIP, INK, CONTACT, FORCE = "tip", "ink", "contact", "force"
QUANTITIES = (TIP, INK, CONTACT, FORCE)
BOUND_NEEDS = {
    "tracking_rms_mm": TIP,
    "tracking_max_mm": TIP,
    "ink_chamfer_mm": INK,
    "gap_mm": CONTACT,
    "force_band_n": FORCE,
    "force_error_n": FORCE,
}


@dataclass(frozen=True)
class Senses:
    """What a backend measures of a run: every quantity (:data:`QUANTITIES`: the pen ``tip``,
    the ``ink`` on the page, ``contact`` of the pen with the paper, the pen ``force``) unless
    ``lacking`` names it, with why. ``Senses()`` senses everything (the simulation)."""

    lacking: tuple[tuple[str, str], ...] = ()

    def __post_init__(self) -> None:
        for quantity, _ in self.lacking:
            if quantity not in QUANTITIES:
                raise InputError(f"unknown quantity {quantity!r}; expected one of "
                                 f"{', '.join(QUANTITIES)}", key="senses", value=quantity,
                                 choices=QUANTITIES)

    @classmethod
    def without(cls, **why: str) -> Senses:
        """Everything but the quantities named, each with why it is not sensed
        (``Senses.without(force="a Dynamixel arm has no force sensor")``)."""
        return cls(tuple(why.items()))

    def senses(self, quantity: str) -> bool:
        return quantity not in dict(self.lacking)

    def why_not(self, quantity: str) -> str:
        """Why ``quantity`` is not sensed ("" when it is)."""
        return dict(self.lacking).get(quantity, "")


@dataclass(frozen=True)
class Shortfall:
    """A bound a finished run missed: its name (a :class:`Bounds` field), the measured value
    and the limit, in the bound's unit (NaN when the metric is undefined), and a sentence."""

    bound: str
    measured: float
    limit: float
    sentence: str

    def __str__(self) -> str:
        return self.sentence


def _value(metrics: Mapping, key: str) -> float:
    """``metrics[key]`` as a float; NaN when absent or not a number."""
    v = metrics.get(key)
    if isinstance(v, bool) or not isinstance(v, int | float):
        return math.nan
    return float(v)


def _measure(bound: str, metrics: Mapping, limit: float,
             force_n: float) -> tuple[float, str, str, str]:
    """The value of ``bound``'s quantity in ``metrics`` (NaN when undefined), its label and
    unit, and the sentence of a shortfall."""
    if bound == "gap_mm":
        v = _value(metrics, "gap_mm")
        # (ends with "drawn without contact", as the reason always has)
        return v, "gaps", "mm", (f"gaps above gap_mm = {limit:g} mm: {v:.4g} mm of the "
                                 "strokes drawn without contact")
    if bound == "force_band_n":
        lo, hi = _value(metrics, "force_p1_n"), _value(metrics, "force_p99_n")
        v = math.nan if math.isnan(lo) or math.isnan(hi) else max(force_n - lo, hi - force_n)
        return v, "force band", "N", (f"force {lo:.3f}..{hi:.3f} N (1st..99th percentile "
                                      f"while drawing) outside {force_n:g} +- {limit:g} N "
                                      "(force_band_n)")
    if bound == "force_error_n":
        mean = _value(metrics, "contact_force_mean_n")
        v = abs(mean - force_n)
        return v, "mean force", "N", (f"mean force {mean:.3f} N, {v:.3g} N from the "
                                      f"{force_n:g} N set point, above force_error_n = "
                                      f"{limit:g} N")
    label = {"tracking_rms_mm": "tracking RMS", "tracking_max_mm": "tracking max",
             "ink_chamfer_mm": "ink chamfer"}[bound]
    v = _value(metrics, bound)
    return v, label, "mm", f"{label} {v:.4g} mm above {bound} = {limit:g} mm"


def judge(metrics: Mapping, bounds: Bounds, force_n: float,
          sensed: Senses = Senses()) -> tuple[list[Shortfall], list[str]]:
    """The bounds a finished run missed, and those it could not be judged on.

    Every bound of ``bounds`` is judged against ``metrics`` (a :class:`Metrics` or the mapping
    :func:`inkarm.analysis.metrics.compute_metrics` returns) unless the quantity it needs is
    not ``sensed``: then it is listed as unjudged, ``"force_band_n not judged: <why>"``. A
    bound holds only when its measured value is a number within it: an undefined (NaN or
    absent) metric is a shortfall, never a pass. ``force_n`` is the force set point F* [N].

    Returns:
        (shortfalls, unjudged): the :class:`Shortfall` of each bound missed, in the order of
        the :class:`Bounds` fields; one sentence per bound not judged.
    """
    shortfalls: list[Shortfall] = []
    unjudged: list[str] = []
    for bound, quantity in BOUND_NEEDS.items():
        if not sensed.senses(quantity):
            unjudged.append(f"{bound} not judged: {sensed.why_not(quantity)}")
            continue
        limit = getattr(bounds, bound)
        measured, label, unit, sentence = _measure(bound, metrics, limit, force_n)
        if measured <= limit:
            continue
        if math.isnan(measured):  # an undefined metric never passes
            sentence = f"{label} undefined, so not within {bound} = {limit:g} {unit}"
        shortfalls.append(Shortfall(bound, measured, limit, sentence))
    return shortfalls, unjudged


@dataclass(frozen=True, eq=False)
class Metrics(Mapping):
    """A run's metrics, typed; also a read-only mapping of the metrics it has (a field left
    None is absent), so ``metrics["tracking_rms_mm"]``, ``.get``, ``.items()``, ``dict(m)``
    and ``m == {}`` (nothing measured) read as they would on a dict. NaN is an undefined
    metric (e.g. the force of an arm that senses none); :meth:`to_dict` is what files get.

    Fields as :func:`inkarm.analysis.metrics.compute_metrics` names them (lengths [mm] in the
    page frame, forces [N], angles [rad]), ``bus_overruns``: control periods a Dynamixel bus
    overran (that backend only), and the human-likeness of the planned drawing (the drawing
    the controller was given, measured as :mod:`inkarm.analysis.humanlike` measures a human
    recording; reported, never judged): ``plan_beta`` (the 2/3 power law's exponent),
    ``plan_peaks_per_second`` [1/s] and ``plan_jerk_per_peak``.
    """

    tracking_rms_mm: float | None = None
    tracking_max_mm: float | None = None
    ink_chamfer_mm: float | None = None
    gap_mm: float | None = None
    contact_force_mean_n: float | None = None
    contact_force_std_n: float | None = None
    force_p1_n: float | None = None
    force_p99_n: float | None = None
    joint_limit_margin_rad: float | None = None
    realtime_factor: float | None = None
    bus_overruns: int | None = None
    plan_beta: float | None = None
    plan_peaks_per_second: float | None = None
    plan_jerk_per_peak: float | None = None

    @classmethod
    def of(cls, values: Mapping | None) -> Metrics:
        """``values`` (a mapping of metric names) as Metrics; an unknown name is refused."""
        if values is None:
            return cls()
        if isinstance(values, Metrics):
            return values
        names = {f.name for f in dataclasses.fields(cls)}
        for key in values:
            if key not in names:
                raise unknown_name("metric", key, sorted(names), key=str(key))
        return cls(**values)

    def replace(self, **values) -> Metrics:
        """These metrics with some replaced (``None`` removes one)."""
        return dataclasses.replace(self, **values)

    def __getitem__(self, key: str):
        value = getattr(self, key, None) if key in _METRIC_NAMES else None
        if value is None:
            raise KeyError(key)
        return value

    def __iter__(self) -> Iterator[str]:
        return (name for name in _METRIC_NAMES if getattr(self, name) is not None)

    def __len__(self) -> int:
        return sum(1 for _ in self)

    def __repr__(self) -> str:
        return f"Metrics({', '.join(f'{k}={v!r}' for k, v in self.items())})"

    def to_dict(self) -> dict:
        """The metrics it has, by name, as plain numbers (NaN kept: a file writer decides)."""
        return dict(self.items())


_METRIC_NAMES = tuple(f.name for f in dataclasses.fields(Metrics))

def metric_text(metrics: Mapping, key: str, unit: str = "mm", spec: str = ".3f") -> str:
    """``metrics[key]`` as people read it: the number and ``unit``, "not sensed" where it is
    undefined (NaN: the backend cannot sense it, or it is absent), "nothing to compare" where
    it is infinite (no ink to measure a distance to)."""
    value = float(metrics.get(key, math.nan))
    if math.isnan(value):
        return "not sensed"
    if math.isinf(value):
        return "nothing to compare"
    return f"{value:{spec}} {unit}".rstrip()


__all__ = ["BOUND_NEEDS", "QUANTITIES", "Bounds", "Metrics", "Senses", "Shortfall", "Status",
           "judge", "metric_text"]
