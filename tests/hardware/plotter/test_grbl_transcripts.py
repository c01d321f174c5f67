"""The emulated GRBL machine against transcripts of the real GRBL 1.1h firmware
(``tests/data/grbl/*.json``: gnea/grbl run by grbl-sim, recorded by
``scripts/record_grbl_transcripts.py``; format and provenance in ``tests/data/grbl/README.md``).

Each transcript is replayed on :class:`~inkarm.hardware.plotter.machine.GrblMachine` from
power-up, event by event in machine time as :mod:`inkarm.hardware.plotter.timing` drives it (no
pseudo-terminal): every step is applied at the machine time the firmware received it, and the
lines the machine sends until the next step are that step's replies. One test per step group,
so a failure names the group and lists every reply that differs.

What must agree:

* every reply line exactly (``ok``, ``error:N``, ``ALARM:N``, ``[MSG:...]``, ``$$``, ``$#``,
  ``$G``, banners), and every status report field by field, in the firmware's order;
* while the firmware reports motion (``Run``, ``Jog``, ``Home``, ``Hold``), the positions
  (``MPos``/``WPos``) within :data:`POSITION_TOL_MM` plus one segment's travel
  (:data:`SEGMENT_S` at the reported feed) and the feed of ``FS`` within
  :data:`FEED_TOL_MM_MIN`, everything else in the report exactly;
* job times (first line to the end of the last planner block) within 1 %, and the end of every
  planner block within 1 % of the job time up to it (:data:`SEGMENT_TOL`);
* where a soft reset stopped a motion, the positions within the travel of
  :data:`START_JITTER_S` (the stepper's start is not reproducible; the evidence is there);
* ``[MSG:Reset to continue]`` with the step the firmware sent it after, or with a neighbouring
  one when it was recorded within :data:`ALARM_MESSAGE_JITTER_S` of that step: grbl-sim's
  0.5 s alarm delay is not reproducible (the evidence is at the constant).

Tolerances: GRBL's position is whole steps (0.004 mm at the stock 250 steps/mm) executed in
segments of 1/100 s (``ACCELERATION_TICKS_PER_SECOND``: ``stepper.c`` prepares each segment at
one step rate, so its position runs up to a segment's travel off a continuous profile), the
report is written when the main loop next looks at its flag, and its feed
(``st_get_realtime_rate``: the speed at the end of the last *prepared* segment) runs up to the
6-segment buffer ahead of the executed motion: at the stock 10 mm/s^2 that is 0.6 mm/s =
36 mm/min. Positions: 0.05 mm (a dozen steps) plus the travel of one segment at the reported
feed; feed: 60 mm/min, the buffer's lead at 10 mm/s^2 with room for one segment more.
"""

from __future__ import annotations

import functools
import inspect
import json
import math
import re
from pathlib import Path

import pytest

from inkarm.hardware.plotter import timing
from inkarm.hardware.plotter.machine import GrblMachine

DATA = Path(__file__).resolve().parents[2] / "data" / "grbl"
TRANSCRIPTS = sorted(DATA.glob("*.json"))
POSITION_TOL_MM = 0.05
SEGMENT_S = 0.01  # GRBL 1.1h config.h ACCELERATION_TICKS_PER_SECOND = 100
FEED_TOL_MM_MIN = 60.0
JOB_TOL = 0.01
SEGMENT_TOL = 0.01
MOVING = ("Run", "Jog", "Home", "Hold")
RX_BUFFER = 128
ALARM_MESSAGE = "[MSG:Reset to continue]"
# GRBL 1.1h report.c report_alarm_message waits delay_ms(500) after ALARM:N before this
# message; grbl-sim's delay loop polls machine time from the firmware's main-loop thread,
# which the host schedules in wall time, so the wait overshoots by a varying amount. The same
# soft_limits session gave 0.520, 0.536 and 0.563 s (the committed recording, its three
# ALARM:2) and 0.647, 0.536, 0.526 s and 0.672, 0.648, 0.526 s when recorded twice more with
# scripts/record_grbl_transcripts.py (2026-11-28); the committed recording alone needs the
# message before 0.5196 s once and after 0.5204 s once, which no fixed delay gives. The
# machine sends it at 0.5 s; it counts as sent with the recorded step when the machine sent
# it with the step before or after and the recorded time is within this of that step [s].
ALARM_MESSAGE_JITTER_S = 0.2
ALARM_ABORT_CYCLE = 3  # ALARM:3, a soft reset while moving
# A motion started from Idle takes its first step when the stepper timer next reaches its
# compare value (stepper.c st_wake_up enables the interrupt on a timer left running since the
# last motion, period at most 65535 cycles of 16 MHz = 4.1 ms), so where a soft reset stops
# it (mc_reset: st_go_idle at once) moves with that phase. Evidence: "G1 X5 F300" reset
# 0.52 s in (reset_overrides, "reset in motion") stopped 2 steps behind the emulator in the
# committed recording and 0 and 3 steps behind in two re-recordings of the same session
# (2026-11-28). The position reports after a reset in motion, until the next motion, may
# differ by the travel of this time at the fastest axis rate ($110-$112) [s].
START_JITTER_S = 65535 / 16e6
TAIL_S = 2.0  # machine time the replay runs on after the last step [s]


def load(path: Path) -> dict:
    return json.loads(path.read_text())


def settings_of(transcript: dict) -> dict[int, float]:
    return {int(key): value for key, value in transcript["settings"].items()}


# -- the replay -------------------------------------------------------------------------------

def realtime(machine: GrblMachine, byte: int, rx_free: int) -> None:
    """A real-time byte as GRBL's serial interrupt hands it over: the machine's own
    ``realtime(byte)`` when it has one, else its named commands."""
    handler = getattr(machine, "realtime", None)
    if callable(handler):
        handler(byte)
        return
    if byte == ord("?"):
        report = machine.status_report(**(
            {"rx_free": rx_free}
            if "rx_free" in inspect.signature(machine.status_report).parameters else {}))
        if report is not None:
            machine.outbox.append(report)
        return
    names = {ord("!"): "feed_hold", ord("~"): "cycle_start", 0x18: "soft_reset",
             0x85: "jog_cancel_byte", 0x9E: "toggle_spindle_stop"}
    if byte in names:
        getattr(machine, names[byte])()
    elif 0x90 <= byte <= 0xA1 and hasattr(machine, "override"):
        machine.override(byte)


class Replay:
    """A machine fed by a transcript's steps, with GRBL's receive buffer of pending lines."""

    def __init__(self, settings: dict[int, float], home_distance_mm: float | None = None):
        # (the recording's limit switches: home_distance_mm from where the carriage powers up)
        self.machine = GrblMachine(settings, home_distance_mm=home_distance_mm)
        self.pending: list[str] = []

    def take_lines(self) -> None:
        m = self.machine
        while self.pending and m.accepts_line():
            m.take_line(self.pending.pop(0))
            m.pump()

    def run_until(self, t: float) -> None:
        """Advance machine time to ``t`` [s], event by event, taking lines as they fit."""
        m = self.machine
        for _ in range(1_000_000):
            self.take_lines()
            m.pump()
            if m.time >= t - 1e-12:
                return
            dt = m.next_event_s()
            dt = 1e-3 if not math.isfinite(dt) or dt <= 0 else dt
            m.advance(min(max(dt, 1e-9), t - m.time))
        raise RuntimeError(f"the machine did not reach t = {t} s")

    def apply(self, step: dict) -> None:
        if "send" in step:
            self.pending.append(step["send"])
            self.take_lines()
        elif "realtime" in step:
            byte = int(step["realtime"], 16)
            rx_free = RX_BUFFER - sum(len(line) + 1 for line in self.pending)
            if byte == 0x18:
                self.pending.clear()
            realtime(self.machine, byte, rx_free)
        self.machine.pump()

    def take_replies(self) -> list[str]:
        out = list(self.machine.outbox)
        self.machine.outbox.clear()
        return out


@functools.cache
def replay(name: str) -> dict[str, list[str]]:
    """Every group's differences (empty when the machine answers as the firmware did)."""
    transcript = load(DATA / f"{name}.json")
    steps = [(group["name"], step) for group in transcript["groups"] for step in group["steps"]]
    if "job" in transcript:  # the job's lines, at the times they arrived (not compared here)
        job = transcript["job"]
        lines = [("", {"send": line, "t": job["first_line_t"] + t, "job": True})
                 for line, t in zip(job["lines"], job["line_t"], strict=True)]
        steps = sorted(steps + lines, key=lambda entry: entry[1]["t"])
    replay = Replay(settings_of(transcript),
                    transcript.get("provenance", {}).get("home_distance_mm"))
    diffs: dict[str, list[str]] = {group["name"]: [] for group in transcript["groups"]}
    answered: list[tuple[str, dict, list[str]]] = []
    for i, (group, step) in enumerate(steps):
        if not step.get("power_up"):
            replay.run_until(step["t"])
            replay.apply(step)
        until = steps[i + 1][1]["t"] if i + 1 < len(steps) else step["t"] + TAIL_S
        try:
            replay.run_until(until)
        except Exception as error:  # noqa: BLE001 - a crash is a difference too
            owner = group or next(g for g, s in steps[i:] if g)  # a job line: the group after
            diffs[owner].append(f"{describe(step)}: the machine raised {error!r}")
            break
        replies = replay.take_replies()
        if not step.get("job"):
            answered.append((group, step, replies))
    shift_alarm_messages(answered)
    settings = settings_of(transcript)
    jitter_mm = START_JITTER_S * max(settings[110], settings[111], settings[112]) / 60.0
    stopped_tol = 0.0  # (after a reset in motion, until the next motion)
    for group, step, replies in answered:
        if f"ALARM:{ALARM_ABORT_CYCLE}" in step["replies"]:
            stopped_tol = jitter_mm
        elif any(r.startswith(("<Run", "<Jog", "<Home")) for r in step["replies"]):
            stopped_tol = 0.0
        diffs[group].extend(compare(step, replies, stopped_tol))
    return diffs


def shift_alarm_messages(answered: list[tuple[str, dict, list[str]]]) -> None:
    """Count :data:`ALARM_MESSAGE` as sent with the step the firmware sent it after when the
    machine sent it with the step before or after, at most :data:`ALARM_MESSAGE_JITTER_S`
    from the recorded time (see :data:`ALARM_MESSAGE_JITTER_S`)."""
    for k, (_, step, got) in enumerate(answered):
        want = step["replies"]
        if ALARM_MESSAGE not in want or ALARM_MESSAGE in got:
            continue
        sent_t = step["reply_t"][want.index(ALARM_MESSAGE)]
        for j in (k - 1, k + 1):
            if not 0 <= j < len(answered):
                continue
            other_step, other = answered[j][1], answered[j][2]
            window = (other_step["t"], answered[j + 1][1]["t"] if j + 1 < len(answered)
                      else math.inf)
            near = window[0] - ALARM_MESSAGE_JITTER_S <= sent_t <= window[1] + \
                ALARM_MESSAGE_JITTER_S
            if near and ALARM_MESSAGE in other and ALARM_MESSAGE not in other_step["replies"]:
                other.remove(ALARM_MESSAGE)
                got.insert(min(want.index(ALARM_MESSAGE), len(got)), ALARM_MESSAGE)
                break


def describe(step: dict) -> str:
    if step.get("power_up"):
        return "power-up"
    what = repr(step["send"]) if "send" in step else f"real-time {step['realtime']}"
    return f"{what} at t={step['t']:.4f} s"


# -- comparing --------------------------------------------------------------------------------

def parse_report(line: str) -> dict | None:
    if not (line.startswith("<") and line.endswith(">")):
        return None
    state, *fields = line[1:-1].split("|")
    out: dict = {"state": state}
    for field in fields:
        name, _, value = field.partition(":")
        out[name] = value
    return out


def numbers(text: str) -> list[float]:
    return [float(v) for v in text.split(",")]


def compare_report(want: str, got: str, stopped_tol_mm: float = 0.0) -> list[str]:
    """Field by field; positions and the feed within tolerance while moving, positions within
    ``stopped_tol_mm`` [mm] where a reset stopped the motion (:data:`START_JITTER_S`)."""
    w, g = parse_report(want), parse_report(got)
    if g is None:
        return [f"expected report {want!r}, got {got!r}"]
    assert w is not None
    if list(w) != list(g) or w["state"] != g["state"]:
        return [f"expected {want!r}, got {got!r} (fields/state differ)"]
    moving = w["state"].split(":")[0] in MOVING
    feed = numbers(w["FS"])[0] if "FS" in w else 0.0  # [mm/min]
    for name in w:
        if w[name] == g[name] or name == "state":
            continue
        if moving and name in ("MPos", "WPos", "FS"):
            a, b = numbers(w[name]), numbers(g[name])
            travel = POSITION_TOL_MM + feed / 60.0 * SEGMENT_S
            tol = [travel] * 3 if name != "FS" else [FEED_TOL_MM_MIN, 0.0]
            if len(a) == len(b) and all(abs(x - y) <= t + 1e-9 for x, y, t in zip(a, b, tol)):
                continue
        if stopped_tol_mm and name in ("MPos", "WPos"):
            a, b = numbers(w[name]), numbers(g[name])
            if len(a) == len(b) and all(abs(x - y) <= stopped_tol_mm + 1e-9
                                        for x, y in zip(a, b)):
                continue
        return [f"expected {want!r}, got {got!r} ({name} differs)"]
    return []


def compare(step: dict, got: list[str], stopped_tol_mm: float = 0.0) -> list[str]:
    want = step["replies"]
    out = []
    for k in range(max(len(want), len(got))):
        w = want[k] if k < len(want) else None
        g = got[k] if k < len(got) else None
        if w is not None and g is not None and w.startswith("<"):
            out += [f"{describe(step)}: reply {k}: {d}"
                    for d in compare_report(w, g, stopped_tol_mm)]
        elif w != g:
            out.append(f"{describe(step)}: reply {k}: expected {w!r}, got {g!r}")
    return out


# -- jobs -------------------------------------------------------------------------------------

WORD = re.compile(r"([A-Z])([-+]?[0-9.]+)")


def block_lines(lines: list[str], settings: dict[int, float]) -> list[int]:
    """The lines that make a GRBL planner block: G0/G1 lines whose target differs from the
    position before by at least one step on an axis (GRBL drops blocks of zero steps)."""
    steps_mm = [settings[100], settings[101], settings[102]]
    position = [0, 0, 0]
    motion, absolute, scale = 0, True, 1.0
    out = []
    for index, raw in enumerate(lines):
        text = re.sub(r"\(.*?\)|;.*", "", raw).replace(" ", "").upper()
        words = WORD.findall(text)
        axes = {}
        for letter, value in words:
            number = float(value)
            if letter == "G":
                if number in (0, 1, 2, 3):
                    motion = int(number)
                elif number in (90, 91):
                    absolute = number == 90
                elif number in (20, 21):
                    scale = 25.4 if number == 20 else 1.0
            elif letter in "XYZ":
                axes["XYZ".index(letter)] = number * scale
        if not axes or motion not in (0, 1) or any(w[0] == "G" and float(w[1]) in (4, 10, 28,
                                                   30, 53, 92) for w in words):
            continue
        target = list(position)
        for axis, mm in axes.items():
            steps = round(mm * steps_mm[axis])
            target[axis] = steps if absolute else position[axis] + steps
        if target != position:
            out.append(index)
            position = target
    return out


def job_names() -> list[str]:
    return [p.stem for p in TRANSCRIPTS if "job" in load(p)]


@functools.cache
def job_schedule(name: str):
    job = load(DATA / f"{name}.json")["job"]
    settings = {**settings_of(load(DATA / f"{name}.json")),
                **{int(k): v for k, v in job["settings"].items()}}
    return job, settings, timing.simulate(job["lines"], settings)


# -- tests ------------------------------------------------------------------------------------

# Groups the emulator does not yet reproduce line for line, each with why (strict: a group
# that starts to pass fails here until it is taken off this list). None at present: all
# 1,987 recorded reply lines agree.
KNOWN_DIFFERENCES: dict[str, str] = {}


def group_cases() -> list:
    cases = []
    for path in TRANSCRIPTS:
        for group in load(path)["groups"]:
            case_id = f"{path.stem}:{group['name']}"
            marks = ([pytest.mark.xfail(reason=KNOWN_DIFFERENCES[case_id], strict=True)]
                     if case_id in KNOWN_DIFFERENCES else [])
            cases.append(pytest.param(path.stem, group["name"], id=case_id, marks=marks))
    return cases


def test_the_transcripts_are_there_and_well_formed():
    assert len(TRANSCRIPTS) >= 6, f"expected the GRBL transcripts in {DATA}"
    lines = 0
    for path in TRANSCRIPTS:
        transcript = load(path)
        assert transcript["format"] == "inkarm-grbl-transcript/1", path.name
        assert transcript["provenance"]["grbl_commit"].startswith("bfb67f0"), path.name
        times = [s["t"] for g in transcript["groups"] for s in g["steps"]]
        assert times == sorted(times), f"{path.name}: steps out of time order"
        lines += sum("send" in s for g in transcript["groups"] for s in g["steps"])
    assert lines >= 120


@pytest.mark.parametrize(("name", "group"), group_cases())
def test_replies_as_grbl(name, group):
    diffs = replay(name)[group]
    assert not diffs, f"{len(diffs)} replies differ from GRBL 1.1h:\n" + "\n".join(diffs[:40])


@pytest.mark.parametrize("name", job_names())
def test_job_time_as_grbl(name):
    job, _, schedule = job_schedule(name)
    ratio = schedule.seconds / job["seconds"]
    assert abs(ratio - 1) <= JOB_TOL, (
        f"{name}: emulator {schedule.seconds:.3f} s, GRBL {job['seconds']:.3f} s "
        f"(ratio {ratio:.4f}, expected within {JOB_TOL:.0%})")


@pytest.mark.parametrize("name", job_names())
def test_job_block_ends_as_grbl(name):
    job, settings, schedule = job_schedule(name)
    lines = block_lines(job["lines"], settings)
    assert len(lines) == len(job["block_end_s"]), (
        f"{name}: {len(lines)} moving G0/G1 lines, GRBL planned {len(job['block_end_s'])} blocks")
    bad = []
    for index, want in zip(lines, job["block_end_s"], strict=True):
        got = float(schedule.line_end_s[index])
        if abs(got - want) > SEGMENT_TOL * want + 1e-3:
            bad.append(f"line {index + 1} {job['lines'][index]!r}: ends at {got:.4f} s, "
                       f"GRBL {want:.4f} s")
    assert not bad, f"{len(bad)} of {len(lines)} blocks end late or early:\n" + "\n".join(
        bad[:30])


@pytest.mark.parametrize("name", job_names())
def test_job_replies_as_grbl(name):
    transcript = load(DATA / f"{name}.json")
    job = transcript["job"]
    refused = [r for r in job["replies"] if r.startswith(("error:", "ALARM:"))]
    assert not refused, f"{name}: GRBL refused job lines: {refused}"
    replay = Replay({**settings_of(transcript), **{int(k): v for k, v in job["settings"].items()}})
    replay.take_replies()
    replies: list[str] = []
    for line in job["lines"]:
        replay.pending.append(line)
        while replay.pending:
            replay.take_lines()
            replay.machine.advance(max(min(replay.machine.next_event_s(), 1.0), 1e-6))
            replay.machine.pump()
        replies += [r for r in replay.take_replies() if not r.startswith("<")]
    for _ in range(100_000):  # the last lines' replies (a dwell's comes when it ends)
        if replay.machine.idle:
            break
        replay.machine.advance(max(min(replay.machine.next_event_s(), 1.0), 1e-6))
        replay.machine.pump()
    replies += [r for r in replay.take_replies() if not r.startswith("<")]
    assert replies == job["replies"], (
        f"{name}: {sum(a != b for a, b in zip(replies, job['replies']))} replies differ, "
        f"{len(replies)} replies against GRBL's {len(job['replies'])}")
