"""GRBL 1.1h's G-code interpreter: the parser state (modal groups, position, work coordinates,
G92, tool length offset), the checks that need it, and what a valid block does, in GRBL's
order of execution (steps 3 and 4 of ``gcode.c`` ``gc_execute_line``; inkarm's own code).

Error codes of the state checks (GRBL 1.1 ``error:N``; the first failing one in GRBL's order):
22 feed rate undefined (G1/G2/G3 with F 0, G93 without F, a jog without F), 26 no axis words
(G10, G92, arcs), 27 line number above 10,000,000, 28 a value word missing (G4 without P,
G10 without P or L), 29 G10 P above 6, 30 G53 without G0 or G1, 31 axis words with G80,
32 an arc without axis words in its plane, 33 an arc whose end is off its circle (> 0.005 mm
and > 0.1 %, or > 0.5 mm) or an R arc ending where it starts, 34 an R arc of too small a
radius, 35 an arc without offsets in its plane, 36 words left unused (P or R on G1, I/J/K
without an arc), 37 G43.1 with an axis word other than Z, 16 a jog with other commands.

Positions are machine millimetres; feeds mm/min as in GRBL. :func:`execute_block` mutates the
state only when the block is valid and returns the actions for the machine: ``("sync",)``,
``("spindle", mode, rpm)``, ``("coolant", mode)``, ``("dwell", s)``, ``("line", target,
feed, rapid, line)`` (feed None for rapids), ``("wco",)``, ``("pause",)``, ``("end",)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from inkarm.hardware.plotter.gcode_parser import (
    AXIS_MOTION,
    AXIS_NONE,
    AXIS_TOOL_LENGTH,
    Block,
    GcodeError,
)

MM_PER_INCH = 25.4
MAX_LINE_NUMBER = 10_000_000
N_COORDINATE_SYSTEM = 6
G28_INDEX, G30_INDEX = 6, 7
ARC_ANGULAR_TRAVEL_EPSILON = 5e-7
PLANES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}
SINGLE_MEANING = "NFST"


@dataclass
class ParserState:
    """GRBL's ``gc_state`` (units: mm, mm/min; ``coord`` 0-5 for G54-G59)."""

    motion: float = 0
    plane: int = 17
    distance: int = 90
    feed_mode: int = 94
    units: int = 21
    coord: int = 0
    spindle: int = 5
    coolant: int = 9
    tool_length: float = 49
    feed: float = 0.0
    spindle_speed: float = 0.0
    tool: int = 0
    position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    coord_system: np.ndarray = field(default_factory=lambda: np.zeros(3))
    coord_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    tool_length_offset: float = 0.0

    def wco(self) -> np.ndarray:
        """The work coordinate offset [mm]: active system + G92 + tool length (on Z)."""
        w = self.coord_system + self.coord_offset
        w[2] += self.tool_length_offset
        return w


def execute_block(state: ParserState, block: Block, params: np.ndarray, jog: bool = False,
                  arc_tolerance: float = 0.002) -> list[tuple]:
    """Check ``block`` against ``state`` and the stored coordinate data ``params`` (8 x 3:
    G54-G59, G28, G30; changed in place by G10/G28.1/G30.1) and do it; raises
    :class:`GcodeError`. ``jog``: the block came from ``$J=`` (G1 and G94 enforced)."""
    g, v = block.groups, dict(block.values)
    used: set[str] = set()
    axes = block.axis_words()
    axis_command = block.axis_command
    motion = 1 if jog else g.get("motion", state.motion)
    feed_mode = 94 if jog else g.get("feed mode", state.feed_mode)
    units = g.get("units", state.units)
    plane = g.get("plane", state.plane)
    distance = g.get("distance", state.distance)
    coord = int(g["coord"]) - 54 if "coord" in g else state.coord
    non_modal = g.get("non-modal", 0)
    scale = MM_PER_INCH if units == 20 else 1.0
    if "N" in v and v["N"] > MAX_LINE_NUMBER:
        raise GcodeError(27, f"line number N{v['N']:g} above {MAX_LINE_NUMBER}")
    # [2-3] feed rate mode and feed rate
    if jog:
        if "F" not in v:
            raise GcodeError(22, "a jog needs F")
        feed = v["F"] * scale
    elif feed_mode == 93:
        if axis_command == AXIS_MOTION and motion not in (80, 0) and "F" not in v:
            raise GcodeError(22, "G93 needs F on every move")
        feed = v.get("F", 0.0)
    elif state.feed_mode == 94:
        feed = v["F"] * scale if "F" in v else state.feed
    else:
        feed = v.get("F", 0.0)
    speed = v.get("S", state.spindle_speed)
    # [10] dwell
    if non_modal == 4:
        if "P" not in v:
            raise GcodeError(28, "G4 needs P")
        used.add("P")
    axis_0, axis_1, axis_linear = PLANES[plane]
    xyz = np.array([v.get(a, 0.0) * scale for a in "XYZ"])
    # [14] tool length offset
    if axis_command == AXIS_TOOL_LENGTH and g["tool length"] == 43.1 and axes != [2]:
        raise GcodeError(37, "G43.1 needs Z and no other axis word")
    # [15] coordinate system
    block_coord = params[coord].copy() if coord != state.coord else state.coord_system.copy()
    # [19] non-modal actions with axis words
    g10_target = g10_values = home = None
    if non_modal == 10:
        if not axes:
            raise GcodeError(26, "G10 needs axis words")
        if "P" not in v and "L" not in v:  # (GRBL asks for either: a missing one is 0)
            raise GcodeError(28, "G10 needs P and L")
        select = math.trunc(v.get("P", 0.0))
        level = v.get("L", 0.0)
        if select > N_COORDINATE_SYSTEM:
            raise GcodeError(29, f"G10 P{select}: only P0-P6")
        if level != 20 and (level != 2 or "R" in v):
            raise GcodeError(20, f"G10 L{level:g}{' R' if 'R' in v else ''} is not "
                             "supported (L2 or L20)")
        used |= {"L", "P"}
        g10_target = select - 1 if select > 0 else coord
        g10_values = params[g10_target].copy()
        for i in axes:
            if level == 20:
                g10_values[i] = state.position[i] - state.coord_offset[i] - xyz[i]
                if i == 2:
                    g10_values[i] -= state.tool_length_offset
            else:
                g10_values[i] = xyz[i]
    elif non_modal == 92:
        if not axes:
            raise GcodeError(26, "G92 needs axis words")
        for i in range(3):
            if i in axes:
                xyz[i] = state.position[i] - block_coord[i] - xyz[i]
                if i == 2:
                    xyz[i] -= state.tool_length_offset
            else:
                xyz[i] = state.coord_offset[i]
    else:
        if axis_command != AXIS_TOOL_LENGTH and axes:
            for i in range(3):
                if i not in axes:
                    xyz[i] = state.position[i]
                elif non_modal != 53:
                    if distance == 90:
                        xyz[i] += block_coord[i] + state.coord_offset[i]
                        if i == 2:
                            xyz[i] += state.tool_length_offset
                    else:
                        xyz[i] += state.position[i]
        if non_modal in (28, 30):
            home = params[G28_INDEX if non_modal == 28 else G30_INDEX].copy()
            if axes:
                for i in range(3):
                    if i not in axes:
                        home[i] = state.position[i]
            else:
                axis_command = AXIS_NONE
        elif non_modal == 53 and motion not in (0, 1):
            raise GcodeError(30, "G53 needs G0 or G1")
    # [20] motion modes
    arc = None
    if motion == 80:
        if axes:
            raise GcodeError(31, "axis words with G80")
    elif axis_command == AXIS_MOTION:
        if motion == 0:
            if not axes:
                axis_command = AXIS_NONE
        else:
            if feed == 0.0:
                raise GcodeError(22, "feed rate undefined")
            if motion == 1:
                if not axes:
                    axis_command = AXIS_NONE
            elif motion in (2, 3):
                arc = _check_arc(state, v, xyz, axes, motion == 2, scale,
                                 (axis_0, axis_1, axis_linear), used)
            else:  # G38.x probing
                if not axes:
                    raise GcodeError(26, "G38 needs axis words")
                if np.array_equal(state.position, xyz):
                    raise GcodeError(33, "G38 target is the current position")
    # [0] unused words
    left = set(v) - used - set("NF" if jog else SINGLE_MEANING)
    if axis_command:
        left -= set("XYZ")
    if left:
        raise GcodeError(36, f"unused words {''.join(sorted(left))}")
    if jog:
        extra = set(g) - {"distance", "units", "non-modal"}
        if extra or non_modal not in (0, 53):
            raise GcodeError(16, "a jog takes only G20/G21, G90/G91, G53, X Y Z, F and N")
        target = xyz if axes else np.zeros(3)  # (GRBL jogs to whatever its target holds)
        return [("jog", target, feed)]
    return _apply(state, block, params, feed, speed, coord, block_coord, xyz, axis_command,
                  motion, non_modal, g10_target, g10_values, home, arc, (axis_0, axis_1, axis_linear), arc_tolerance)


def _check_arc(state: ParserState, v: dict, xyz: np.ndarray, axes: list[int],
               clockwise: bool, scale: float, plane: tuple[int, int, int],
               used: set[str]) -> tuple[np.ndarray, float, bool]:
    """GRBL's arc checks; returns the centre offset (3,), the radius [mm] and the direction."""
    a0, a1, _ = plane
    if not axes:
        raise GcodeError(26, "an arc needs axis words")
    if a0 not in axes and a1 not in axes:
        raise GcodeError(32, "an arc needs axis words in its plane")
    x = xyz[a0] - state.position[a0]
    y = xyz[a1] - state.position[a1]
    ijk = np.zeros(3)
    if "R" in v:
        used.add("R")
        if np.array_equal(state.position, xyz):
            raise GcodeError(33, "an R arc must end away from its start")
        r = v["R"] * scale
        h = 4.0 * r * r - x * x - y * y
        if h < 0:
            raise GcodeError(34, f"radius {abs(r):g} mm is too small for the chord")
        h_d = -math.sqrt(h) / math.hypot(x, y)
        if not clockwise:
            h_d = -h_d
        if r < 0:
            h_d, r = -h_d, -r
        ijk[a0] = 0.5 * (x - y * h_d)
        ijk[a1] = 0.5 * (y + x * h_d)
        return ijk, r, clockwise
    given = [i for i, a in enumerate("IJK") if a in v]
    if a0 not in given and a1 not in given:
        raise GcodeError(35, "an arc needs I/J/K offsets in its plane")
    used |= {"I", "J", "K"}
    for i in given:
        ijk[i] = v["IJK"[i]] * scale
    r = math.hypot(ijk[a0], ijk[a1])
    delta = abs(math.hypot(x - ijk[a0], y - ijk[a1]) - r)
    if delta > 0.005 and (delta > 0.5 or delta > 0.001 * r):
        raise GcodeError(33, f"the arc's end is {delta:.3f} mm off its circle")
    return ijk, r, clockwise


def _apply(state, block, params, feed, speed, coord, block_coord, xyz, axis_command, motion,
           non_modal, g10_target, g10_values, home, arc, plane, arc_tolerance) -> list[tuple]:
    """Step 4 of ``gc_execute_line``: update the state and list the actions."""
    g, v = block.groups, block.values
    out: list[tuple] = []
    line = int(v.get("N", 0))
    state.feed_mode = g.get("feed mode", state.feed_mode)
    state.feed = feed
    if speed != state.spindle_speed:
        if state.spindle != 5:
            out += [("sync",), ("spindle", state.spindle, speed)]
        state.spindle_speed = speed
    state.tool = int(v.get("T", 0))
    spindle = g.get("spindle", state.spindle)
    if spindle != state.spindle:
        out += [("sync",), ("spindle", spindle, state.spindle_speed)]
        state.spindle = int(spindle)
    coolant = state.coolant
    for code in block.coolant:
        coolant = code
    if coolant != state.coolant:
        out += [("sync",), ("coolant", coolant)]
        state.coolant = coolant
    if non_modal == 4:
        out += [("sync",), ("dwell", v["P"])]
    state.plane = g.get("plane", state.plane)
    state.units = g.get("units", state.units)
    if axis_command == AXIS_TOOL_LENGTH:
        state.tool_length = g["tool length"]
        tlo = 0.0 if state.tool_length == 49 else xyz[2]
        if tlo != state.tool_length_offset:
            state.tool_length_offset = tlo
            out.append(("wco",))
    if coord != state.coord:
        state.coord = coord
        state.coord_system = block_coord.copy()
        out.append(("wco",))
    state.distance = g.get("distance", state.distance)
    inverse = state.feed_mode == 93
    if non_modal == 10:
        out.append(("sync",))  # GRBL syncs the planner before an EEPROM write
        params[g10_target] = g10_values
        if g10_target == state.coord:
            state.coord_system = g10_values.copy()
            out.append(("wco",))
    elif non_modal in (28, 30):
        if axis_command:
            out.append(("line", xyz.copy(), None, line))
        out.append(("line", home.copy(), None, line))
        state.position = home.copy()
    elif non_modal in (28.1, 30.1):
        out.append(("sync",))
        params[G28_INDEX if non_modal == 28.1 else G30_INDEX] = state.position.copy()
    elif non_modal == 92:
        state.coord_offset = xyz.copy()
        out.append(("wco",))
    elif non_modal == 92.1:
        state.coord_offset = np.zeros(3)
        out.append(("wco",))
    state.motion = motion
    if motion != 80 and axis_command == AXIS_MOTION:
        if motion == 0:
            out.append(("line", xyz.copy(), None, line))
        elif motion in (2, 3):
            out += arc_lines(state.position, xyz, arc, plane, feed, inverse, arc_tolerance, line)
        else:  # G1 (and G38.x, run as a straight move)
            out.append(("line", xyz.copy(), _feed(feed, inverse, state.position, xyz), line))
        state.position = xyz.copy()
    flow = g.get("flow")
    if flow in (0, 2, 30):
        out.append(("sync",))
        if flow == 0:
            out.append(("pause",))
        else:
            state.motion, state.plane, state.distance, state.feed_mode = 1, 17, 90, 94
            state.coord, state.spindle, state.coolant = 0, 5, 9
            state.coord_system = params[0].copy()
            out.append(("end",))
    return out


def _feed(feed: float, inverse: bool, start: np.ndarray, end: np.ndarray) -> float:
    """The planner's feed [mm/min]; in G93 the F word is moves per minute."""
    if not inverse:
        return feed
    return feed * float(np.linalg.norm(end - start))


def arc_lines(start: np.ndarray, target: np.ndarray, arc, plane, feed: float, inverse: bool,
              tolerance: float, line: int = 0) -> list[tuple]:
    """GRBL's ``mc_arc``: chords within ``tolerance`` [mm] of the circle, ``floor(|theta| r /
    2 / sqrt(tol (2 r - tol)))`` of them (none: one straight line to the end)."""
    ijk, radius, clockwise = arc
    a0, a1, lin = plane
    centre = np.array([start[a0] + ijk[a0], start[a1] + ijk[a1]])
    r0 = -ijk[a0], -ijk[a1]
    rt = target[a0] - centre[0], target[a1] - centre[1]
    angle = math.atan2(r0[0] * rt[1] - r0[1] * rt[0], r0[0] * rt[0] + r0[1] * rt[1])
    if clockwise and angle >= -ARC_ANGULAR_TRAVEL_EPSILON:
        angle -= 2 * math.pi
    elif not clockwise and angle <= ARC_ANGULAR_TRAVEL_EPSILON:
        angle += 2 * math.pi
    segments = math.floor(abs(0.5 * angle * radius)
                          / math.sqrt(tolerance * (2 * radius - tolerance)))
    rate = feed
    if inverse:
        rate = feed * segments if segments else _feed(feed, True, start, target)
    out = []
    for k in range(1, segments):
        a = angle * k / segments
        c, s = math.cos(a), math.sin(a)
        point = start.copy()
        point[a0] = centre[0] + c * r0[0] - s * r0[1]
        point[a1] = centre[1] + s * r0[0] + c * r0[1]
        point[lin] = start[lin] + (target[lin] - start[lin]) * k / segments
        out.append(("line", point, rate, line))
    out.append(("line", target.copy(), rate, line))
    return out


__all__ = ["G28_INDEX", "G30_INDEX", "ParserState", "arc_lines", "execute_block"]
