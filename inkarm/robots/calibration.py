"""What calibration found out about a cell: the real sheet's height map and the arm's geometry.

A :class:`CellCalibration` is the controller's corrected belief about one robot's cell, kept in
the user's configuration folder (never inside the installed package)::

    <calibration_dir()>/calibration/<robot>.toml

    robot = "iiwa14"
    notes = ["paper: 96 touches, heights -0.42..0.97 mm, RMS residual 0.021 mm"]

    [geometry]                       # robots/geometry.py: GeometryErrors
    link_length_mm = [0.0, 0.31, -0.2, ...]
    joint_offset_deg = [0.05, ...]
    tip_offset_mm = [0.0, 0.0, 2.0]

    [paper]                          # HeightMap, page frame [mm]
    x_mm = [20.0, 30.0, 40.0]
    y_mm = [50.0, 60.0]
    z_mm = [[0.1, 0.2, 0.1],         # one row per y, one column per x
            [0.0, 0.3, 0.2]]

``calibration_dir()`` is ``$INKARM_CONFIG_DIR``, else ``$XDG_CONFIG_HOME/inkarm``, else
``~/.config/inkarm``. The Dynamixel joint zeros live beside it in ``<robot>.joints.toml``
(:mod:`inkarm.hardware.dynamixel.calibration`).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from inkarm.errors import InputError, ScenarioError
from inkarm.io.toml import TomlReader, load_toml
from inkarm.robots.geometry import GeometryErrors

CONFIG_ENV = "INKARM_CONFIG_DIR"
GEOMETRY_KEYS = ("link_length_mm", "joint_offset_deg", "tip_offset_mm")
PAPER_KEYS = ("x_mm", "y_mm", "z_mm")
TOP_KEYS = ("robot", "notes", "geometry", "paper")


@dataclass(frozen=True, eq=False)
class HeightMap:
    """Height of the real sheet above the model's sheet on a grid in the page frame.

    Attributes:
        x_mm: Grid abscissae [mm], (nx,), strictly increasing, nx >= 1.
        y_mm: Grid ordinates [mm], (ny,), strictly increasing, ny >= 1.
        z_mm: Heights [mm], (ny, nx): ``z_mm[j, i]`` at ``(x_mm[i], y_mm[j])``, along the
            model sheet's normal (up +); pen-length errors along the normal are included.

    :meth:`height` interpolates bilinearly and holds the edge values outside the grid.
    """

    x_mm: np.ndarray
    y_mm: np.ndarray
    z_mm: np.ndarray

    def __post_init__(self):
        x = np.array(self.x_mm, dtype=float).reshape(-1)
        y = np.array(self.y_mm, dtype=float).reshape(-1)
        z = np.array(self.z_mm, dtype=float)
        for name, a in (("x_mm", x), ("y_mm", y)):
            if a.size == 0:
                raise InputError("expected at least one grid line", key=name, value=a.tolist())
            if not np.all(np.isfinite(a)) or np.any(np.diff(a) <= 0):
                raise InputError("expected finite, strictly increasing grid lines [mm]",
                                 key=name, value=a.tolist())
        if z.shape != (y.size, x.size):
            raise InputError(f"expected shape (len(y_mm), len(x_mm)) = ({y.size}, {x.size}), "
                             f"got {z.shape}", key="z_mm")
        if not np.all(np.isfinite(z)):
            raise InputError("expected finite heights [mm]", key="z_mm")
        for name, a in (("x_mm", x), ("y_mm", y), ("z_mm", z)):
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @property
    def shape(self) -> tuple[int, int]:
        """(ny, nx)."""
        return self.z_mm.shape

    @property
    def range_mm(self) -> tuple[float, float]:
        """Lowest and highest grid height [mm]."""
        return float(self.z_mm.min()), float(self.z_mm.max())

    def height(self, x_mm, y_mm):
        """Bilinear height [mm] at page points (scalars or broadcastable arrays)::

            z = (1-s)(1-t) z[j,i] + s(1-t) z[j,i+1] + (1-s) t z[j+1,i] + s t z[j+1,i+1]

        with ``s = (x - x_i)/(x_{i+1} - x_i)``, ``t`` likewise in y, after clamping x, y to
        the grid. Returns a float for scalar input, else an array."""
        _, _, i, s, i1, j, t, j1 = self._corners(x_mm, y_mm)
        z = self.z_mm
        out = ((1 - s) * (1 - t) * z[j, i] + s * (1 - t) * z[j, i1]
               + (1 - s) * t * z[j1, i] + s * t * z[j1, i1])
        return float(out) if out.ndim == 0 else out

    def _corners(self, x_mm, y_mm) -> tuple:
        """The points as arrays x, y and their cells: i, s, i + 1 (held at the last grid line)
        across x; j, t, j + 1 across y (:func:`_cell`)."""
        x, y = np.broadcast_arrays(np.asarray(x_mm, float), np.asarray(y_mm, float))
        i, s = _cell(self.x_mm, x)
        j, t = _cell(self.y_mm, y)
        ny, nx = self.z_mm.shape
        return x, y, i, s, np.minimum(i + 1, nx - 1), j, t, np.minimum(j + 1, ny - 1)

    def slope(self, x_mm, y_mm) -> tuple:
        """(dz/dx, dz/dy) [mm/mm] of the bilinear surface at page points; 0 outside the grid
        along a clamped axis (the height is held there)."""
        x, y, i, s, i1, j, t, j1 = self._corners(x_mm, y_mm)
        z = self.z_mm
        dx = _spacing(self.x_mm, i)
        dy = _spacing(self.y_mm, j)
        inside_x = (x >= self.x_mm[0]) & (x <= self.x_mm[-1]) & (self.x_mm.size > 1)
        inside_y = (y >= self.y_mm[0]) & (y <= self.y_mm[-1]) & (self.y_mm.size > 1)
        gx = ((1 - t) * (z[j, i1] - z[j, i]) + t * (z[j1, i1] - z[j1, i])) / dx * inside_x
        gy = ((1 - s) * (z[j1, i] - z[j, i]) + s * (z[j1, i1] - z[j, i1])) / dy * inside_y
        if gx.ndim == 0:
            return float(gx), float(gy)
        return gx, gy


def _cell(grid: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index of the grid cell holding each clamped value and the fraction across it."""
    if grid.size == 1:
        return np.zeros(v.shape, dtype=int), np.zeros(v.shape)
    vc = np.clip(v, grid[0], grid[-1])
    i = np.clip(np.searchsorted(grid, vc, side="right") - 1, 0, grid.size - 2)
    return i, (vc - grid[i]) / (grid[i + 1] - grid[i])


def _spacing(grid: np.ndarray, i: np.ndarray) -> np.ndarray:
    if grid.size == 1:
        return np.ones(i.shape)
    return grid[i + 1] - grid[i]


@dataclass(frozen=True, eq=False)
class CellCalibration:
    """A robot cell's calibration: what the controller should believe instead of the nominal.

    Attributes:
        robot: The robot profile's name it was measured on.
        paper: The real sheet's height map, or None (believe the flat sheet).
        geometry: Link, joint and pen-tip errors (robots/geometry.py); zero = as built.
        notes: Free text lines: how and when each part was measured.
    """

    robot: str
    paper: HeightMap | None = None
    geometry: GeometryErrors = field(default_factory=GeometryErrors)
    notes: tuple[str, ...] = ()

    @property
    def is_empty(self) -> bool:
        """True when it corrects nothing (no map, zero geometry)."""
        return self.paper is None and self.geometry.is_zero

    def describe(self) -> str:
        """One line: what it corrects (for run notes and command output)."""
        parts = []
        if self.paper is not None:
            lo, hi = self.paper.range_mm
            ny, nx = self.paper.shape
            parts.append(f"paper map {nx}x{ny} ({lo:+.2f}..{hi:+.2f} mm)")
        g = self.geometry
        if any(g.link_length_mm) or any(g.joint_offset_deg):
            parts.append("links/joints")
        if any(g.tip_offset_mm):
            tip = ", ".join(f"{v:+.2f}" for v in g.tip_offset_mm)
            parts.append(f"pen tip ({tip}) mm")
        return ", ".join(parts) if parts else "nothing (empty)"


def calibration_dir() -> Path:
    """The user's inkarm configuration folder: ``$INKARM_CONFIG_DIR``, else
    ``$XDG_CONFIG_HOME/inkarm``, else ``~/.config/inkarm``."""
    explicit = os.environ.get(CONFIG_ENV)
    if explicit:
        return Path(explicit).expanduser()
    xdg = os.environ.get("XDG_CONFIG_HOME")
    if xdg:
        return Path(xdg).expanduser() / "inkarm"
    return Path.home() / ".config" / "inkarm"


def calibration_path(robot_name: str) -> Path:
    """``calibration_dir()/calibration/<robot_name>.toml``."""
    name = str(robot_name)
    if not name or any(c in name for c in "/\\") or name in (".", ".."):
        raise InputError(f"a robot name makes a file name; got {name!r}", key="robot",
                         value=name)
    return calibration_dir() / "calibration" / f"{name}.toml"


def read_calibration(path: str | Path) -> CellCalibration:
    """Read a calibration file (module docstring); ScenarioError names the file, key and
    value at fault."""
    data = load_toml(path, "calibration file")
    rd = TomlReader(str(path))
    rd.keys(data, TOP_KEYS, "")
    if "robot" not in data:
        raise rd.error("robot", "missing: the robot profile's name this calibration is for")
    robot = rd.text(data["robot"], "robot")
    notes = data.get("notes", [])
    if not isinstance(notes, list):
        raise rd.error("notes", "expected an array of strings", value=notes)
    notes = tuple(rd.text(n, f"notes[{i}]") for i, n in enumerate(notes))
    geometry = _read_geometry(rd, data.get("geometry", {}))
    paper = _read_paper(rd, data["paper"]) if "paper" in data else None
    return CellCalibration(robot=robot, paper=paper, geometry=geometry, notes=notes)


def _read_geometry(rd: TomlReader, table) -> GeometryErrors:
    g = rd.table(table, "geometry")
    rd.keys(g, GEOMETRY_KEYS, "geometry")
    links = _vector(rd, g.get("link_length_mm", []), "geometry.link_length_mm")
    if links and links[0] != 0.0:
        raise rd.error("geometry.link_length_mm[0]", "expected 0 (joint 0 has no link before "
                       "it)", value=links[0])
    offsets = _vector(rd, g.get("joint_offset_deg", []), "geometry.joint_offset_deg")
    tip = _vector(rd, g.get("tip_offset_mm", [0.0, 0.0, 0.0]), "geometry.tip_offset_mm")
    if len(tip) != 3:
        raise rd.error("geometry.tip_offset_mm", f"expected 3 numbers (x, y, z in the flange "
                       f"frame) [mm], got {len(tip)}", value=list(tip))
    for key, values, bound in (("link_length_mm", links, LIMITS["mm"]),
                               ("tip_offset_mm", tip, LIMITS["mm"]),
                               ("joint_offset_deg", offsets, LIMITS["deg"])):
        _within(rd, f"geometry.{key}", values, bound)
    try:
        return GeometryErrors(link_length_mm=links, joint_offset_deg=offsets,
                              tip_offset_mm=(tip[0], tip[1], tip[2]))
    except InputError as e:  # (checked above; whatever GeometryErrors adds names the file too)
        raise ScenarioError(e.message, file=rd.source, key=f"geometry.{e.key}",
                            value=e.value) from None


# What a calibration may correct: as large as the plant truths it is measured against
# (sim/imperfections.py RANGES); beyond, the file is not a calibration of this kind of cell.
LIMITS = {"mm": 50.0, "deg": 10.0}


def _within(rd: TomlReader, key: str, values, bound: float) -> None:
    worst = max((abs(float(v)) for v in values), default=0.0)
    if not worst <= bound:
        raise rd.error(key, f"expected corrections within +-{bound:g} "
                       f"{'deg' if key.endswith('deg') else 'mm'}, got {worst:g}", value=worst)


def _vector(rd: TomlReader, value, key: str) -> tuple[float, ...]:
    return tuple(float(v) for v in rd.array(value, key, 1))


def _read_paper(rd: TomlReader, table) -> HeightMap:
    p = rd.table(table, "paper")
    rd.keys(p, PAPER_KEYS, "paper")
    for name in PAPER_KEYS:
        if name not in p:
            raise rd.error(f"paper.{name}", "missing: a height map needs x_mm, y_mm and z_mm")
    x = rd.array(p["x_mm"], "paper.x_mm", 1)
    y = rd.array(p["y_mm"], "paper.y_mm", 1)
    z = rd.array(p["z_mm"], "paper.z_mm", 2)
    _within(rd, "paper.z_mm", np.ravel(z), LIMITS["mm"])
    try:
        return HeightMap(x, y, z)
    except InputError as e:
        raise ScenarioError(e.message, file=rd.source, key=f"paper.{e.key}",
                            value=e.value) from None


def write_calibration(cal: CellCalibration, path: str | Path) -> Path:
    """Write ``cal`` as TOML (read back exactly by :func:`read_calibration`), creating the
    folder; atomic (a partial file is renamed into place)."""
    path = Path(path)
    lines = [f"# inkarm cell calibration of robot {cal.robot!r}",
             f"robot = {_string(cal.robot)}",
             "notes = [" + ", ".join(_string(n) for n in cal.notes) + "]", ""]
    g = cal.geometry
    lines += ["[geometry]", f"link_length_mm = {_floats(g.link_length_mm)}",
              f"joint_offset_deg = {_floats(g.joint_offset_deg)}",
              f"tip_offset_mm = {_floats(g.tip_offset_mm)}", ""]
    if cal.paper is not None:
        m = cal.paper
        rows = ",\n  ".join(_floats(r) for r in m.z_mm)
        lines += ["[paper]  # height of the real sheet above the believed one [mm], page frame",
                  f"x_mm = {_floats(m.x_mm)}", f"y_mm = {_floats(m.y_mm)}",
                  f"z_mm = [  # one row per y_mm\n  {rows},\n]", ""]
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.partial")
    tmp.write_text("\n".join(lines), encoding="utf-8")
    tmp.replace(path)
    return path


def _floats(values: Sequence[float]) -> str:
    out = []
    for v in values:
        v = float(v)
        if not math.isfinite(v):
            raise InputError("a calibration holds finite numbers only", value=v)
        out.append(repr(v))
    return "[" + ", ".join(out) + "]"


def _string(text: str) -> str:
    """A TOML basic string (JSON escaping is valid TOML for these characters)."""
    return json.dumps(str(text), ensure_ascii=False)
