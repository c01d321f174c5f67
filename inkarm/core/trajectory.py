"""Time-stamped pen paths: :class:`Trajectory` (one stroke) and :class:`Drawing` (a page of them).

Units: time in [s], positions in [mm] in the page frame (x to the right, y up, origin at the
page's lower-left corner; D = 2, or 3 with z the height above the paper).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from inkarm.core.csvrows import CSV_MAX_LINE, CSV_ROW_BYTES, read_rows  # noqa: F401 (re-exported)
from inkarm.core.equality import same
from inkarm.core.npz import read_npz
from inkarm.errors import InputError

A4_MM = (210.0, 297.0)


MAX_COORD_MM = 1e6
"""Largest |coordinate| in [mm] read from a trace file (CSV or SVG): a kilometre. Anything
bigger is a unit or data error, and would overflow lengths, speeds and squared errors."""
MAX_TIME_S = 1e10
"""Largest |t| in [s] read from a CSV trace (about 300 years: Unix times in seconds pass)."""


def _as_array(name: str, value, ndim: int) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim != ndim:
        raise InputError(f"{name}: expected a {ndim}-D array, got shape {arr.shape}")
    if not np.isfinite(arr).all():
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise InputError(f"{name}: non-finite value (NaN or inf) at index {tuple(int(i) for i in bad)}")
    return arr


def _check_increasing(t: np.ndarray) -> None:
    """Raise :class:`InputError` unless ``t`` is strictly increasing (NaN fails)."""
    if t.shape[0] > 1 and not (t[1:] > t[:-1]).all():
        i = int(np.argmax(~(t[1:] > t[:-1])))
        raise InputError(
            f"trajectory t: must be strictly increasing, but t[{i + 1}] = {t[i + 1]} "
            f"<= t[{i}] = {t[i]}"
        )


def time_derivative(values: np.ndarray, t: np.ndarray) -> np.ndarray:
    """d values / dt along axis 0 by finite differences, the same shape as ``values``: the one
    derivative estimate of inkarm (:meth:`Trajectory.velocity`, and the speed, acceleration
    and jerk of :mod:`inkarm.analysis.kinematics`); zeros for a single sample.

    Central differences inside (second order, also on a non-uniform grid), and second-order
    one-sided differences at the two ends when there are 3 samples or more (first order with
    2). Second order at the ends because a pen stroke starts and ends accelerating: a
    first-order difference there is off by a h / 2 (a the acceleration, h the step), e.g. a
    stroke starting from rest at constant acceleration gets a start speed of a h / 2 instead
    of 0, while the second-order difference is exact for any quadratic x(t), as the central
    differences are inside. The price is a little more noise at the ends (weights -3/2, 2,
    -1/2 instead of -1, 1), negligible next to that bias for smooth model output.
    """
    n = t.shape[0]
    if n < 2:
        return np.zeros_like(values, dtype=float)
    return np.gradient(values, t, axis=0, edge_order=2 if n >= 3 else 1)


@dataclass(frozen=True, eq=False)
class Trajectory:
    """One pen-down stroke sampled in time.

    A value: ``==`` compares every field, arrays exactly element by element (a missing ``vel``
    or ``pressure`` equals only a missing one). Not hashable: the arrays are not copied and
    stay writable, so a hash could change under a dict's feet.

    Attributes:
        t: Sample times in [s], shape (N,), strictly increasing.
        pos: Pen positions in [mm], shape (N, D) with D in {2, 3}.
        vel: Optional velocities in [mm/s], shape (N, D); estimated by finite differences when
            absent (see :meth:`velocity`).
        pressure: Optional per-sample pressure or width in [0, 1], shape (N,).
    """

    t: np.ndarray
    pos: np.ndarray
    vel: np.ndarray | None = None
    pressure: np.ndarray | None = None

    def __post_init__(self) -> None:
        t = _as_array("trajectory t", self.t, 1)
        pos = _as_array("trajectory pos", self.pos, 2)
        if pos.shape[0] != t.shape[0]:
            raise InputError(
                f"trajectory: t has {t.shape[0]} samples but pos has {pos.shape[0]} rows"
            )
        if pos.shape[1] not in (1, 2, 3):
            raise InputError(f"trajectory pos: expected 1 to 3 columns, got {pos.shape[1]}")
        if t.shape[0] == 0:
            raise InputError("trajectory: no samples")
        _check_increasing(t)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "pos", pos)
        if self.vel is not None:
            vel = _as_array("trajectory vel", self.vel, 2)
            if vel.shape != pos.shape:
                raise InputError(f"trajectory vel: shape {vel.shape} differs from pos {pos.shape}")
            object.__setattr__(self, "vel", vel)
        if self.pressure is not None:
            pressure = _as_array("trajectory pressure", self.pressure, 1)
            if pressure.shape != t.shape:
                raise InputError(
                    f"trajectory pressure: shape {pressure.shape} differs from t {t.shape}"
                )
            object.__setattr__(self, "pressure", pressure)

    def __eq__(self, other) -> bool:
        if other.__class__ is not self.__class__:
            return NotImplemented
        return all(
            same(getattr(self, name), getattr(other, name))
            for name in ("t", "pos", "vel", "pressure")
        )

    __hash__ = None  # type: ignore[assignment]

    @classmethod
    def from_checked(cls, t: np.ndarray, pos: np.ndarray, vel: np.ndarray | None = None) -> Trajectory:
        """A trajectory from float arrays its producer has already checked (finite, matching
        shapes), skipping the validation that a movement model's hot path would otherwise pay
        on every call. The order of ``t`` is still checked (one vectorised comparison): a
        decreasing or repeated time raises :class:`InputError`, as in the constructor."""
        _check_increasing(t)
        traj = object.__new__(cls)
        for name, value in (("t", t), ("pos", pos), ("vel", vel), ("pressure", None)):
            object.__setattr__(traj, name, value)
        return traj

    @property
    def n(self) -> int:
        """Number of samples N."""
        return self.t.shape[0]

    @property
    def dim(self) -> int:
        """Spatial dimension D."""
        return self.pos.shape[1]

    @property
    def duration(self) -> float:
        """t[-1] - t[0] in [s]."""
        return float(self.t[-1] - self.t[0])

    @property
    def length(self) -> float:
        """Arc length of the polyline in [mm]."""
        return float(np.sum(np.linalg.norm(np.diff(self.pos, axis=0), axis=1)))

    def velocity(self) -> np.ndarray:
        """Velocity in [mm/s], (N, D): the stored one, else :func:`time_derivative` of the
        positions (second-order finite differences, ends included)."""
        if self.vel is not None:
            return self.vel
        return time_derivative(self.pos, self.t)

    def speed(self) -> np.ndarray:
        """Tangential speed |v| in [mm/s], (N,), of :meth:`velocity` (the definition that
        :func:`inkarm.analysis.kinematics.speed` uses too)."""
        return np.linalg.norm(self.velocity(), axis=1)

    def shifted(self, dt: float = 0.0, dpos=None) -> Trajectory:
        """The same stroke delayed by ``dt`` [s] and translated by ``dpos`` [mm]."""
        pos = self.pos if dpos is None else self.pos + np.asarray(dpos, dtype=float)
        return replace(self, t=self.t + dt, pos=pos)

    def resample(self, dt: float) -> Trajectory:
        """Linear interpolation onto a uniform grid of step ``dt`` [s] from t[0] to t[-1].

        The last sample is kept exactly, so the grid's final step may be shorter than dt.
        """
        if not np.isfinite(dt) or dt <= 0:
            raise InputError(f"resample: dt must be a positive number of seconds, got {dt}")
        t = np.arange(self.t[0], self.t[-1], dt)
        if t.size == 0 or t[-1] < self.t[-1]:
            t = np.append(t, self.t[-1])
        if t.size > 1 and t[-1] - t[-2] < 1e-9 * max(dt, 1.0):
            t = np.delete(t, -2)
        pos = np.column_stack([np.interp(t, self.t, c) for c in self.pos.T])
        vel = None
        if self.vel is not None:
            vel = np.column_stack([np.interp(t, self.t, c) for c in self.vel.T])
        pressure = None if self.pressure is None else np.interp(t, self.t, self.pressure)
        return Trajectory(t=t, pos=pos, vel=vel, pressure=pressure)

    def to_csv(self, path: str | Path) -> None:
        """Write ``t,x,y[,z]`` with a header row."""
        Drawing([self]).to_csv(path, stroke_column=False)

    @staticmethod
    def from_csv(path: str | Path) -> Trajectory:
        """Read a CSV with header ``t,x,y`` or ``t,x,y,z`` (a ``stroke`` column is refused here:
        use :meth:`Drawing.from_csv`)."""
        drawing = Drawing.from_csv(path)
        if len(drawing.strokes) != 1:
            raise InputError(
                f"{path}: holds {len(drawing.strokes)} strokes; read it with Drawing.from_csv"
            )
        return drawing.strokes[0]


@dataclass(frozen=True, eq=False)
class Drawing:
    """An ordered list of pen-down strokes on a page; the pen is up between strokes.

    A value: ``==`` compares the strokes (as :class:`Trajectory` does), the page size and the
    meta (arrays in it element by element). Not hashable (see :class:`Trajectory`). A drawing
    read back from its CSV equals the original when it had no velocities, pressures or meta,
    and the page size given to :meth:`from_csv` (which the file does not hold) is its own.

    Attributes:
        strokes: The strokes, in drawing order, as a tuple (any sequence given is stored as
            one, so a frozen drawing cannot gain or lose strokes). Stroke times are absolute
            and non-overlapping when the drawing came from a timed plan; they may also each
            start at 0.
        page_size: (width, height) of the page in [mm].
    """

    strokes: tuple[Trajectory, ...]
    page_size: tuple[float, float] = A4_MM
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        strokes = tuple(self.strokes)
        for i, s in enumerate(strokes):
            if not isinstance(s, Trajectory):
                raise InputError(f"drawing stroke {i}: expected a Trajectory, got {type(s).__name__}")
        dims = {s.dim for s in strokes}
        if len(dims) > 1:
            raise InputError(f"drawing: strokes mix dimensions {sorted(dims)}")
        w, h = (float(v) for v in self.page_size)
        if not (w > 0 and h > 0 and np.isfinite(w) and np.isfinite(h)):
            raise InputError(f"drawing page_size: expected positive (width, height) in mm, got {self.page_size}")
        object.__setattr__(self, "strokes", strokes)
        object.__setattr__(self, "page_size", (w, h))

    def __eq__(self, other) -> bool:
        if other.__class__ is not self.__class__:
            return NotImplemented
        return (
            self.page_size == other.page_size
            and self.strokes == other.strokes
            and same(self.meta, other.meta)
        )

    __hash__ = None  # type: ignore[assignment]

    @property
    def dim(self) -> int:
        return self.strokes[0].dim if self.strokes else 2

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(min, max) corners of all strokes in [mm]."""
        if not self.strokes:
            raise InputError("drawing: no strokes")
        allpos = np.vstack([s.pos for s in self.strokes])
        return allpos.min(axis=0), allpos.max(axis=0)

    def transformed(self, scale: float = 1.0, offset=(0.0, 0.0)) -> Drawing:
        """Scale about the origin then translate by ``offset`` [mm] (x, y only)."""
        off = np.zeros(self.dim)
        off[: len(offset)] = offset
        k = np.ones(self.dim)
        k[:2] = scale
        strokes = [
            replace(s, pos=s.pos * k + off, vel=None if s.vel is None else s.vel * k)
            for s in self.strokes
        ]
        return replace(self, strokes=strokes)

    def sequential(self, pause: float = 0.0) -> Drawing:
        """Strokes re-timed to follow each other, separated by ``pause`` [s]."""
        strokes, t0 = [], 0.0
        for s in self.strokes:
            strokes.append(s.shifted(dt=t0 - s.t[0]))
            t0 = strokes[-1].t[-1] + pause
        return replace(self, strokes=strokes)

    # -- files -----------------------------------------------------------------------------

    def to_csv(self, path: str | Path, stroke_column: bool = True) -> None:
        """Write ``t,x,y[,z][,stroke]`` rows, strokes in order, as the csv module writes them
        (CRLF ends): each value is ``repr`` of its float, the shortest text that reads back to
        the same double; one block of text per stroke."""
        names = ["t", "x", "y", "z"][: 1 + self.dim]
        with open(path, "w", newline="") as f:
            f.write(",".join(names + (["stroke"] if stroke_column else [])) + "\r\n")
            for k, s in enumerate(self.strokes):
                end = f",{k}\r\n" if stroke_column else "\r\n"
                columns = (map(repr, c.tolist()) for c in (s.t, *s.pos.T))
                f.write(end.join(map(",".join, zip(*columns))) + end)

    @staticmethod
    def from_csv(path: str | Path, page_size: tuple[float, float] = A4_MM) -> Drawing:
        """Read ``t,x,y[,z]`` with an optional ``stroke`` column (integer stroke index).

        Bounded before and while parsing: a file too big for ``INKARM_MAX_STEPS`` rows (at
        :data:`CSV_ROW_BYTES` bytes a row) is refused from its size, rows are counted as they
        are read, lines are at most :data:`CSV_MAX_LINE` characters; coordinates beyond
        :data:`MAX_COORD_MM` and times beyond :data:`MAX_TIME_S` are refused naming the line.
        """
        from inkarm.core.budget import STEPS, require

        path = Path(path)
        if not path.is_file():
            raise InputError(f"{path}: no such file")
        size = path.stat().st_size
        require(size / CSV_ROW_BYTES, STEPS,
                f"{path}: rows of a {size / 1e6:.3g} MB CSV file (at {CSV_ROW_BYTES} bytes a row)",
                value=size)
        header, arr, linenos = read_rows(path, size)
        cols = [h for h in header if h != "stroke"]
        pos_idx = [header.index(c) for c in cols[1:]]
        t_idx = header.index("t")
        for idx, bound, unit in [(t_idx, MAX_TIME_S, "s")] + [(i, MAX_COORD_MM, "mm") for i in pos_idx]:
            outside = np.abs(arr[:, idx]) > bound
            if outside.any():
                row = int(np.argmax(outside))
                raise InputError(
                    f"{path}:{linenos[row]}: {header[idx]} = {arr[row, idx]:g} {unit} is outside "
                    f"|{header[idx]}| <= {bound:g} {unit}", value=float(arr[row, idx]))
        if "stroke" in header:
            sid = arr[:, header.index("stroke")]
            if np.any(sid != np.round(sid)):
                lineno = linenos[int(np.argmax(sid != np.round(sid)))]
                raise InputError(f"{path}:{lineno}: stroke must be a whole number")
            breaks = np.flatnonzero(np.diff(sid) != 0) + 1
            groups = np.split(np.arange(len(arr)), breaks)
        else:
            groups = [np.arange(len(arr))]
        strokes = []
        for g in groups:
            try:
                strokes.append(Trajectory(t=arr[g, t_idx], pos=arr[g][:, pos_idx]))
            except InputError as e:
                raise InputError(f"{path}: {e}") from None
        return Drawing(strokes, page_size=page_size)

    def to_npz(self, path: str | Path) -> None:
        """Write arrays ``t``, ``pos``, ``stroke`` (stroke index per sample) and ``page_size``."""
        t = np.concatenate([s.t for s in self.strokes]) if self.strokes else np.zeros(0)
        pos = np.vstack([s.pos for s in self.strokes]) if self.strokes else np.zeros((0, 2))
        sid = np.concatenate([np.full(s.n, k) for k, s in enumerate(self.strokes)]) if self.strokes else np.zeros(0, int)
        np.savez(path, t=t, pos=pos, stroke=sid, page_size=np.array(self.page_size))

    @staticmethod
    def from_npz(path: str | Path) -> Drawing:
        z = read_npz(path, "a drawing")
        missing = {"t", "pos", "stroke"} - set(z)
        if missing:
            raise InputError(f"{path}: missing arrays {sorted(missing)}")
        t, pos, sid = z["t"], z["pos"], z["stroke"]
        page = tuple(z["page_size"]) if "page_size" in z else A4_MM
        strokes = [Trajectory(t=t[sid == k], pos=pos[sid == k]) for k in np.unique(sid)]
        return Drawing(strokes, page_size=page)

    def to_svg(self, path: str | Path, stroke_width: float = 0.5) -> None:
        """Write the strokes as SVG polylines in a viewBox of the page in [mm] (y flipped so the
        page's y axis points up, as in inkarm's page frame).

        A drawing with ``meta["layers"]`` (one vpype layer id per stroke) is written as vpype
        writes layers: one Inkscape layer per id, ascending, ``<g inkscape:groupmode="layer"
        inkscape:label="N" id="layerN">``, each holding its strokes in drawing order (so
        reading the file back keeps the layers; strokes of different layers come out grouped
        by layer). Without it, one group holds every stroke.
        """
        w, h = self.page_size
        style = (f'fill="none" stroke="black" stroke-width="{stroke_width}" '
                 'stroke-linecap="round" stroke-linejoin="round"')
        layers = self._svg_layers()  # (refused before the file is opened)
        with open(path, "w") as f:  # a line at a time: a page of text is tens of MB
            f.write('<?xml version="1.0" encoding="UTF-8"?>\n'
                    '<svg xmlns="http://www.w3.org/2000/svg" '
                    'xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape" '
                    f'width="{w}mm" height="{h}mm" viewBox="0 0 {w} {h}">\n')
            for layer, indices in layers:
                if layer is None:
                    f.write(f"<g {style}>\n")
                else:
                    f.write(f'<g inkscape:groupmode="layer" inkscape:label="{layer}" '
                            f'id="layer{layer}" {style}>\n')
                for k in indices:
                    x, y = self.strokes[k].pos[:, :2].T
                    pts = " ".join(map("{:.3f},{:.3f}".format, x.tolist(), (h - y).tolist()))
                    f.write(f'<polyline points="{pts}"/>\n')
                f.write("</g>\n")
            f.write("</svg>\n")

    def layer_ids(self) -> np.ndarray:
        """One vpype layer id per stroke: ``meta["layers"]`` as int64, checked (an integer >= 1
        per stroke), or all 1 when absent."""
        if "layers" not in self.meta:
            return np.ones(len(self.strokes), dtype=np.int64)
        raw = self.meta["layers"]
        try:
            layers = np.asarray(raw)
            ok = (layers.ndim == 1 and layers.dtype.kind in "iu"
                  and len(layers) == len(self.strokes) and bool(np.all(layers >= 1)))
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise InputError(f"drawing meta layers: expected one integer layer id >= 1 per "
                             f"stroke ({len(self.strokes)}), got {raw!r}", key="layers")
        return layers.astype(np.int64)

    def _svg_layers(self) -> list[tuple[int | None, list[int]]]:
        """(layer id, stroke indices) per SVG group :meth:`to_svg` writes: one per id of
        ``meta["layers"]`` (:meth:`layer_ids`) ascending, or (None, all) without layers."""
        if self.meta.get("layers") is None:
            return [(None, list(range(len(self.strokes))))]
        try:
            ids = self.layer_ids()
        except InputError:
            got = np.asarray(self.meta["layers"])
            raise InputError(f"drawing meta['layers']: expected one integer layer id per stroke "
                             f"({len(self.strokes)}), got {got.dtype} of shape {got.shape}; "
                             "ids must be >= 1", key="layers") from None
        return [(int(lid), np.flatnonzero(ids == lid).tolist()) for lid in np.unique(ids)]
