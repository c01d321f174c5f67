"""The two-step calibration of a real arm: a *drawn file* (``.npz``) that keeps what a fit needs
between drawing a calibration pattern and reading it from a scan of the sheet
(``inkarm calibrate pen|kinematics|paper --drawn FILE.npz``, then ``--read FILE.npz --scan
SHEET.png``).

A drawn file holds, besides each part's own arrays (:mod:`inkarm.jobs.calibration_pen`,
:mod:`~inkarm.jobs.calibration_kinematics`, :mod:`~inkarm.jobs.calibration`):

* ``format``: :data:`FORMAT`; ``part``: pen, kinematics or paper; ``robot``: the robot's name;
  ``page_size_mm``: (w, h) of the sheet [mm];
* ``scenario``: the scenario as JSON (:meth:`~inkarm.jobs.scenario.Scenario.to_dict`, file
  names absolute) and ``base_dir``;
* ``cal_*``: the calibration the controller believed while it drew (its robot, notes,
  geometry and paper map; ``cal_robot`` empty: none).

Only what a real cell offers is kept: joint readings, the sensed force, phases and strokes of
its log; never the plant's true tip (:class:`SavedRun`).

A scan (:func:`scan_corners`): an image of the sheet with its corners in pixels (u right, v
down; lower-left, lower-right, upper-right, upper-left), by default the image's own corners
(an emulator's PNG covers the page exactly: ``inkarm emulate dynamixel --out sheet.png``).
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from inkarm.errors import InputError
from inkarm.robots.calibration import CellCalibration, HeightMap

FORMAT = "inkarm-drawn-calibration-1"
DRAWN_PARTS = ("pen", "kinematics", "paper")
ASPECT_TOLERANCE = 0.02  # a scan's aspect (default corners) vs the page's: relative
SIDE_TOLERANCE = 0.25  # given corners: mean opposite sides' ratio vs the page's, relative
LOG_COLUMNS = ("time", "q", "force", "phase", "stroke")  # what hardware logs too


@dataclass(frozen=True, eq=False)
class SavedRun:
    """A pattern run as a drawn file keeps it: its ``log`` (joint readings, force, phases and
    strokes; the true tip and the reference NaN), no canvas (the ink is on the real sheet)."""

    log: Any
    canvas: Any = None
    finished: bool = True
    reason: str | None = None
    notes: tuple[str, ...] = ()


@dataclass(frozen=True, eq=False)
class DrawnFile:
    """A drawn file as read (:func:`load_drawn`): its ``part``, ``robot``, ``page_size_mm``
    [mm], the ``scenario`` (believing ``calibration``, the one it was drawn with, in memory),
    and the part's ``arrays``."""

    path: Path
    part: str
    robot: str
    page_size_mm: tuple[float, float]
    scenario: Any
    calibration: CellCalibration | None
    arrays: dict[str, np.ndarray]


def save_drawn(path: str | Path, part: str, scenario, calibration: CellCalibration | None,
               arrays: dict[str, np.ndarray]) -> Path:
    """Write a drawn file (module docstring) for ``part`` of ``scenario`` (its robot, its
    sheet), drawn believing ``calibration``, with the part's ``arrays``; returns its path
    (``.npz`` added when missing, as numpy does)."""
    from inkarm.sim.cell_config import Cell

    if part not in DRAWN_PARTS:
        raise InputError(f"unknown part {part!r}; expected one of {', '.join(DRAWN_PARTS)}",
                         key="part", value=part, choices=DRAWN_PARTS)
    path = Path(path)
    if path.suffix != ".npz":
        path = path.with_name(path.name + ".npz")
    cell = Cell(scenario.cell, scenario.robot)
    data = {"format": np.array(FORMAT), "part": np.array(part),
            "robot": np.array(scenario.robot.name),
            "page_size_mm": np.asarray(cell.paper_size_mm, dtype=float),
            "scenario": np.array(json.dumps(scenario.to_dict())),
            "base_dir": np.array(str(scenario.base_dir)), **_calibration_arrays(calibration)}
    clash = sorted(set(arrays) & set(data))
    if clash:
        raise InputError(f"a part's arrays may not be named {', '.join(clash)}", key="arrays")
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **data, **{k: np.asarray(v) for k, v in arrays.items()})
    return path


def load_drawn(path: str | Path, part: str, robot: str | None = None) -> DrawnFile:
    """Read a drawn file written by :func:`save_drawn`. Raises InputError (naming ``--read``
    and the file) when it is missing, not a drawn file, of another ``part``, or of another
    ``robot`` (when given)."""
    from inkarm.jobs.scenario import parse_scenario

    path = Path(path)
    if not path.is_file():
        raise InputError(f"no such drawn file: {path} (write one with `inkarm calibrate "
                         f"{part} --drawn {path}`)", key="--read", value=str(path))
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except (OSError, ValueError) as e:
        raise InputError(f"cannot read {path} as a drawn file ({e})", key="--read",
                         value=str(path)) from None
    if str(data.get("format", "")) != FORMAT:
        raise InputError(f"{path} is not a drawn calibration file (format "
                         f"{str(data.get('format', 'none'))!r}, expected {FORMAT!r})",
                         key="--read", value=str(path))
    held = str(data["part"])
    if held != part:
        raise InputError(f"{path} holds a drawn {held} pattern, not {part} (read it with "
                         f"`inkarm calibrate {held} --read {path} --scan ...`)", key="--read",
                         value=str(path), choices=DRAWN_PARTS)
    name = str(data["robot"])
    if robot is not None and robot != name:
        raise InputError(f"{path} was drawn by robot {name!r}, not {robot!r}", key="--robot",
                         value=robot)
    scenario = parse_scenario(json.loads(str(data["scenario"])),
                              source=f"{path} (scenario)", base_dir=str(data["base_dir"]))
    calibration = _calibration_of(data)
    scenario = dataclasses.replace(scenario, calibration=calibration)  # (None: the nominal)
    own = {k: v for k, v in data.items()
           if k not in {"format", "part", "robot", "page_size_mm", "scenario", "base_dir"}
           and not k.startswith("cal_")}
    size = tuple(float(v) for v in data["page_size_mm"])
    return DrawnFile(path, held, name, (size[0], size[1]), scenario, calibration, own)


def log_arrays(log, prefix: str = "log_") -> dict[str, np.ndarray]:
    """The columns of a :class:`~inkarm.core.log.DrawLog` that hardware logs too
    (:data:`LOG_COLUMNS`), keyed ``prefix + name``."""
    return {prefix + name: np.asarray(getattr(log, name)) for name in LOG_COLUMNS}


def saved_log(arrays: dict[str, np.ndarray], prefix: str = "log_"):
    """The :class:`~inkarm.core.log.DrawLog` of :func:`log_arrays` (tip, reference, speeds and
    torques NaN: a real cell does not log the true tip)."""
    from inkarm.core.log import DrawLog

    q = arrays[prefix + "q"]
    k = len(q)
    nan3 = np.full((k, 3), np.nan)
    return DrawLog(time=arrays[prefix + "time"], q=q, qd=np.full_like(q, np.nan),
                   torque=np.full_like(q, np.nan), tip=nan3, force=arrays[prefix + "force"],
                   reference=nan3.copy(), phase=arrays[prefix + "phase"],
                   stroke=arrays[prefix + "stroke"])


def parse_corners(text: str | None) -> np.ndarray | None:
    """``--corners "u,v u,v u,v u,v"`` as (4, 2) pixels (None: not given). Raises InputError
    naming ``--corners`` for anything but four pairs of finite numbers."""
    if text is None:
        return None
    pairs = text.replace(";", " ").split()
    try:
        corners = np.array([[float(a) for a in p.split(",")] for p in pairs], dtype=float)
    except ValueError:
        corners = np.zeros((0,))
    if corners.shape != (4, 2) or not np.isfinite(corners).all():
        raise InputError(f"expected the sheet's 4 corners as \"u,v u,v u,v u,v\" pixels "
                         f"(lower-left, lower-right, upper-right, upper-left), got {text!r}",
                         key="--corners", value=text)
    return corners


def scan_corners(darkness: np.ndarray, corners: np.ndarray | None,
                 page_size_mm: tuple[float, float], scan: str | Path) -> np.ndarray:
    """The corners [px] of the sheet in a scan ``darkness`` (rows, cols): ``corners`` when
    given, else the image's own, (0, H), (W, H), (W, 0), (0, 0). Refuses (InputError naming
    ``--scan``) a scan whose aspect W/H differs from the page's w/h by more than
    :data:`ASPECT_TOLERANCE` (default corners), or whose corners' mean widths over mean
    heights do by more than :data:`SIDE_TOLERANCE` (given ones: a photograph's perspective
    moves it): a scan of another page size."""
    w, h = page_size_mm
    rows, cols = darkness.shape[:2]
    if corners is None:
        corners = np.array([[0.0, rows], [cols, rows], [cols, 0.0], [0.0, 0.0]])
        aspect, tolerance, what = cols / rows, ASPECT_TOLERANCE, f"{cols}x{rows} px"
    else:
        side = np.linalg.norm(np.roll(corners, -1, axis=0) - corners, axis=1)
        aspect = (side[0] + side[2]) / max(side[1] + side[3], 1e-9)
        tolerance, what = SIDE_TOLERANCE, "the given corners"
    if abs(aspect / (w / h) - 1.0) > tolerance:
        raise InputError(f"{scan}: {what} has an aspect of {aspect:.3f}, the drawn page "
                         f"{w:g} x {h:g} mm has {w / h:.3f}: a scan of another page size (or "
                         "give the sheet's --corners)", key="--scan", value=str(scan))
    return corners


def _calibration_arrays(cal: CellCalibration | None) -> dict[str, np.ndarray]:
    if cal is None:
        return {"cal_robot": np.array("")}
    g = cal.geometry
    out = {"cal_robot": np.array(cal.robot), "cal_notes": np.array(cal.notes, dtype=str),
           "cal_link_length_mm": np.asarray(g.link_length_mm, dtype=float),
           "cal_joint_offset_deg": np.asarray(g.joint_offset_deg, dtype=float),
           "cal_tip_offset_mm": np.asarray(g.tip_offset_mm, dtype=float)}
    if cal.paper is not None:
        out |= {"cal_paper_x_mm": cal.paper.x_mm, "cal_paper_y_mm": cal.paper.y_mm,
                "cal_paper_z_mm": cal.paper.z_mm}
    return out


def _calibration_of(data: dict[str, np.ndarray]) -> CellCalibration | None:
    from inkarm.robots.geometry import GeometryErrors

    robot = str(data.get("cal_robot", ""))
    if not robot:
        return None

    def floats(key: str) -> tuple[float, ...]:
        return tuple(float(v) for v in data[key])

    tip = floats("cal_tip_offset_mm")
    geometry = GeometryErrors(link_length_mm=floats("cal_link_length_mm"),
                              joint_offset_deg=floats("cal_joint_offset_deg"),
                              tip_offset_mm=(tip[0], tip[1], tip[2]))
    paper = (HeightMap(data["cal_paper_x_mm"], data["cal_paper_y_mm"], data["cal_paper_z_mm"])
             if "cal_paper_z_mm" in data else None)
    return CellCalibration(robot, paper, geometry, tuple(str(n) for n in data["cal_notes"]))


__all__ = ["ASPECT_TOLERANCE", "DRAWN_PARTS", "FORMAT", "LOG_COLUMNS", "SIDE_TOLERANCE",
           "DrawnFile", "SavedRun", "load_drawn", "log_arrays", "parse_corners", "save_drawn",
           "saved_log", "scan_corners"]
