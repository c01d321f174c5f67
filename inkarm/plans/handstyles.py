"""Handstyles: named kinemic realisations of a target sequence (seed 000 sec. 4 and 4.1).

Berio et al. call the centres of the Gaussians the *iconic* description of a letter and
everything else (covariances, system order, maximum displacement d) its *kinemic*
realisation; a handstyle is one choice of the latter. Covariances are semi-tied
(seed 000 eq. 22)::

    Sigma_i = H D_i H^T,   D_i = h_i I,   h_i ~ N(h, rho)

so every target of a style shares the oblique basis H (a slant, a shear) and differs only in
magnitude. Larger h or smaller d give smoother, looser strokes; a slanted H leans them.

The LQT optimum is linear in the means (it starts at rest on the first mean), and scaling
Sigma and R together only scales the whole cost, so the *shape* of a realised stroke depends
on the ratio sigma / d = sqrt(h) / d, the shape of H, the order and rho, never on the
drawing's size: one style fits 5 mm letters and 50 mm tags alike. With R from eq. 9 the
chain's time constant is about T_s / (2 pi) * (sigma / d)^(1/n).

A :class:`Handstyle` also carries the few planning choices that belong to a hand: time per
target, how sparsely a font polyline is turned into targets (``thin_angle``,
``max_spacing``) and when a ligature drops a sharp junction target (``ligature_angle``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from pathlib import Path

import numpy as np

from inkarm.core.plan import GaussianTarget, MotorPlan, StrokePlan
from inkarm.core.trajectory import A4_MM, Drawing
from inkarm.errors import ScenarioError
from inkarm.io.toml import load_toml
from inkarm.models.lqt import LQTConfig, semi_tied_covariances, solve


def slanted_basis(slant_deg: float, stretch: float = 1.0) -> np.ndarray:
    """Oblique basis H = [e_x, v]: v leans ``slant_deg`` [deg] right of vertical, |v| = stretch.

    With D_i = h I, Sigma = h H H^T is an ellipse elongated along the slant: the shear that
    seed 000 (Fig. 7) describes as turning a circle into an oriented ellipse.
    """
    a = np.radians(slant_deg)
    return np.array([[1.0, stretch * np.sin(a)], [0.0, stretch * np.cos(a)]])


@dataclass(frozen=True)
class Handstyle:
    """A handstyle: semi-tied covariance settings plus LQT and planning parameters.

    Attributes:
        name: Preset or user name.
        basis: H, (2, 2), columns are the (dimensionless) oblique basis vectors.
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
        ligature_angle: A junction target whose turning angle exceeds this [deg] is dropped
            when two letters are joined (seed 000 sec. 4.1); 180 keeps all.
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
    description: str = ""

    def __post_init__(self) -> None:
        where = f"handstyle {self.name!r}"
        basis = np.asarray(self.basis, dtype=float)
        if basis.shape != (2, 2) or not np.all(np.isfinite(basis)):
            raise ScenarioError(
                f"{where}: basis must be two finite 2-D vectors, got {basis.tolist()}"
            )
        if abs(np.linalg.det(basis)) < 1e-9:
            raise ScenarioError(
                f"{where}: basis vectors {basis.T.tolist()} are parallel (singular H)"
            )
        object.__setattr__(self, "basis", basis)
        _positive(where, "h", self.h)
        _positive(where, "d", self.d)
        _positive(where, "segment_time", self.segment_time)
        if not (np.isfinite(self.rho) and self.rho >= 0):
            raise ScenarioError(f"{where}: rho must be >= 0, got {self.rho}")
        if (
            isinstance(self.order, bool)
            or int(self.order) != self.order
            or not 1 <= self.order <= 7
        ):
            raise ScenarioError(f"{where}: order must be an integer in 1..7, got {self.order}")
        object.__setattr__(self, "order", int(self.order))
        if self.max_spacing is not None:
            _positive(where, "max_spacing", self.max_spacing)
        for key in ("thin_angle", "ligature_angle"):
            value = getattr(self, key)
            if not (np.isfinite(value) and 0.0 <= value <= 180.0):
                raise ScenarioError(f"{where}: {key} must be in [0, 180] degrees, got {value}")

    def lqt_config(self, dt: float = 0.01) -> LQTConfig:
        """The LQT settings of this style, time step ``dt`` in [s]."""
        return LQTConfig(order=self.order, dt=dt, d=self.d)

    def covariances(self, m: int, rng: np.random.Generator) -> np.ndarray:
        """(m, 2, 2) semi-tied covariances in [mm^2], seed 000 eq. 22."""
        return np.asarray(semi_tied_covariances(m, self.basis, self.h, rho=self.rho, seed=rng))

    def stroke_plan(
        self, means: np.ndarray, rng: np.random.Generator, meta: dict | None = None
    ) -> StrokePlan:
        """A stroke through ``means`` (m, 2) [mm] with this style's covariances and timing."""
        covs = self.covariances(len(means), rng)
        targets = tuple(GaussianTarget(mu, c) for mu, c in zip(means, covs))
        return StrokePlan(targets, self.segment_time, meta=dict(meta or {}))

    def motor_plan(self, sequences, rng: np.random.Generator, unit: str) -> MotorPlan:
        """One stroke per joined target sequence (``means``, ``letters``, ``connectors``), each
        stroke's meta naming the ``unit`` (e.g. "letters", "glyphs") its targets come from."""
        return MotorPlan(tuple(
            self.stroke_plan(
                seq.means,
                rng,
                meta={
                    unit: tuple(int(i) for i in seq.letters),
                    "connectors": tuple(bool(c) for c in seq.connectors),
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
        cfg = self.lqt_config(dt)
        strokes = [solve(stroke, cfg) for stroke in plan.strokes]
        meta = {"style": self.name, "strokes": [dict(s.meta) for s in plan.strokes]}
        return Drawing(strokes, page_size=page_size, meta=meta).sequential(pause=pen_up_time)


def _positive(where: str, key: str, value) -> None:
    if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
        raise ScenarioError(f"{where}: {key} must be a positive number, got {value!r}")


# Only sigma / d = sqrt(h) / d (with the order and H's shape) sets how much a style smooths.
PRESETS: dict[str, Handstyle] = {
    s.name: s
    for s in (
        Handstyle(
            "faithful",
            h=0.01,
            d=0.01,
            order=4,
            segment_time=0.06,
            max_spacing=0.15,
            description="every font vertex a tight target: the font, drawn by a smooth hand",
        ),
        Handstyle(
            "cursive",
            basis=slanted_basis(20.0, stretch=1.5),
            h=0.2,
            d=0.01,
            order=4,
            segment_time=0.07,
            thin_angle=15.0,
            description="slight right slant, moderately smooth: everyday handwriting",
        ),
        Handstyle(
            "loose",
            h=1.0,
            d=0.01,
            order=5,
            segment_time=0.08,
            thin_angle=25.0,
            description="large covariances, 5th order: rounded, co-articulated letters",
        ),
        Handstyle(
            "italic",
            basis=slanted_basis(35.0, stretch=2.5),
            h=0.3,
            d=0.01,
            order=5,
            segment_time=0.08,
            thin_angle=20.0,
            description="strong oblique basis: covariances stretched along a 35 deg slant",
        ),
        Handstyle(
            "hurried",
            basis=slanted_basis(-10.0, stretch=1.5),
            h=0.3,
            rho=0.05,
            d=0.02,
            order=3,
            segment_time=0.07,
            thin_angle=15.0,
            description="3rd order, leaning back, per-target magnitude noise (rho > 0)",
        ),
        Handstyle(
            "graffiti",
            basis=slanted_basis(25.0, stretch=2.0),
            h=1.0,
            rho=0.1,
            d=0.05,
            order=5,
            segment_time=0.1,
            thin_angle=20.0,
            description="tag style: sweeping 5th-order strokes on a slanted basis",
        ),
    )
}

_KEYS = {f.name for f in fields(Handstyle)} - {"name"}


def handstyle_from_mapping(
    table: dict, name: str = "custom", where: str = "handstyle"
) -> Handstyle:
    """A user handstyle from a mapping (a TOML table or a dict).

    Keys are the :class:`Handstyle` fields (``basis`` as a list of two basis vectors) plus
    ``base``, the preset to start from (default ``"faithful"``). ``slant`` [deg] and
    ``stretch`` give ``basis = slanted_basis(slant, stretch)`` instead of ``basis``.
    Unknown keys raise :class:`ScenarioError` naming the key.
    """
    if not isinstance(table, dict):
        raise ScenarioError(
            f"{where}: expected a table of handstyle settings, got {type(table).__name__}"
        )
    allowed = _KEYS | {"base", "slant", "stretch"}
    for key in table:
        if key not in allowed:
            raise ScenarioError(
                f"{where}: unknown key {key!r}; expected one of {', '.join(sorted(allowed))}"
            )
    values = dict(table)
    try:
        base = get_handstyle(str(values.pop("base", "faithful")))
    except ScenarioError as e:
        raise ScenarioError(f"{where}: base: {e}") from None
    if "basis" in values:
        if "slant" in values or "stretch" in values:
            raise ScenarioError(f"{where}: give either basis or slant/stretch, not both")
        try:
            values["basis"] = np.array(values["basis"], dtype=float).T
        except (TypeError, ValueError):
            raise ScenarioError(
                f"{where}: basis must be two 2-D vectors, got {values['basis']!r}"
            ) from None
    elif "slant" in values or "stretch" in values:
        values["basis"] = slanted_basis(
            _number(where, "slant", values.pop("slant", 0.0)),
            _number(where, "stretch", values.pop("stretch", 1.0)),
        )
    for key in ("h", "rho", "d", "segment_time", "thin_angle", "max_spacing", "ligature_angle"):
        if key in values:
            values[key] = _number(where, key, values[key])
    if "order" in values and (
        isinstance(values["order"], bool) or not isinstance(values["order"], int)
    ):
        raise ScenarioError(f"{where}: order must be an integer in 1..7, got {values['order']!r}")
    try:
        return replace(base, name=name, **values)
    except ScenarioError as e:
        raise ScenarioError(f"{where}: {str(e).split(': ', 1)[-1]}") from None


def _number(where: str, key: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScenarioError(f"{where}: {key} must be a number, got {value!r}")
    return float(value)


def load_handstyles(path: str | Path) -> dict[str, Handstyle]:
    """Handstyles defined in a TOML file, one table per style: ``[styles.NAME]``."""
    doc = load_toml(path, "handstyle file")
    unknown = set(doc) - {"styles"}
    if unknown:
        raise ScenarioError(f"{path}: unknown key {min(unknown)!r}; expected [styles.NAME] tables")
    styles = doc.get("styles", {})
    if not isinstance(styles, dict):
        raise ScenarioError(f"{path}: styles must be a table of [styles.NAME] tables")
    return {
        name: handstyle_from_mapping(table, name=name, where=f"{path}: styles.{name}")
        for name, table in styles.items()
    }


def get_handstyle(name: str, extra: dict[str, Handstyle] | None = None) -> Handstyle:
    """The style called ``name`` among ``extra`` (user styles, first) and the presets."""
    styles = {**PRESETS, **(extra or {})}
    if name not in styles:
        raise ScenarioError(f"unknown handstyle {name!r}; available: {', '.join(sorted(styles))}")
    return styles[name]
