"""Handstyles: named kinemic realisations of a target sequence (seed 000 sec. 4 and 4.1).

Berio et al. call the centres of the Gaussians the *iconic* description of a letter and
everything else (covariances, system order, maximum displacement d) its *kinemic*
realisation; a handstyle is one choice of the latter. Covariances are semi-tied
(seed 000 eq. 22)::

    Sigma_i = H D_i H^T,   D_i = h_i I,   h_i ~ N(h, rho)

so every target of a style shares the oblique basis H (a slant, a shear) and differs only in
magnitude. Larger h or smaller d give smoother, looser strokes; a slanted H leans them. The
basis vectors are the *columns* of H; a TOML file writes H row by row (``basis = [[H00, H01],
[H10, H11]]``), the same convention as ``semi_tied.H`` in a plan file.

The LQT optimum is linear in the means (it starts at rest on the first mean), and scaling
Sigma and R together only scales the whole cost, so the *shape* of a realised stroke depends
on the ratio sigma / d = sqrt(h) / d, the shape of H, the order and rho, never on the
drawing's size: one style fits 5 mm letters and 50 mm tags alike. With R from eq. 9 the
chain's time constant is about T_s / (2 pi) * (sigma / d)^(1/n).

A :class:`Handstyle` also carries the few planning choices that belong to a hand: time per
target, how sparsely a font polyline is turned into targets (``thin_angle``,
``max_spacing``), and how letters are joined: no junction target of a ligature turns by more
than ``ligature_angle``, the connector bending or looping (``eyelet``) so that the letters
keep their targets (:func:`inkarm.plans.ligatures.join_ligatures`).

The presets (:data:`PRESETS`) live in ``inkarm/data/handstyles.toml`` and are read by the
same checked reader as a user's ``--styles`` file (:func:`load_handstyles`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from functools import lru_cache
from pathlib import Path
from types import MappingProxyType

import numpy as np

from inkarm.core.plan import GaussianTarget, MotorPlan, StrokePlan, stroke_from_arrays
from inkarm.core.trajectory import A4_MM, Drawing
from inkarm.errors import ScenarioError
from inkarm.io.toml import load_toml
from inkarm.models.lqt import LQTConfig, semi_tied_covariances


def slanted_basis(slant_deg: float, stretch: float = 1.0) -> np.ndarray:
    """Oblique basis H = [e_x, v]: v leans ``slant_deg`` [deg] right of vertical, |v| = stretch.

    The basis vectors are the *columns* of H. With D_i = h I, Sigma = h H H^T is an ellipse
    elongated along the slant: the shear that seed 000 (Fig. 7) describes as turning a circle
    into an oriented ellipse.
    """
    a = np.radians(slant_deg)
    return np.array([[1.0, stretch * np.sin(a)], [0.0, stretch * np.cos(a)]])



TIMINGS = ("isochronous", "pulses")
"""How a restyle times its targets: DPPLA targets held alike (seed 000's local isochrony), or
key-points at the trace's speed minima and peaks, at its own times, velocities and accelerations
(:mod:`inkarm.plans.pulses`)."""
PULSE_DT = 0.005
"""The LQT time step of a restyle with timing "pulses" [s], unless told otherwise. Key-points
land on the nearest step and take the recording's state at that step's time, so a coarser step
keeps the peaks too (LASA training demonstrations: 69 % of restyles keep their exact peak count
at 5 ms and at 10 ms); 5 ms is kept as the step the ``human`` style was fitted at."""
MIN_SPACING = 0.01  # [fraction of the letter height]: 100 targets a letter height at most

@dataclass(frozen=True)
class Handstyle:
    """A handstyle: semi-tied covariance settings plus LQT and planning parameters.

    Attributes:
        name: Preset or user name.
        basis: H, (2, 2), dimensionless; its *columns* are the oblique basis vectors and
            Sigma_i = h_i H H^T. In a handstyle file ``basis`` is H written row by row,
            ``[[H00, H01], [H10, H11]]``, exactly like ``semi_tied.H`` in a plan file
            (:mod:`inkarm.io.planfile`): the same matrix gives the same covariances.
        h: Covariance magnitude in [mm^2] (seed 000 eq. 22).
        rho: Variance of the per-target magnitudes h_i ~ N(h, rho), in [mm^4]; 0 = none.
        d: Maximum displacement in [mm] that sets the control cost (seed 000 eq. 9).
        order: Order n of the integrator chain (1..7).
        segment_time: Time each target is tracked, T_s in [s] (local isochrony).
        thin_angle: A font vertex becomes a target only where the path has turned by at
            least this many [deg] since the last target; 0 keeps every vertex.
        max_spacing: Longest distance between consecutive letter targets, as a fraction of the
            letter height; longer edges get evenly spaced extra targets. None keeps the
            font's own (sparse) vertices.
        ligature_angle: Where two letters are joined, no junction target (the end of the
            one, connector targets, the start of the other) turns by more than this [deg]
            (seed 000 sec. 4.1); 180 accepts any junction.
        eyelet: Size of the connector's bends and of the loop by which it turns back into a
            letter (a cursive retrace written as an eyelet), as a fraction of the letter
            height; 0 = seed 000's rule instead, which drops sharp junction targets, letter
            targets included.
        timing: How a restyle with this style times its targets: "isochronous" (DPPLA
            targets, each held alike) or "pulses" (key-points at the trace's own speed minima
            and peaks, at its times, velocities and accelerations:
            :mod:`inkarm.plans.pulses`). Text is always isochronous (a font has no timing of
            its own).
        description: One line for ``--help`` and listings.
    """

    name: str
    basis: np.ndarray = field(default_factory=lambda: np.eye(2))
    h: float = 0.01
    rho: float = 0.0
    d: float = 0.01
    order: int = 4
    segment_time: float = 0.06
    thin_angle: float = 0.0
    max_spacing: float | None = None
    ligature_angle: float = 100.0
    eyelet: float = 0.1
    timing: str = "isochronous"
    description: str = ""

    def __post_init__(self) -> None:
        basis = np.asarray(self.basis, dtype=float)
        if basis.shape != (2, 2) or not np.all(np.isfinite(basis)):
            given = np.asarray(self.basis).tolist()
            self._fail(f"basis must be H as a finite 2 x 2 matrix, written row by row, got {given}",
                       given)
        if abs(np.linalg.det(basis)) < 1e-9:
            self._fail(f"basis H = {basis.tolist()} is singular: its columns (the basis "
                       "vectors) are parallel", basis.tolist())
        object.__setattr__(self, "basis", basis)
        for key in ("h", "d", "segment_time"):
            self._check_positive(key)
        if not (np.isfinite(self.rho) and self.rho >= 0):
            self._fail(f"rho must be >= 0, got {self.rho}", self.rho)
        if (
            isinstance(self.order, bool)
            or int(self.order) != self.order
            or not 1 <= self.order <= 7
        ):
            self._fail(f"order must be an integer in 1..7, got {self.order}", self.order)
        object.__setattr__(self, "order", int(self.order))
        if self.max_spacing is not None:
            self._check_positive("max_spacing")
            if self.max_spacing < MIN_SPACING:  # a budget: each letter gets 1 / spacing targets
                self._fail(f"max_spacing must be at least {MIN_SPACING} (a fraction of the "
                           f"letter height), got {self.max_spacing}", self.max_spacing)
        if not (np.isfinite(self.eyelet) and 0.0 <= self.eyelet <= 1.0):
            self._fail(f"eyelet must be in [0, 1] (a fraction of the letter height), got "
                       f"{self.eyelet}", self.eyelet)
        if self.timing not in TIMINGS:
            self._fail(f"timing must be one of {', '.join(TIMINGS)}, got {self.timing!r}",
                       self.timing)
        for key in ("thin_angle", "ligature_angle"):
            value = getattr(self, key)
            if not (np.isfinite(value) and 0.0 <= value <= 180.0):
                self._fail(f"{key} must be in [0, 180] degrees, got {value}", value)

    def _fail(self, message: str, value) -> None:
        raise ScenarioError(message, key=f"handstyle {self.name!r}", value=value)

    def _check_positive(self, key: str) -> None:
        value = getattr(self, key)
        if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
            self._fail(f"{key} must be a positive number, got {value!r}", value)

    def lqt_config(self, dt: float = 0.01) -> LQTConfig:
        """The LQT settings of this style, time step ``dt`` in [s]."""
        return LQTConfig(order=self.order, dt=dt, d=self.d)

    def covariances(self, m: int, rng: np.random.Generator) -> np.ndarray:
        """(m, 2, 2) semi-tied covariances in [mm^2], seed 000 eq. 22.

        With rho = 0 every target's is h H H^T and ``rng`` is not drawn from: the one
        covariance is worked out (and checked) once per style and repeated."""
        if self.rho == 0 and isinstance(m, int) and not isinstance(m, bool) and m >= 1:
            one = _unperturbed_covariance(tuple(self.basis.ravel().tolist()), self.h)
            return np.repeat(one, m, axis=0)
        return np.asarray(semi_tied_covariances(m, self.basis, self.h, rho=self.rho, seed=rng))

    def stroke_plan(
        self, means: np.ndarray, rng: np.random.Generator, meta: dict | None = None
    ) -> StrokePlan:
        """A stroke through ``means`` (m, 2) [mm] with this style's covariances and timing."""
        covs = self.covariances(len(means), rng)
        plan = stroke_from_arrays(means, covs, self.segment_time, meta=meta)  # checked in bulk
        if plan is not None:
            return plan
        targets = tuple(GaussianTarget(mu, c) for mu, c in zip(means, covs))  # raises the error
        return StrokePlan(targets, self.segment_time, meta=dict(meta or {}))

    def motor_plan(self, sequences, rng: np.random.Generator, unit: str) -> MotorPlan:
        """One stroke per joined target sequence (``means``, ``letters``, ``connectors``), each
        stroke's meta naming the ``unit`` (e.g. "letters", "glyphs") its targets come from.
        Refused for a style with timing "pulses": a font's targets have no timing of their own
        to keep."""
        if self.timing != "isochronous":
            text_styles = sorted(PRESETS)
            raise ScenarioError(
                f"handstyle {self.name!r} re-times recordings (timing {self.timing!r}); "
                f"{unit} have no recording to take a timing from: choose one of "
                f"{', '.join(text_styles)}, or use it with `inkarm restyle --hand {self.name}`",
                key="style", value=self.name, choices=text_styles)
        return MotorPlan(tuple(
            self.stroke_plan(
                seq.means,
                rng,
                meta={  # Python ints and bools, as int(i) and bool(c) of each
                    unit: tuple(np.asarray(seq.letters).astype(np.int64).tolist()),
                    "connectors": tuple(np.asarray(seq.connectors).astype(bool).tolist()),
                },
            )
            for seq in sequences
        ))

    def realise(
        self,
        plan: MotorPlan,
        dt: float = 0.01,
        pen_up_time: float = 0.25,
        page_size: tuple[float, float] = A4_MM,
    ) -> Drawing:
        """Solve the LQT for every stroke and time the strokes one after the other.

        Args:
            plan: The motor plan (covariances already set, e.g. by :meth:`stroke_plan`).
            dt: LQT time step in [s].
            pen_up_time: Pause between strokes in [s] (pen travel, not simulated here).
            page_size: (width, height) of the page in [mm].
        """
        from inkarm.models.lqt import solve  # (the solvers bring SciPy: only when solving)

        cfg = self.lqt_config(dt)
        strokes = [solve(stroke, cfg) for stroke in plan.strokes]
        meta = {"style": self.name, "strokes": [dict(s.meta) for s in plan.strokes]}
        return Drawing(strokes, page_size=page_size, meta=meta).sequential(pause=pen_up_time)


@lru_cache(maxsize=64)
def _unperturbed_covariance(basis: tuple[float, ...], h: float) -> np.ndarray:
    """semi_tied_covariances(1, H, h), rho = 0: (1, 2, 2), read-only (shared); equal, element
    for element, to every matrix that ``semi_tied_covariances(m, H, h)`` returns."""
    one = np.asarray(semi_tied_covariances(1, np.reshape(basis, (2, 2)), h, rho=0.0))
    one.flags.writeable = False
    return one


PRESETS_FILE = Path(__file__).parents[1] / "data" / "handstyles.toml"
"""The preset handstyles, read with :func:`load_handstyles` like a user's file."""
FITTED_FILE = PRESETS_FILE.with_name("handstyles_fitted.toml")
"""The fitted handstyles (:data:`FITTED`), made by ``inkarm fit-style``."""

_KEYS = {f.name for f in fields(Handstyle)} - {"name"}
_NUMBERS = (
    "h", "rho", "d", "segment_time", "thin_angle", "max_spacing", "ligature_angle", "eyelet"
)


def handstyle_from_mapping(
    table: dict,
    name: str = "custom",
    where: str = "handstyle",
    *,
    file: str | Path | None = None,
    bases: Mapping[str, Handstyle] | None = None,
    default_base: str | None = "faithful",
) -> Handstyle:
    """A handstyle from a mapping (a TOML table or a dict).

    Keys are the :class:`Handstyle` fields plus ``base``, the style to start from (one of
    ``bases``, default the presets; without ``base``, ``default_base``, or the Handstyle
    defaults when that is None). ``basis`` is H written row by row (its columns are the
    basis vectors, as ``semi_tied.H`` in a plan file); ``slant`` [deg] and ``stretch`` give
    ``basis = slanted_basis(slant, stretch)`` instead. Errors are :class:`ScenarioError`
    with ``file``, ``key`` = ``where`` and the offending ``value``.
    """

    def error(message: str, value=ScenarioError.NO_VALUE, choices=()) -> ScenarioError:
        return ScenarioError(message, file=file, key=where, value=value, choices=choices)

    if not isinstance(table, dict):
        raise error(f"expected a table of handstyle settings, got {type(table).__name__}")
    allowed = sorted(_KEYS | {"base", "slant", "stretch"})
    for key in table:
        if key not in allowed:
            raise error(f"unknown key {key!r}; expected one of {', '.join(allowed)}", key, allowed)
    values = dict(table)
    base_name = values.pop("base", default_base)
    try:
        base = Handstyle(name) if base_name is None else _lookup(
            str(base_name), PRESETS if bases is None else bases
        )
    except ScenarioError as e:
        raise error(f"base: {e.message}", base_name, e.choices) from None
    _read_basis(values, error)
    for key in _NUMBERS:
        if key in values:
            values[key] = _number(error, key, values[key])
    for key in ("description", "timing"):
        if not isinstance(values.get(key, ""), str):
            raise error(f"{key} must be a string, got {values[key]!r}", values[key])
    if "order" in values and (
        isinstance(values["order"], bool) or not isinstance(values["order"], int)
    ):
        raise error(f"order must be an integer in 1..7, got {values['order']!r}", values["order"])
    try:
        return replace(base, name=name, **values)
    except ScenarioError as e:
        raise error(e.message, e.value) from None


def _read_basis(values: dict, error) -> None:
    """Replace ``basis`` (H row by row) or ``slant``/``stretch`` in ``values`` by the array H."""
    if "basis" in values:
        if "slant" in values or "stretch" in values:
            raise error("give either basis or slant/stretch, not both")
        try:
            values["basis"] = np.array(values["basis"], dtype=float)
        except (TypeError, ValueError):
            raise error(f"basis must be H as a 2 x 2 matrix, written row by row, got "
                        f"{values['basis']!r}", values["basis"]) from None
    elif "slant" in values or "stretch" in values:
        values["basis"] = slanted_basis(
            _number(error, "slant", values.pop("slant", 0.0)),
            _number(error, "stretch", values.pop("stretch", 1.0)),
        )


def _number(error, key: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise error(f"{key} must be a number, got {value!r}", value)
    return float(value)


def load_handstyles(path: str | Path) -> dict[str, Handstyle]:
    """Handstyles defined in a TOML file, one table per style: ``[styles.NAME]``.

    A style without ``base`` starts from the ``faithful`` preset; ``base`` names a preset or
    a style above it in the same file.
    """
    return _read_styles(path, PRESETS, default_base="faithful")


def _read_styles(
    path: str | Path, bases: Mapping[str, Handstyle], default_base: str | None
) -> dict[str, Handstyle]:
    """The [styles.NAME] tables of a TOML file; ``base`` may name one of ``bases`` or a style
    above it in the same file."""
    doc = load_toml(path, "handstyle file")
    unknown = set(doc) - {"styles"}
    if unknown:
        key = min(unknown)
        raise ScenarioError(f"unknown key {key!r}; expected [styles.NAME] tables",
                            file=str(path), value=key, choices=("styles",))
    styles = doc.get("styles", {})
    if not isinstance(styles, dict):
        raise ScenarioError("styles must be a table of [styles.NAME] tables", file=str(path),
                            key="styles", value=styles)
    out: dict[str, Handstyle] = {}
    for name, table in styles.items():
        out[name] = handstyle_from_mapping(
            table, name=name, where=f"styles.{name}", file=str(path),
            bases={**bases, **out}, default_base=default_base,
        )
    return out


def _lookup(name: str, styles: Mapping[str, Handstyle]) -> Handstyle:
    if name not in styles:
        raise ScenarioError(
            f"unknown handstyle {name!r}; available: {', '.join(sorted(styles))}",
            value=name, choices=sorted(styles),
        )
    return styles[name]


def get_handstyle(name: str, extra: Mapping[str, Handstyle] | None = None) -> Handstyle:
    """The style called ``name`` among ``extra`` (user styles, first), the presets and the
    fitted styles."""
    return _lookup(name, {**PRESETS, **FITTED, **(extra or {})})


PRESETS: Mapping[str, Handstyle] = MappingProxyType(
    _read_styles(PRESETS_FILE, {}, default_base=None)
)
"""The preset handstyles by name (read-only), read from ``inkarm/data/handstyles.toml``."""
FITTED: Mapping[str, Handstyle] = MappingProxyType(
    _read_styles(FITTED_FILE, {}, default_base=None)
)
"""The handstyles fitted to people (``human``), read from ``inkarm/data/handstyles_fitted.toml``:
they restyle recordings with their own timing (``timing = "pulses"``), not text."""
