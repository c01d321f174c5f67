"""Record transcripts of the real GRBL 1.1h firmware, run on this PC by grbl-sim, as test data
(``tests/data/grbl/*.json``; the format is in ``tests/data/grbl/README.md``).

The firmware executable is built elsewhere and given by path; this script never builds it (the
workplace keeps GRBL's code and any recipe that builds it out of this repository). It expects
grbl-sim's command line (``-n -t SPEEDUP -s STEPFILE -b BLOCKFILE``) and a harness that logs
the simulated time of every received byte, sent line and planner block boundary to
``$GRBL_SIM_TIMELOG`` (``R <t> <hex>``, ``T <t> <line>``, ``S <t>`` / ``E <t>``) and reads
``$GRBL_SIM_HOME_DISTANCE_MM``, the distance of the carriage below its home switches at
power-up. Each session starts from a fresh EEPROM (GRBL's stock ``DEFAULTS_GENERIC``).

    .venv/bin/python scripts/record_grbl_transcripts.py PATH/grbl_sim.exe [--only NAME ...]

Times in the transcripts are the firmware's simulated machine time [s] since power-up (the
simulator's 16 MHz tick counter), not wall time.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import select
import subprocess
import sys
import tempfile
import time
import tty
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "tests" / "data" / "grbl"
GCODE = ROOT / "tests" / "data" / "gcode"
GRBL_COMMIT = "bfb67f0c7963fe3ce4aaf8a97f9009ea5a8db36e"  # gnea/grbl: GRBL 1.1h.20190830
SIM_COMMIT = "9bdd165"  # grbl/grbl-sim
HARNESS = (
    "gcc 12 builds with -fcommon (GRBL's headers define globals in every unit)",
    "the simulated input pins read as pulled up (no switch pressed, no control pin active)",
    "stdin is read unbuffered (read(2) of one byte; stdio would hide a burst's tail from select)",
    ("the receive check allows GRBL 1.1's RX_BUFFER_SIZE+1 = 129 ring slots, and the "
     "firmware's serial_read yields the CPU only when the buffer is empty, not per character"),
    ("the transmit ring is drained while its head and tail differ (the UDRIE0 flag, set and "
     "cleared by two threads, raced and left replies unsent)"),
    ("the receive interrupt waits while the firmware has interrupts disabled, as on the AVR, "
     "and GRBL's real-time flag setters/clearers (system.c, atomic by cli() on the AVR) are "
     "replaced by atomic operations: the firmware's interrupts run in a second thread here"),
    ("terminal modes are set only when stdin is a terminal (speed; no change of behaviour)"),
    ("serial.c, stepper.c and planner.c compiled with -O0: at -O3 gcc stored a ring's head "
     "before the byte it guards, and the other thread read a stale byte"),
    ("limit switches, an addition for $H: while homing is enabled ($22=1), an axis' switch "
     "reads closed while the carriage is at or past the home end of travel (toward +, $23=0); "
     "the carriage starts GRBL_SIM_HOME_DISTANCE_MM below the switches"),
    ("delays (_delay_ms/_delay_us) last machine time, not wall time; a delay inside an "
     "interrupt (st_go_idle's $1 stepper lock) advances machine time at once"),
    ("lockstep: while the stepper interrupt runs, machine time advances at most 1 ms past the "
     "main loop's last st_prep_buffer call (the OS could preempt the firmware's main-loop thread "
     "long enough for the segment buffer to run dry)"),
    ("GRBL_SIM_TIMELOG, an addition for recording: the machine time of every received byte, "
     "sent line, planner block start/end, block's last step and stepper idle"),
)
# Lines after which GRBL resets or reports late: the next step waits RESET_SETTLE_S [s] of
# machine time, so that all they cause is theirs (the simulator writes EEPROM instantly and
# its reset latency, 10-60 ms, is not the AVR's)
RESETTING = ("$RST", "$C", "$SLP", "$N", "$X", "$H")
RESET_SETTLE_S = 0.5
REPLY_TIMEOUT_S = 45.0  # wall seconds; the longest wait (homing) takes ~15
ATTEMPTS = 4  # grbl-sim runs the firmware's ISRs and main loop in two threads: a rare race
# (a lost real-time flag) can stall a session; it is then recorded again from power-up
NUMERIC = ("MPos", "WPos", "WCO", "FS", "F", "Bf", "Ln", "Ov")
PLOTTER = {100: 80, 101: 80, 102: 400, 110: 12000, 111: 12000, 112: 3000, 120: 1500,
           121: 1500, 122: 500, 130: 300, 131: 300, 132: 40}  # inkarm's plotter machine


def parse_report(line: str) -> dict:
    """``<State|Field:a,b|...>`` as ``{"state": ..., field: [numbers] or text}``."""
    state, *fields = line[1:-1].split("|")
    out: dict = {"state": state}
    for field in fields:
        name, _, value = field.partition(":")
        try:
            out[name] = [float(v) for v in value.split(",")] if name in NUMERIC else value
        except ValueError:  # kept as sent
            out[name] = value
    return out


class Simulator:
    """One grbl-sim process: stdin a pipe, stdout a raw pseudo-terminal (line-buffered)."""

    def __init__(self, exe: Path, workdir: Path, speedup: float, home_mm: float):
        self.speedup = speedup
        self.timelog = workdir / "timelog.txt"
        master, slave = os.openpty()
        tty.setraw(master)
        tty.setraw(slave)
        env = dict(os.environ, GRBL_SIM_TIMELOG=str(self.timelog),
                   GRBL_SIM_HOME_DISTANCE_MM=str(home_mm))
        self.proc = subprocess.Popen(
            [str(exe), "-n", "-t", str(speedup), "-s", os.devnull, "-b", os.devnull],
            cwd=workdir, stdin=subprocess.PIPE, stdout=slave, stderr=subprocess.DEVNULL,
            env=env)
        os.close(slave)
        self.master = master
        self.buffer = b""
        self.lines: list[str] = []  # every line the firmware sent so far, in order
        self.sent: list[int] = []  # every byte sent to it so far, in order

    def pump(self, wait_s: float) -> None:
        ready, _, _ = select.select([self.master], [], [], wait_s)
        if not ready:
            return
        try:
            self.buffer += os.read(self.master, 65536)
        except OSError:
            return
        *done, self.buffer = self.buffer.split(b"\n")
        self.lines.extend(line.rstrip(b"\r").decode("ascii", "replace") for line in done)

    def send(self, data: bytes) -> None:
        self.sent.extend(data)
        assert self.proc.stdin is not None
        self.proc.stdin.write(data)
        self.proc.stdin.flush()

    def wait_for(self, start: int, done: Callable[[str], bool],
                 timeout_s: float = REPLY_TIMEOUT_S) -> None:
        """Read until ``done(line)`` holds for a line at index >= ``start``."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            if any(done(line) for line in self.lines[start:]):
                return
            self.pump(0.005)
        tail = self.timelog.read_text().splitlines()[-12:] if self.timelog.exists() else []
        raise TimeoutError(f"no awaited reply; got {self.lines[start:]!r}; the time log "
                           "ends:\n" + "\n".join(tail))

    def sleep(self, sim_s: float) -> None:
        end = time.monotonic() + sim_s / self.speedup
        while (left := end - time.monotonic()) > 0:
            self.pump(min(0.005, left))

    def close(self) -> list[tuple[str, float, str]]:
        """End the process; returns its time log as (kind, t, rest) rows."""
        self.sleep(0.1)
        self.proc.kill()
        self.proc.wait()
        os.close(self.master)
        rows = []
        for row in self.timelog.read_text().splitlines():
            kind, t, *rest = row.split(" ", 2)
            rows.append((kind, float(t), rest[0] if rest else ""))
        return rows


def is_report(line: str) -> bool:
    return line.startswith("<") and line.endswith(">")


def is_prompt(line: str) -> bool:
    return line == "ok" or line.startswith(("error:", "ALARM:"))


class Recorder:
    """Runs a session's steps against a simulator, noting which bytes each step sent."""

    def __init__(self, sim: Simulator):
        self.sim = sim
        self.steps: list[tuple[str, dict, int]] = []  # group, step, index of its last byte
        self.group = ""
        self.job: dict | None = None

    def _sent(self, step: dict) -> None:
        self.steps.append((self.group, step, len(self.sim.sent) - 1))

    def line(self, text: str, settle_s: float = 0.02, answered: bool = True) -> None:
        """Send a line; wait for its ``ok``/``error:``/``ALARM:`` (and ``settle_s`` more);
        ``answered=False``: a line the firmware does not answer now (asleep)."""
        first = len(self.sim.lines)
        self.sim.send(text.encode("ascii") + b"\n")
        self._sent({"send": text})
        if answered:
            self.sim.wait_for(first, is_prompt)
        if text.startswith(RESETTING):
            settle_s = max(settle_s, RESET_SETTLE_S)
        self.sim.sleep(settle_s)

    def lines(self, *texts: str) -> None:
        for text in texts:
            self.line(text)

    def realtime(self, byte: int, settle_s: float = 0.05, answered: bool = True) -> dict:
        """Send a real-time byte; ``?`` waits for the report (returned parsed), 0x18 for the
        banner, the others ``settle_s``; ``answered=False``: a ``?`` the firmware does not
        answer (its critical-alarm loop waits for a reset only)."""
        first = len(self.sim.lines)
        self.sim.send(bytes([byte]))
        self._sent({"realtime": f"0x{byte:02x}"})
        if byte == ord("?") and answered:
            self.sim.wait_for(first, is_report)
            return parse_report(next(x for x in self.sim.lines[first:] if is_report(x)))
        if byte == 0x18:
            self.sim.wait_for(first, lambda x: x.startswith("Grbl "))
            settle_s = max(settle_s, RESET_SETTLE_S)
        self.sim.sleep(settle_s)
        return {}

    def wait(self, sim_s: float) -> None:
        self.sim.sleep(sim_s)

    def poll_until_idle(self, period_s: float = 0.2, extra: int = 0, limit: int = 3000) -> int:
        """``?`` every ``period_s`` of machine time until the state is Idle/Alarm/Check, and
        ``extra`` polls more; returns how many polls."""
        settled = 0
        for n in range(1, limit + 1):
            state = self.realtime(ord("?"), settle_s=0).get("state", "")
            settled = settled + 1 if state.split(":")[0] in ("Idle", "Alarm", "Check") else 0
            if settled > extra:
                return n
            self.sim.sleep(period_s)
        raise TimeoutError("the machine never went idle")

    def move(self, text: str) -> None:
        self.line(text)
        self.poll_until_idle()

    def stream(self, lines: list[str], settings: dict[int, float]) -> None:
        """Character-counting streaming of a job (GRBL's 128-byte receive buffer kept full);
        the job's lines, replies and times go to ``self.job``, not to the steps."""
        first_byte, first_reply = len(self.sim.sent), len(self.sim.lines)
        in_flight: list[int] = []
        answered = first_reply
        ends: list[int] = []

        def collect() -> None:
            nonlocal answered
            while answered < len(self.sim.lines):
                reply = self.sim.lines[answered]
                answered += 1
                if reply == "ok" or reply.startswith("error:"):
                    in_flight.pop(0)

        for text in lines:
            data = text.encode("ascii") + b"\n"
            while sum(in_flight) + len(data) > 128:
                self.sim.pump(0.001)
                collect()
            self.sim.send(data)
            ends.append(len(self.sim.sent) - 1)
            in_flight.append(len(data))
        while in_flight:
            self.sim.pump(0.005)
            collect()
        self.job = {"lines": lines, "settings": {str(k): v for k, v in settings.items()},
                    "first_byte": first_byte, "line_ends": ends, "first_reply": first_reply}
        self.group = "after the job"
        self.line("G4 P0")  # answered once the planner is empty and the stepper idle
        self.poll_until_idle()


# -- sessions ---------------------------------------------------------------------------------

SESSIONS: dict[str, tuple[str, Callable[[Recorder], None], dict[int, float]]] = {}


def session(description: str, eeprom: dict[int, float] | None = None):
    """Register a session; ``eeprom``: settings stored before its power-up."""
    def register(run: Callable[[Recorder], None]):
        SESSIONS[run.__name__] = (description, run, eeprom or {})
        return run
    return register


@session("every $ command: views, startup lines, settings good and bad, check mode, jogging "
         "and its cancel, settings resets, sleep")
def dollar_commands(r: Recorder) -> None:
    r.group = "views"
    r.lines("$", "$$", "$#", "$G", "$I", "$N")
    r.realtime(ord("?"))
    r.group = "startup lines"
    r.lines("$N0=G21 G90", "$N1=G0 X1", "$N1=G54 G17", "$N2=G20", "$N", "$N0=", "$N1=", "$N")
    r.group = "build info"
    r.lines("$I=inkarm", "$I")
    r.group = "settings good"
    r.lines("$110=600", "$110=500.0", "$1=255", "$1=25", "$10=2", "$10=1", "$13=1", "$13=0",
            "$30=1000.5", "$30=1000", "$100=250.000", "$32=0", "$11=0.01", "$3=7", "$3=0")
    r.group = "settings bad"
    r.lines("$110=-5", "$1=256", "$0=2", "$999=1", "$100=abc", "$=1", "$110", "$x=1", "$22=2",
            "$11=0", "$120=0", "$4=1.5", "$140=1", "$131=", "$20=1", "$21=1")
    r.group = "settings restored"
    r.lines("$1=25", "$11=0.010", "$120=10", "$22=0", "$4=0", "$21=0", "$$")
    r.group = "check mode"
    r.line("$C")
    r.realtime(ord("?"))
    r.lines("$G", "G0 X10", "G1 X5", "G1 X5 F100", "G4 P1", "M3 S100", "G2 X1 Y1", "G38.2 Z-1",
            "G0 X1000")
    r.realtime(ord("?"))
    r.line("$C")
    r.wait(0.3)
    r.realtime(ord("?"))
    r.lines("$G", "$X")
    r.group = "jog"
    r.line("$J=G91 X2 F300")
    r.poll_until_idle()
    r.line("$J=X-1 Y1 F600")
    r.poll_until_idle()
    r.lines("$J=G91 G20 X0.05 F10", "$J=X5", "$J=G1 X5 F100", "$J=G91 F100", "$J=M3 X1 F100",
            "$J=G4 P1", "$J=G91 X1 F100 S5", "$J=G53 X0 F300", "$J=X0 Y0 Z0 F-1")
    r.poll_until_idle()
    r.group = "jog cancel"
    r.line("$J=G91 X20 F300")
    r.wait(0.5)
    r.realtime(ord("?"))
    r.realtime(0x85)
    r.poll_until_idle(extra=1)
    r.line("$J=G91 X-1 F300")
    r.wait(0.2)
    r.realtime(ord("!"))
    r.poll_until_idle(extra=1)
    r.realtime(0x85)
    r.poll_until_idle(extra=1)
    r.line("G0 X0 Y0")
    r.poll_until_idle()
    r.group = "settings resets"
    r.lines("$110=700", "G10 L2 P1 X3", "$N0=G21", "$RST=$", "$$", "$#", "$RST=#", "$#", "$N",
            "$RST=*", "$N", "$RST=x", "$RST=")
    r.realtime(0x18)
    r.group = "unknown"
    r.lines("$Z", "$ $", "$HH", "$XX", "$CC", "$SLEEP", "$II", "$GG", "$##", "$NN")
    r.group = "sleep"
    r.line("$SLP")
    r.wait(0.2)
    r.realtime(ord("?"))
    r.line("G0 X1", settle_s=0.3, answered=False)
    r.realtime(0x18)
    r.realtime(ord("?"))
    r.lines("$X")


@session("the G-code GRBL 1.1h accepts: modal groups, coordinate systems, G10, G28/G30, G53, "
         "G92, arcs, dwells, coolant, tool, F/S/N words")
def gcode_accepted(r: Recorder) -> None:
    r.group = "preamble"
    r.lines("G17 G40 G49 G80", "G21 G90 G94", "G18", "G19", "G17", "G20", "G21", "G91", "G90",
            "G93", "G94", "G91.1", "G61", "M8", "M9", "T1", "T255")
    r.group = "program pause"
    r.line("M0 G0", settle_s=0.3, answered=False)  # ok once resumed
    r.realtime(ord("?"))
    r.realtime(ord("~"), settle_s=0.3)
    r.realtime(ord("?"))
    r.lines("M1", "$G")
    r.group = "feed, spindle, line numbers"
    r.lines("F500", "S200", "N10 G0 X0", "N99999 G0 Y0", "M3 S300", "M5", "M4 S100", "M5",
            "G1 F100", "$G")
    r.realtime(ord("?"))
    r.group = "coordinate systems"
    r.lines("G10 L2 P1 X1 Y2 Z3", "G10 L2 P2 X-1", "G10 L2 P0 Y5", "G10 L20 P3 X0 Y0",
            "G10 L2 P6 X1.5", "$#", "G55", "$G", "G56", "G57", "G58", "G59", "G54", "$G")
    r.realtime(ord("?"))
    r.group = "G53 and home positions"
    r.move("G53 G0 X2 Y1")
    r.lines("G28.1", "$#")
    r.move("G53 G0 X0 Y0")
    r.lines("G30.1", "$#")
    r.move("G28")
    r.realtime(ord("?"))
    r.move("G30 X1")
    r.move("G28 G91 X0.5")
    r.line("G90")
    r.realtime(ord("?"))
    r.group = "G92"
    r.lines("G92 X10 Y10", "$#")
    r.realtime(ord("?"))
    r.lines("G92.1", "$#", "G92 X0", "G92.1")
    r.group = "arcs"
    r.move("G0 X0 Y0 Z0")
    r.move("G2 X2 Y0 I1 J0 F300")
    r.move("G3 X0 Y0 R1")
    r.move("G2 X1 Y1 R-1")
    r.move("G17 G2 X0 Y0 I-0.5 J-0.5")
    r.move("G18 G2 X1 Z0 I0.5 K0")
    r.move("G17 G0 X0 Y0 Z0")
    r.group = "dwell"
    r.lines("G4 P0.2", "G4 P0", "G4 P1.5", "G4P0.1")
    r.group = "motion modes"
    r.move("G1 X1 F200")
    r.move("X0")
    r.move("G0 X0.5 Y0.5")
    r.lines("G80", "G0", "G1", "$G")


@session("lines GRBL 1.1h refuses, with their error codes")
def gcode_errors(r: Recorder) -> None:
    r.group = "words and numbers"
    r.lines("G4", "G4 P-1", "F-100", "G0 G1", "G1 X1 P1 F100", "G1 X1 R1 F100", "G0 X1.2.3",
            "G0 X", "X", "G0 X1 X2", "G1 F100 F200", "G5", "M100", "G0 Q1", "@", "G0 X1a",
            "G2 X1 Y1 F100", "G2 X1 F100 R0", "G3 X0 Y0 F100 R1", "G1 X1", "G1", "G4 P1 X1",
            "M3 S-1", "T256", "N-1 G0", "N100000000 G0 X0", "G10 L2 P10 X1", "G10 L3 P1 X1",
            "G10 L2 X1", "G28.2", "G43", "G43.1 Z1 G49", "G38.2 X1", "G1.5 X1", "G0 X1 G92 Y1",
            "G53 G91 G0 X1", "G53 G1 X0", "G91.2", "M7", "M6 T1", "G20 G21", "M3 M5",
            "G2 X1 Y1 I1000000 J0 F100", "G0 X1e3", "G0 X--1", "$J=G0 X1 F100")
    r.group = "feed after G93"
    r.lines("G93", "G1 X1", "G94", "$G")


@session("the 79-character line limit, after spaces and comments are stripped")
def line_length(r: Recorder) -> None:
    body78 = "G0X" + "0" * 73 + "1"  # 77 characters
    r.group = "at the limit"
    r.lines("G4P0." + "0" * 74, "G4P0." + "0" * 75)
    r.lines(body78 + "Y", body78 + "Y0")
    r.group = "spaces and comments do not count"
    spaced = " ".join("G4P0." + "0" * 74)
    r.lines(spaced, "G4 P0 (" + "c" * 90 + ")", "G4 P0 ;" + "c" * 120,
            "G4P0." + "0" * 74 + "(comment)", "(only a comment)", "", " ", ";")
    r.group = "over the limit"
    r.lines("G4P0." + "0" * 76, "G4P0." + "0" * 120, " ".join("G4P0." + "0" * 75),
            "G4P0.0(" + "c" * 10 + ")" + "0" * 75)
    r.realtime(ord("?"))
    r.lines("$G")


@session("homing and soft limits in GRBL's machine space [-travel, 0] (homing enabled at "
         "power-up), the soft-limit alarm, $X and soft resets", eeprom={22: 1})
def soft_limits(r: Recorder) -> None:
    r.group = "locked at power-up"
    r.realtime(ord("?"))
    r.lines("G0 X-1", "$$", "$G", "$#", "$J=G91 X-1 F100", "$SLP")
    r.realtime(0x18)
    r.realtime(ord("?"))
    r.group = "unlocked without homing"
    r.lines("$X", "$20=1")
    r.realtime(ord("?"))
    r.move("G0 X-2")
    r.lines("$20=0")
    r.realtime(0x18)
    r.group = "homing"
    r.line("$H")
    r.realtime(ord("?"))
    r.lines("$#", "$G", "$20=1", "$20=1")
    r.realtime(ord("?"))
    r.group = "inside the machine space"
    r.move("G0 X-10 Y-20")
    r.move("G53 G0 X-199 Y-199 Z-1")
    r.move("G0 X-5 Y-5 Z-1")
    r.move("G0 X0 Y0 Z0")  # machine 0: on the switches (Pn:XYZ)
    r.move("G0 X-1 Y-1 Z-1")
    r.group = "outside: ALARM:2"
    r.line("G0 X10")
    r.wait(0.3)
    critical_alarm(r)
    r.realtime(0x18)
    r.realtime(ord("?"))
    r.lines("G0 X-1", "$X", "$G")
    r.realtime(ord("?"))
    r.group = "work offset"
    r.lines("G10 L2 P1 X-190 Y-190 Z0", "$#")
    r.move("G0 X5 Y5")
    r.move("G1 X185 Y185 F500")
    r.realtime(ord("?"))
    r.line("G0 X200")
    r.wait(0.3)
    critical_alarm(r)
    r.realtime(0x18)
    r.lines("$X", "$#")
    r.move("G0 X5 Y5")
    r.group = "alarm during motion"
    r.line("G53 G0 X-150")
    r.wait(0.4)
    r.line("G53 G0 X-250")
    r.wait(0.2)
    critical_alarm(r)
    r.realtime(0x18)
    r.realtime(ord("?"))
    r.line("$X")
    r.realtime(ord("?"))
    r.group = "jog outside"
    r.lines("$J=G53 X10 F500", "$J=G91 X-500 F500", "$J=G53 X-5 F500")
    r.poll_until_idle()


def critical_alarm(r: Recorder) -> None:
    """After a soft-limit alarm GRBL answers nothing (no report, no line) until a reset."""
    r.realtime(ord("?"), settle_s=0.2, answered=False)
    r.line("$X", settle_s=0.2, answered=False)
    r.line("G0 X-1", settle_s=0.2, answered=False)


@session("a soft reset clears the G92 offset and keeps G54-G59; the spindle speed clamped to "
         "$30 in reports; feed, rapid, spindle and coolant overrides")
def reset_overrides(r: Recorder) -> None:
    r.group = "soft limits need homing"
    r.lines("$20=1", "$21=1", "$21=0")
    r.group = "soft reset clears G92"
    r.lines("G10 L2 P1 X1", "G92 X5 Y5", "G55", "G91", "G20", "M8", "$#", "$G")
    r.realtime(0x18)
    r.lines("$#", "$G")
    r.realtime(ord("?"))
    r.group = "spindle clamp"
    r.line("M3 S5000")
    r.realtime(ord("?"))
    r.lines("$G", "S-1", "S0", "M3 S20")
    r.realtime(ord("?"))
    r.lines("$30=100", "M3 S5000")
    r.realtime(ord("?"))
    r.lines("$31=50", "M3 S10", "$G")
    r.realtime(ord("?"))
    r.lines("M5", "$30=1000", "$31=0")
    r.group = "overrides idle"
    for byte in (0x91, 0x91, 0x93, 0x94, 0x92, 0x96, 0x97, 0x9A, 0x9B, 0x9C, 0xA0, 0xA1):
        r.realtime(byte)
        r.realtime(ord("?"))
    for byte in (0x90, 0x95, 0x99):
        r.realtime(byte)
    r.realtime(ord("?"))
    r.group = "overrides in motion"
    r.line("M3 S500")
    r.line("G1 X10 F300")
    r.wait(0.4)
    r.realtime(ord("?"))
    for byte in (0x91, 0x91, 0x92, 0x97, 0x9A):
        r.realtime(byte)
        r.wait(0.2)
        r.realtime(ord("?"))
    r.realtime(0x90)
    r.realtime(0x99)
    r.poll_until_idle(extra=1)
    r.group = "feed hold and resume"
    r.line("G1 X0 F300")
    r.wait(0.5)
    r.realtime(ord("!"))
    r.realtime(ord("?"))
    r.wait(0.5)
    r.realtime(ord("?"))
    r.realtime(0x9E)
    r.realtime(ord("?"))
    r.realtime(0x9E)
    r.realtime(ord("~"))
    r.poll_until_idle(extra=1)
    r.line("M5")
    r.group = "reset in motion"
    r.line("G1 X5 F300")
    r.wait(0.5)
    r.realtime(0x18)
    r.realtime(ord("?"))
    r.lines("$X", "$#")


@session("status-report fields and their cadence: Ov/A every 20th busy and 10th idle report, "
         "WCO every 30th busy and 10th idle, Bf and Ln under $10 masks")
def report_cadence(r: Recorder) -> None:
    r.group = "idle cadence"
    r.lines("G10 L2 P1 X1 Y1", "M3 S300", "M8")
    for _ in range(24):
        r.realtime(ord("?"))
    r.group = "busy cadence $10=1"
    r.lines("G1 X40 F300", "G1 X0 Y20", "G0 X0 Y0")
    r.poll_until_idle(period_s=0.2, extra=12)
    for mask in (0, 2, 3):
        r.group = f"busy cadence $10={mask}"
        r.lines(f"$10={mask}", "N7 G1 X12 F300", "N8 G1 X0", "N9 G1 Y1")
        r.poll_until_idle(period_s=0.2, extra=3)
    r.group = "line numbers $10=0"
    r.lines("N123 G4 P1.0")
    r.realtime(ord("?"))
    r.lines("$10=1", "M5", "M9")
    r.realtime(ord("?"))


def zigzag() -> list[str]:
    out = ["G21", "G90", "G94", "G0 X10 Y10", "M3 S1000", "G4 P0.15"]
    for i in range(40):
        out.append(f"G1 X{110 if i % 2 == 0 else 10} Y{10 + 2 * (i + 1)} F6000")
    return [*out, "M5", "G4 P0.15", "G0 X0 Y0"]


def inkarm_word() -> list[str]:
    """``inkarm gcode scenarios/word_fix_it.toml`` (the servo pen profile): "fix it"."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "word.gcode"
        cli = Path(sys.executable).with_name("inkarm")
        subprocess.run([str(cli), "gcode", str(ROOT / "scenarios" / "word_fix_it.toml"),
                        "--out", str(out)], check=True, capture_output=True)
        return out.read_text().splitlines()


def gcode_file(name: str) -> Callable[[], list[str]]:
    def read() -> list[str]:
        return (GCODE / name).read_text().splitlines()
    return read


def job_session(name: str, description: str, lines: Callable[[], list[str]],
                settings: dict[int, float]) -> None:
    def run(r: Recorder) -> None:
        if settings:
            r.group = "plotter settings"
            r.lines(*(f"${k}={v}" for k, v in settings.items()))
        r.group = "job"
        r.stream(lines(), settings)
    run.__name__ = name
    session(description)(run)


job_session("job_zigzag", "a zigzag job: 40 G1 strokes of 100 mm at 100 mm/s, with pen "
            "down/up and dwells, on plotter settings (80 steps/mm, 12000 mm/min, 1500 mm/s^2)",
            zigzag, PLOTTER)
job_session("job_word", "an `inkarm gcode` job: scenarios/word_fix_it.toml (\"fix it\", servo "
            "pen profile, 1388 lines) on GRBL's stock settings", inkarm_word, {})
job_session("job_globe", "a vpype-gcode job from a real SVG: tests/data/gcode/globe_65s.gcode "
            "(Feather's globe icon, vpype-gcode's ninja profile) on GRBL's stock settings",
            gcode_file("globe_65s.gcode"), {})


# -- assembly ---------------------------------------------------------------------------------

def assemble(rec: Recorder, log: list[tuple[str, float, str]], name: str) -> dict:
    """Pair every step with the sim time of its last byte and the lines the firmware sent
    after it and before the next step's last byte (in the time log's order; the power-up
    lines go to a step of their own)."""
    received = [row for row in log if row[0] == "R"]
    sent = [(t, text) for kind, t, text in log if kind == "T"]
    if len(received) < len(rec.sim.sent):
        raise RuntimeError(f"{name}: the time log holds {len(received)} received bytes, "
                           f"{len(rec.sim.sent)} were sent")
    lines = rec.sim.lines
    if [text for _, text in sent[:len(lines)]] != lines:
        raise RuntimeError(f"{name}: the time log's lines differ from the port's")
    # which step's window each sent line falls in: count the step ends before it in the log
    ends = {id(received[last]): k for k, (_, _, last) in enumerate(rec.steps)}
    job = (id(received[rec.job["first_byte"]]), id(received[rec.job["line_ends"][-1]])) \
        if rec.job else (None, None)
    windows: list[list[tuple[float, str]]] = [[] for _ in range(len(rec.steps) + 1)]
    job_replies: list[str] = []
    step, in_job, n_lines = 0, False, 0
    for row in log:
        if row[0] == "R":
            if id(row) == job[0]:
                in_job = True
            if id(row) in ends:
                step = ends[id(row)] + 1
                in_job = False
        elif row[0] == "T" and n_lines < len(lines):
            n_lines += 1
            if in_job:  # the job's own replies are in its summary
                job_replies.append(row[2])
            else:
                windows[step].append((row[1], row[2]))
    groups = [{"name": "power-up", "steps": [_step({"power_up": True}, 0.0, windows[0])]}]
    for k, (group, entry, last) in enumerate(rec.steps):
        if groups[-1]["name"] != group:
            groups.append({"name": group, "steps": []})
        groups[-1]["steps"].append(_step(entry, received[last][1], windows[k + 1]))
    out = {"format": "inkarm-grbl-transcript/1", "name": name, "groups": groups}
    if rec.job:
        out["job"] = job_summary(rec.job, [row[1] for row in received], job_replies, log)
    return out


def _step(step: dict, t: float, replies: list[tuple[float, str]]) -> dict:
    out = dict(step)
    out["t"] = round(t, 7)
    out["replies"] = [line for _, line in replies]
    out["reply_t"] = [round(rt, 7) for rt, _ in replies]
    reports = [parse_report(line) for _, line in replies if is_report(line)]
    if reports:
        out["reports"] = reports
    return out


def job_summary(job: dict, received: list[float], replies: list[str], log) -> dict:
    """The job's time from its first line's arrival until the stepper went idle (GRBL flags
    the cycle stop then, after its $1 stepper lock delay), and when every planner block took
    its last step."""
    t0 = received[job["line_ends"][0]]
    ends = [t for kind, t, _ in log if kind == "B" and t >= t0]
    idle = [t for kind, t, _ in log if kind == "I" and t >= t0]
    return {
        "lines": job["lines"], "settings": job["settings"],
        "line_t": [round(received[i] - t0, 7) for i in job["line_ends"]],
        "replies": [line for line in replies if not is_report(line)],
        "first_line_t": round(t0, 7),
        "block_end_s": [round(t - t0, 7) for t in ends],
        "last_step_s": round(ends[-1] - t0, 7) if ends else 0.0,
        "seconds": round(idle[-1] - t0, 7) if idle else 0.0,
    }


def run_session(exe: Path, name: str, speedup: float, home_mm: float) -> dict:
    description, run, eeprom = SESSIONS[name]
    with tempfile.TemporaryDirectory(prefix="grblsim-") as tmp:
        work = Path(tmp)
        # a first run writes GRBL's defaults to a fresh EEPROM (and prints error:7 doing it),
        # then the session's power-up settings; Ctrl-F ends it cleanly (the EEPROM file closed)
        first = Simulator(exe, work, speedup, home_mm)
        first.wait_for(0, lambda x: x.startswith("Grbl "), timeout_s=30)
        for key, value in eeprom.items():
            start = len(first.lines)
            first.send(f"${key}={value}\n".encode("ascii"))
            first.wait_for(start, lambda x: x == "ok")
        first.send(b"\x06")
        first.proc.wait(timeout=30)
        os.close(first.master)
        sim = Simulator(exe, work, speedup, home_mm)
        rec = Recorder(sim)
        try:
            sim.wait_for(0, lambda x: x.startswith("Grbl "), timeout_s=30)
            sim.sleep(0.2)
            run(rec)
        finally:
            log = sim.close()
    transcript = assemble(rec, log, name)
    transcript["description"] = description
    transcript["eeprom"] = {str(key): value for key, value in eeprom.items()}
    return transcript


def read_defaults(exe: Path) -> dict[str, float]:
    """The ``$$`` a fresh EEPROM prints: GRBL's stock defaults."""
    with tempfile.TemporaryDirectory(prefix="grblsim-") as tmp:
        done = subprocess.run([str(exe), "-n", "-s", os.devnull, "-b", os.devnull], cwd=tmp,
                              input=b"", capture_output=True, timeout=60, check=False)
    out: dict[str, float] = {}
    for line in done.stdout.decode("ascii", "replace").splitlines():
        key, eq, value = line.strip().partition("=")
        if key.startswith("$") and eq:
            out[key[1:]] = float(value) if "." in value else int(value)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("exe", type=Path, help="grbl-sim executable (grbl_sim.exe)")
    parser.add_argument("--out", type=Path, default=OUT, help="transcript directory")
    parser.add_argument("--only", nargs="*", default=None, choices=sorted(SESSIONS),
                        help="sessions to record (default: all)")
    parser.add_argument("--speedup", type=float, default=1.0,
                        help="simulated seconds per wall second (default 1)")
    parser.add_argument("--home-distance-mm", type=float, default=5.0,
                        help="carriage distance below the home switches at power-up [mm]")
    args = parser.parse_args(argv)
    if not args.exe.is_file():
        parser.error(f"{args.exe}: no such executable (build grbl-sim first, outside the repo)")
    settings = read_defaults(args.exe)
    args.out.mkdir(parents=True, exist_ok=True)
    for name in SESSIONS:
        if args.only and name not in args.only:
            continue
        t0 = time.monotonic()
        for attempt in range(1, ATTEMPTS + 1):
            try:
                transcript = run_session(args.exe, name, args.speedup, args.home_distance_mm)
                break
            except TimeoutError as error:
                print(f"{name}: attempt {attempt} stalled: {str(error)[:300]}", flush=True)
        else:
            raise SystemExit(f"{name}: stalled {ATTEMPTS} times")
        transcript["settings"] = {**settings, **transcript.pop("eeprom")}
        transcript["provenance"] = {
            "firmware": "GRBL 1.1h (gnea/grbl), stock config.h: DEFAULTS_GENERIC, ATmega328p",
            "grbl_commit": GRBL_COMMIT, "grbl_sim_commit": SIM_COMMIT,
            "harness": list(HARNESS), "home_distance_mm": args.home_distance_mm,
            "speedup": args.speedup,
            "recorded": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d"),
            "times": "simulated machine time [s] since power-up (16 MHz tick counter)"}
        path = args.out / f"{name}.json"
        path.write_text(json.dumps(transcript, indent=1) + "\n")
        n = sum(1 for g in transcript["groups"] for s in g["steps"] if "send" in s)
        job = transcript.get("job")
        extra = f", job {len(job['lines'])} lines {job['seconds']:.3f} s" if job else ""
        print(f"{path.name}: {n} request lines{extra}; {time.monotonic() - t0:.0f} s wall",
              flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
