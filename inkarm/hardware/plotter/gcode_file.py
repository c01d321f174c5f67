"""A G-code file made elsewhere (vpype-gcode, Inkscape, a CAM program), read and checked as
GRBL 1.1h would take it, before a byte of it is sent.

:func:`read_gcode_file` keeps the lines GRBL would act on and refuses, naming the file and the
line, what GRBL would refuse: a byte that is not ASCII (not a G-code text file), a line longer
than GRBL's line buffer (79 characters once spaces and comments are dropped: GRBL 1.1h
``protocol.c`` answers ``error:11`` whatever it holds) or than its 128-byte receive buffer
(a sender would wait for ever), a ``$`` system command (settings and homing are the sender's,
not the job's), and every word-level and state-level check of :mod:`.gcode_parser` and
:mod:`.interpreter` (an unsupported word or command, a feed never given, a bad arc), with
GRBL's ``error:N`` code. Blank and comment-only lines, and a lone ``%`` (a tape marker that
CAM programs write and GRBL does not take), are not sent.

:func:`machine_targets` walks the job on GRBL's parser state from where the machine stands,
with its stored offsets (G54, G28, G30), as GRBL would queue it: every target of every move
in machine coordinates, arcs cut into GRBL's chords (``mc_arc``). :func:`check_reach` refuses
the first one that leaves the machine's travel.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from inkarm.errors import InputError
from inkarm.hardware.plotter.gcode_parser import (
    MAX_LINE,
    GcodeError,
    filter_line,
    normalise,
    parse_block,
)
from inkarm.hardware.plotter.homing import travel as axes_travel
from inkarm.hardware.plotter.interpreter import G28_INDEX, G30_INDEX, ParserState, execute_block
from inkarm.hardware.plotter.settings import GRBL_DEFAULTS

RX_BUFFER = 128  # GRBL 1.1h's serial receive buffer [bytes]: a line and its newline must fit
_COMMENT = re.compile(r"\([^)]*\)?|;.*")
TOLERANCE_MM = 1e-3


@dataclass(frozen=True, eq=False)
class GcodeJob:
    """The lines of a G-code file that are sent, each with its line number in the file.

    Attributes:
        path: The file.
        lines: The lines sent (comments and surrounding spaces removed).
        numbers: Each sent line's 1-based line number in the file.
        drawing: Whether each line is a feed move (it moves, in G1, G2 or G3: the pen draws)
            rather than a rapid (G0: travel) or a line that does not move.
        extent: What :func:`work_extent` returns, found as the file is read (None: found
            when asked).
    """

    path: str
    lines: tuple[str, ...]
    numbers: tuple[int, ...]
    drawing: tuple[bool, ...]
    extent: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def bytes(self) -> int:
        """Bytes sent, newlines included."""
        return sum(len(line) + 1 for line in self.lines)


def sent_text(raw: str) -> str:
    """What of a file's line is sent: without ``(...)`` and ``;`` comments and outer spaces."""
    return _COMMENT.sub("", raw).strip()


def read_gcode_file(path: str | Path) -> GcodeJob:
    """Read and check a G-code file (module docstring); raises :class:`InputError` naming the
    file and line."""
    name = str(path)
    p = Path(path)
    if not p.is_file():
        raise InputError("no such file" if not p.exists() else "not a file", file=name,
                         value=name)
    data = p.read_bytes()
    lines: list[str] = []
    numbers: list[int] = []
    for number, raw_bytes in enumerate(data.splitlines(), start=1):
        bad = next((b for b in raw_bytes if b >= 0x80 or (b < 0x20 and b not in (9, 12))),
                   None)
        if bad is not None:
            raise InputError(f"line {number}: byte 0x{bad:02X} is not G-code text (expected "
                             "a G-code text file, ASCII)", file=name, key=f"line {number}")
        raw = raw_bytes.decode("ascii")
        text = sent_text(raw)
        if not text or text == "%":
            continue
        where = {"file": name, "key": f"line {number}"}
        if text.startswith("<"):
            raise InputError("this is XML (an SVG?), not G-code; make G-code from a drawing "
                             "first: inkarm gcode DRAWING.svg --out FILE.gcode", **where)
        if text.startswith("$"):
            raise InputError(f"{text!r} is a GRBL system command, not G-code: settings, "
                             "homing and unlocking are the sender's ($H runs when $22=1); "
                             "remove it", **where)
        kept, overflow = filter_line(text)
        if overflow:
            raise InputError(f"{len(normalise(text))} characters once spaces and comments are "
                             f"dropped; GRBL 1.1h keeps {MAX_LINE} (an 80-byte line buffer) and "
                             f"answers error:11: {text[:40]!r}...", **where)
        if len(text) + 1 > RX_BUFFER:
            raise InputError(f"{len(text) + 1} bytes with its newline, more than GRBL's "
                             f"{RX_BUFFER}-byte receive buffer: {text[:40]!r}...", **where)
        if kept:
            lines.append(text)
            numbers.append(number)
    if not lines:
        raise InputError("no G-code line in it (expected G-code text: G0/G1 moves ...)",
                         file=name)
    job = GcodeJob(name, tuple(lines), tuple(numbers), ())
    targets, drawing = machine_targets(job)
    return GcodeJob(name, job.lines, job.numbers, tuple(drawing), _extent(targets))


def machine_targets(job: GcodeJob, params: np.ndarray | None = None,
                    start_mm=(0.0, 0.0, 0.0), arc_tolerance_mm: float = 0.002
                    ) -> tuple[list[tuple[int, np.ndarray]], list[bool]]:
    """Every move's target as GRBL queues it: (0-based line index, machine point [mm]), arcs
    as their chords; and per line whether it is a feed move (it moves, in G1-G3). ``params``: the
    stored G54-G59, G28 and G30 positions (8 x 3 [mm], machine; zeros when None);
    ``start_mm``: the machine position before the first line. Raises :class:`InputError`
    with GRBL's ``error:N`` for a line GRBL refuses."""
    params = np.zeros((8, 3)) if params is None else np.array(params, dtype=float)
    state = ParserState(coord_system=params[0].copy(),
                        position=np.asarray(start_mm, dtype=float).copy())
    targets: list[tuple[int, np.ndarray]] = []
    drawing: list[bool] = []
    for i, text in enumerate(job.lines):
        try:
            actions = execute_block(state, parse_block(filter_line(text)[0]), params,
                                    arc_tolerance=arc_tolerance_mm)
        except GcodeError as e:
            raise InputError(f"GRBL 1.1h refuses {text!r}: {e}", file=job.path,
                             key=f"line {job.numbers[i]}") from None
        moves = [np.asarray(a[1], dtype=float) for a in actions if a[0] == "line"]
        drawing.append(bool(moves) and state.motion in (1, 2, 3))
        targets.extend((i, point) for point in moves)
    return targets, drawing


def work_extent(job: GcodeJob) -> tuple[np.ndarray, np.ndarray]:
    """The lowest and highest point [mm] (x, y, z) the job's moves reach, in its own (work)
    coordinates from a machine at 0 with no offsets (the page frame of a file drawn from
    its origin)."""
    if job.extent is not None:
        return job.extent
    return _extent(machine_targets(job)[0])


def _extent(targets: list[tuple[int, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """The lowest and highest of ``targets``' points [mm] (zeros when there are none)."""
    points = np.array([p for _, p in targets])
    if not len(points):
        return np.zeros(3), np.zeros(3)
    return points.min(axis=0), points.max(axis=0)


def stored_params(offsets: dict[str, tuple[float, ...]], origin_mm=None) -> np.ndarray:
    """GRBL's stored coordinate data (8 x 3 [mm]: G54-G59, G28, G30) from ``$#``'s answer
    (:func:`inkarm.hardware.plotter.workspace.read_offsets`), with G54's x, y replaced by
    ``origin_mm`` (the page origin the sender sets) when given."""
    params = np.zeros((8, 3))
    names = {f"G{54 + k}": k for k in range(6)} | {"G28": G28_INDEX, "G30": G30_INDEX}
    for name, k in names.items():
        values = offsets.get(name)
        if values:
            params[k, : min(3, len(values))] = values[:3]
    if origin_mm is not None:
        params[0, :2] = origin_mm[:2]
    return params


def check_reach(job: GcodeJob, settings: dict[int, float], homed: bool,
                origin_mm: tuple[float, float], params: np.ndarray | None = None,
                start_mm=(0.0, 0.0, 0.0)) -> None:
    """Refuse the job's first move that leaves the machine's travel (``$130``, ``$131``; and
    ``$132`` with soft limits on), naming the file's line, the point (work and machine) and
    the travel. A homed machine's space is [-$13x, 0] (GRBL 1.1h limits.c, see
    :mod:`.workspace`); one that does not home reaches [0, $13x] from where it powered up
    (the page's lower-left corner)."""
    travel = axes_travel({**GRBL_DEFAULTS, **settings})
    lo, hi = (-travel, np.zeros(3)) if homed else (np.zeros(3), travel)
    axes = 3 if homed and settings.get(20) else 2
    if params is None:
        params = stored_params({}, origin_mm)
    targets, _ = machine_targets(job, params, start_mm, settings.get(12, 0.002))
    wco = params[0]
    for i, point in targets:
        out = (point[:axes] < lo[:axes] - TOLERANCE_MM) | (point[:axes] > hi[:axes] + TOLERANCE_MM)
        if not out.any():
            continue
        axis = int(np.argmax(out))
        name = "XYZ"[axis]
        work = point - wco
        space = ", ".join(f"{'XYZ'[a]} {lo[a]:g} to {hi[a]:g} mm (${130 + a})"
                          for a in range(axes))
        how = ("homed ($22=1): machine space [-$13x, 0]" if homed else
               "not homed ($22=0): from the power-up corner")
        raise InputError(
            f"the move to X {work[0]:.3f} Y {work[1]:.3f} Z {work[2]:.3f} mm (machine X "
            f"{point[0]:.3f} Y {point[1]:.3f} Z {point[2]:.3f}) leaves the machine's travel in "
            f"{name}: {space}; page origin at machine ({origin_mm[0]:g}, {origin_mm[1]:g}) "
            f"mm, {how}. Scale or move the drawing, or choose another --origin",
            file=job.path, key=f"line {job.numbers[i]}")


__all__ = ["GcodeJob", "check_reach", "machine_targets", "read_gcode_file", "sent_text",
           "stored_params", "work_extent"]
