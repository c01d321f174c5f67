"""Traces to analyse or restyle: a CSV of time-stamped samples, or the paths of an SVG file.

CSV files are read with :meth:`Drawing.from_csv` (``t,x,y[,z][,stroke]``). In an SVG file the
``d`` attribute of every ``<path>`` (commands M, L, H, V, C, S, Q, T, A, Z, absolute and
relative) and the ``points`` of every ``<polyline>`` and ``<polygon>`` are flattened, mapped
to the page frame in [mm] (y up, origin at the page's lower-left corner, ``transform``
attributes applied) and sampled uniformly in arc length, each sub-path a stroke traced at a
constant ``speed``; consecutive samples are at most ``speed / rate`` apart. Other shapes
(``<line>``, ``<rect>``, ``<circle>``, ``<use>``, text) and anything inside ``<defs>`` are not
drawn; an SVG with nothing drawable is refused.

Units: a root ``width``/``height`` with a unit (mm, cm, in, pt, pc, px) and a ``viewBox``
fix the scale; a bare number is CSS pixels (1/96 in); with no width/height, one user unit is
one millimetre (as :meth:`Drawing.to_svg` writes).
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError

DEFAULT_SPEED = 50.0
"""Pen speed along an SVG path in [mm/s]."""
DEFAULT_RATE = 200.0
"""Sampling rate of an SVG path in [Hz]."""

_MM_PER_UNIT = {
    "mm": 1.0,
    "cm": 10.0,
    "in": 25.4,
    "pt": 25.4 / 72,
    "pc": 25.4 / 6,
    "px": 25.4 / 96,
    "": 25.4 / 96,
}
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_SEPARATORS = re.compile(r"[\s,]*")
_ARGS = {"M": 2, "L": 2, "H": 1, "V": 1, "C": 6, "S": 4, "Q": 4, "T": 2, "A": 7, "Z": 0}
_CURVE_POINTS = 32
"""Points per curve piece when flattening, before the arc-length resampling."""


def load_trace(
    path: str | Path, speed: float = DEFAULT_SPEED, rate: float = DEFAULT_RATE
) -> Drawing:
    """Read a trace from ``.csv`` (time-stamped samples) or ``.svg`` (paths traced at ``speed``
    [mm/s], sampled at ``rate`` [Hz])."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return Drawing.from_csv(path)
    if suffix == ".svg":
        return read_svg(path, speed, rate)
    raise InputError(f"{path}: unknown trace format {suffix!r}; expected .csv or .svg")


def read_svg(path: str | Path, speed: float = DEFAULT_SPEED, rate: float = DEFAULT_RATE) -> Drawing:
    """The sub-paths of an SVG file as strokes sampled uniformly in arc length (module docstring)."""
    path = Path(path)
    for name, value in (("speed", speed), ("rate", rate)):
        if not (np.isfinite(value) and value > 0):
            raise InputError(f"{path}: SVG trace {name} must be positive, got {value}")
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as e:
        raise InputError(f"{path}: not well-formed XML ({e})") from None
    if _local(root.tag) != "svg":
        raise InputError(f"{path}: root element is <{_local(root.tag)}>, expected <svg>")
    page_w, page_h, to_page = _page_transform(root, path)
    polylines = []
    for elem, matrix in _walk(root, to_page, path):
        tag = _local(elem.tag)
        where = f"{path}: <{tag}>" + (f" id={elem.get('id')!r}" if elem.get("id") else "")
        if tag == "path":
            pieces = parse_path_data(elem.get("d", ""), where)
        else:
            pieces = [_parse_points(elem.get("points", ""), tag == "polygon", where)]
        polylines += [_apply(matrix, p) for p in pieces]
    spacing = speed / rate
    strokes = []
    for poly in polylines:
        pos = resample_arc_length(poly, spacing)
        if pos is not None:
            length = np.linalg.norm(np.diff(pos, axis=0), axis=1)
            t = np.concatenate([[0.0], np.cumsum(length)]) / speed
            strokes.append(Trajectory(t=t, pos=pos))
    if not strokes:
        raise InputError(
            f"{path}: no drawable <path>, <polyline> or <polygon> (of non-zero length) found"
        )
    return Drawing(strokes, page_size=(page_w, page_h))


def resample_arc_length(points: np.ndarray, spacing: float) -> np.ndarray | None:
    """Points equally spaced in arc length, at most ``spacing`` apart, both ends kept; None for
    a polyline of zero length."""
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(steps)])
    if s[-1] <= 0:
        return None
    keep = np.concatenate([[True], steps > 0])
    s, points = s[keep], points[keep]
    targets = np.linspace(0.0, s[-1], math.ceil(s[-1] / spacing) + 1)
    return np.column_stack([np.interp(targets, s, c) for c in points.T])


# -- document structure --------------------------------------------------------------------


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _length_mm(value: str | None, path: Path, name: str) -> float | None:
    if value is None:
        return None
    m = re.fullmatch(
        r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(mm|cm|in|pt|pc|px|)\s*", value
    )
    if not m or float(m.group(1)) <= 0:
        raise InputError(
            f"{path}: <svg {name}={value!r}>: expected a positive length in mm, cm, in, pt, pc or px"
        )
    return float(m.group(1)) * _MM_PER_UNIT[m.group(2)]


def _page_transform(root: ET.Element, path: Path) -> tuple[float, float, np.ndarray]:
    """Page size in [mm] and the affine map from root user units to the page frame."""
    width = _length_mm(root.get("width"), path, "width")
    height = _length_mm(root.get("height"), path, "height")
    box = root.get("viewBox")
    if box is not None:
        try:
            min_x, min_y, vb_w, vb_h = (float(v) for v in box.replace(",", " ").split())
        except ValueError:
            raise InputError(f"{path}: <svg viewBox={box!r}>: expected four numbers") from None
        if vb_w <= 0 or vb_h <= 0:
            raise InputError(f"{path}: <svg viewBox={box!r}>: width and height must be positive")
        sx = width / vb_w if width else (height / vb_h if height else 1.0)
        sy = height / vb_h if height else sx
    else:
        min_x = min_y = 0.0
        sx = sy = 1.0 if width is None and height is None else 25.4 / 96
        vb_w = (width or 210.0) / sx
        vb_h = (height or 297.0) / sy
    page_w, page_h = vb_w * sx, vb_h * sy
    # x_page = (x - min_x) sx; y_page = page_h - (y - min_y) sy: the page's y axis points up.
    to_page = np.array([[sx, 0.0, -min_x * sx], [0.0, -sy, page_h + min_y * sy], [0.0, 0.0, 1.0]])
    return page_w, page_h, to_page


def _walk(elem: ET.Element, matrix: np.ndarray, path: Path):
    """Yield (element, user-to-page matrix) for every path, polyline and polygon, skipping
    <defs>, <symbol>, <clipPath>, <mask> and <pattern> (not drawn)."""
    for child in elem:
        tag = _local(child.tag)
        if tag in ("defs", "symbol", "clipPath", "mask", "pattern"):
            continue
        m = matrix @ _parse_transform(child.get("transform"), f"{path}: <{tag}>")
        if tag in ("path", "polyline", "polygon"):
            yield child, m
        yield from _walk(child, m, path)


def _parse_transform(text: str | None, where: str) -> np.ndarray:
    """The 3x3 matrix of an SVG ``transform`` list (matrix, translate, scale, rotate, skewX/Y)."""
    m = np.eye(3)
    if not text:
        return m
    pos = 0
    for call in re.finditer(r"\s*,?\s*(\w+)\s*\(([^)]*)\)", text):
        if call.start() != pos:
            break
        pos = call.end()
        name, args = call.group(1), [float(v) for v in _NUMBER.findall(call.group(2))]
        m = m @ _transform_matrix(name, args, where, text)
    if text[pos:].strip():
        raise InputError(f"{where}: cannot parse transform={text!r} near {text[pos : pos + 20]!r}")
    return m


def _transform_matrix(name: str, a: list[float], where: str, text: str) -> np.ndarray:
    counts = {
        "matrix": (6,),
        "translate": (1, 2),
        "scale": (1, 2),
        "rotate": (1, 3),
        "skewX": (1,),
        "skewY": (1,),
    }
    if name not in counts or len(a) not in counts[name]:
        raise InputError(
            f"{where}: transform {name}({', '.join(map(str, a))}) not understood in {text!r}"
        )
    if name == "matrix":
        return np.array([[a[0], a[2], a[4]], [a[1], a[3], a[5]], [0, 0, 1]])
    if name == "translate":
        return np.array([[1, 0, a[0]], [0, 1, a[1] if len(a) > 1 else 0.0], [0, 0, 1]])
    if name == "scale":
        return np.diag([a[0], a[1] if len(a) > 1 else a[0], 1.0])
    if name == "rotate":
        c, s = math.cos(math.radians(a[0])), math.sin(math.radians(a[0]))
        r = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        if len(a) == 3:
            shift = np.array([[1, 0, a[1]], [0, 1, a[2]], [0, 0, 1]])
            r = shift @ r @ np.linalg.inv(shift)
        return r
    k = math.tan(math.radians(a[0]))
    return (
        np.array([[1, k, 0], [0, 1, 0], [0, 0, 1]])
        if name == "skewX"
        else np.array([[1, 0, 0], [k, 1, 0], [0, 0, 1]])
    )


def _apply(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ matrix[:2, :2].T + matrix[:2, 2]


def _parse_points(text: str, closed: bool, where: str) -> np.ndarray:
    values = _numbers_only(text, where, "points")
    if len(values) % 2 or len(values) < 4:
        raise InputError(
            f"{where}: points={text[:40]!r}: expected an even count of at least 4 numbers"
        )
    pts = np.array(values).reshape(-1, 2)
    return np.vstack([pts, pts[:1]]) if closed else pts


def _numbers_only(text: str, where: str, attribute: str) -> list[float]:
    values, pos = [], 0
    while True:
        pos = _SEPARATORS.match(text, pos).end()
        if pos == len(text):
            return values
        m = _NUMBER.match(text, pos)
        if not m:
            raise InputError(
                f"{where}: {attribute}: unexpected {text[pos : pos + 10]!r} at character {pos}"
            )
        values.append(float(m.group()))
        pos = m.end()


# -- path data -----------------------------------------------------------------------------


class _Scanner:
    """Reads commands, numbers and arc flags from SVG path data."""

    def __init__(self, text: str, where: str):
        self.text, self.pos, self.where = text, 0, where

    def skip(self) -> None:
        self.pos = _SEPARATORS.match(self.text, self.pos).end()

    def done(self) -> bool:
        self.skip()
        return self.pos >= len(self.text)

    def command_ahead(self) -> str | None:
        """The command letter at the read position, if any, without consuming it."""
        self.skip()
        c = self.text[self.pos : self.pos + 1]
        return c if c and c in "MmLlHhVvCcSsQqTtAaZz" else None

    def command(self) -> str | None:
        c = self.command_ahead()
        if c is not None:
            self.pos += 1
        return c

    def number_ahead(self) -> bool:
        self.skip()
        return _NUMBER.match(self.text, self.pos) is not None

    def number(self) -> float:
        self.skip()
        m = _NUMBER.match(self.text, self.pos)
        if not m:
            self.fail("a number")
        self.pos = m.end()
        return float(m.group())

    def flag(self) -> bool:
        self.skip()
        c = self.text[self.pos : self.pos + 1]
        if c not in ("0", "1"):
            self.fail("an arc flag 0 or 1")
        self.pos += 1
        return c == "1"

    def fail(self, expected: str):
        got = self.text[self.pos : self.pos + 10] or "end of data"
        raise InputError(
            f"{self.where}: d: expected {expected} at character {self.pos}, got {got!r}"
        )


def parse_path_data(d: str, where: str = "path") -> list[np.ndarray]:
    """Flatten SVG path data into polylines in user units, one (n, 2) array per sub-path.

    Curves (quadratic and cubic Beziers, elliptical arcs) are flattened into ``_CURVE_POINTS``
    points each; the arc-length resampling comes after. ``where`` names the element in errors.
    """
    scan = _Scanner(d, where)
    subpaths: list[list[np.ndarray]] = []
    current = start = np.zeros(2)
    prev_cmd, prev_ctrl = "", None
    cmd = scan.command()
    if cmd is None and not scan.done():
        scan.fail("a path command (M, L, C, ...)")
    if cmd is not None and cmd not in "Mm":
        raise InputError(f"{where}: d: path data must start with M or m, got {cmd!r}")
    while cmd is not None:
        upper, relative = cmd.upper(), cmd.islower()
        first = True
        while first or (upper != "Z" and not scan.done() and scan.command_ahead() is None):
            if not first and not scan.number_ahead():
                scan.fail("a number or a path command")
            args = [
                scan.flag() if upper == "A" and n in (3, 4) else scan.number()
                for n in range(_ARGS[upper])
            ]
            base = current if relative else np.zeros(2)
            if upper == "M":
                current = start = base + args
                subpaths.append([current[None]])
                # Further coordinate pairs after a moveto are implicit linetos.
                upper = "L"
                prev_ctrl = None
            elif upper == "Z":
                subpaths[-1].append(start[None])
                current = start
                prev_ctrl = None
            else:
                if not subpaths:
                    subpaths.append([current[None]])
                points, end, prev_ctrl = _segment(
                    upper, args, base, current, prev_cmd, prev_ctrl, where
                )
                subpaths[-1].append(points)
                current = end
            prev_cmd, first = upper, False
        cmd = scan.command()
        if cmd is None and not scan.done():
            scan.fail("a path command")
    return [np.vstack(parts) for parts in subpaths if sum(len(p) for p in parts) > 1]


def _segment(upper, args, base, current, prev_cmd, prev_ctrl, where):
    """Flattened points (excluding ``current``), end point and the control point to reflect."""
    s = np.linspace(0.0, 1.0, _CURVE_POINTS + 1)[1:, None]
    if upper == "L":
        end = base + args
        return end[None], end, None
    if upper == "H":
        end = np.array([args[0] + base[0], current[1]])
        return end[None], end, None
    if upper == "V":
        end = np.array([current[0], args[0] + base[1]])
        return end[None], end, None
    if upper in ("C", "S"):
        if upper == "C":
            c1, c2, end = base + args[0:2], base + args[2:4], base + args[4:6]
        else:
            c1 = 2 * current - prev_ctrl if prev_cmd in ("C", "S") else current
            c2, end = base + args[0:2], base + args[2:4]
        pts = (
            ((1 - s) ** 3) * current
            + 3 * ((1 - s) ** 2) * s * c1
            + 3 * (1 - s) * s * s * c2
            + s**3 * end
        )
        return pts, end, c2
    if upper in ("Q", "T"):
        if upper == "Q":
            c, end = base + args[0:2], base + args[2:4]
        else:
            c = 2 * current - prev_ctrl if prev_cmd in ("Q", "T") else current
            end = base + args[0:2]
        pts = ((1 - s) ** 2) * current + 2 * (1 - s) * s * c + s * s * end
        return pts, end, c
    end = base + args[5:7]
    return _arc(current, args[0], args[1], args[2], args[3], args[4], end), end, None


def _arc(p0, rx, ry, phi_deg, large, sweep, p1) -> np.ndarray:
    """Points of an SVG elliptical arc from p0 to p1 (SVG 1.1 implementation notes F.6.5-6)."""
    rx, ry = abs(rx), abs(ry)
    if rx == 0 or ry == 0 or np.allclose(p0, p1):
        return p1[None]
    phi = math.radians(phi_deg)
    cos_p, sin_p = math.cos(phi), math.sin(phi)
    rot = np.array([[cos_p, -sin_p], [sin_p, cos_p]])
    x1, y1 = rot.T @ ((p0 - p1) / 2)
    scale = (x1 / rx) ** 2 + (y1 / ry) ** 2
    if scale > 1:  # radii too small to reach p1: scale them up (F.6.6)
        rx, ry = rx * math.sqrt(scale), ry * math.sqrt(scale)
    num = max(rx * rx * ry * ry - rx * rx * y1 * y1 - ry * ry * x1 * x1, 0.0)
    coef = math.sqrt(num / (rx * rx * y1 * y1 + ry * ry * x1 * x1))
    if large == sweep:
        coef = -coef
    cx1, cy1 = coef * rx * y1 / ry, -coef * ry * x1 / rx
    centre = rot @ np.array([cx1, cy1]) + (p0 + p1) / 2
    theta0 = math.atan2((y1 - cy1) / ry, (x1 - cx1) / rx)
    theta1 = math.atan2((-y1 - cy1) / ry, (-x1 - cx1) / rx)
    dtheta = theta1 - theta0
    if sweep and dtheta < 0:
        dtheta += 2 * math.pi
    elif not sweep and dtheta > 0:
        dtheta -= 2 * math.pi
    theta = theta0 + dtheta * np.linspace(0.0, 1.0, _CURVE_POINTS + 1)[1:]
    ellipse = np.column_stack([rx * np.cos(theta), ry * np.sin(theta)])
    pts = ellipse @ rot.T + centre
    pts[-1] = p1
    return pts
