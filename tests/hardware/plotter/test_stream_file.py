"""``inkarm stream FILE.gcode``: a G-code file made elsewhere streamed to the GRBL emulator (in
this process, on a pseudo-terminal), checked before any motion byte, stopped safely.

Oracles: the emulator's own counts (every line of the file taken, in order, no byte dropped by
its 128-byte receive buffer), its machine clock (the job's machine time against the planner's
estimate: machine seconds, so the host's load does not count), the lines it received (none
that moves before a refusal; the pen-up line after a stop) and its pen.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from inkarm.cli import main
from inkarm.hardware.plotter.emulator import EmulatorConfig, Fault, GrblEmulator
from inkarm.hardware.plotter.file_stream import Progress, clock_text, progress_line, stream_file
from inkarm.hardware.plotter.gcode_file import read_gcode_file
from inkarm.hardware.plotter.profiles import load_profile

DATA = Path(__file__).resolve().parents[2] / "data" / "gcode"
QUICK_JOB = DATA / "compass_quick.gcode"  # 183 lines, vpype-gcode (ninja profile)
LONG_JOB = DATA / "icons_tiled_5k.gcode"  # 5,081 lines, vpype-gcode (ninja profile)
# GRBL 1.1h's stock rates and accelerations on X and Y (500 mm/min, 10 mm/s^2): the planner
# keeps 15 blocks of about 60 ms each, so the link keeps it fed at these speed-ups (machine
# seconds per wall second): at 100x a stall of the host of 10 ms starves it; the timed runs
# go slower
SPEEDUP = 100.0
TIMED_SPEEDUP = 25.0
STOCK_XY = ((110, 500.0), (111, 500.0), (120, 10.0), (121, 10.0))
# What `stream` sends before the job on a machine without homing: $$, $# (read), $$, G10 L2 P1,
# G54, $# (workspace.set_up)
SETUP_LINES = 6
PEN_UP = load_profile(None).pen_lines(False)  # the servo profile's: M5 and its dwell
MOVES = re.compile(r"^\s*(G0*[0123]\b|[XYZ])|[^A-Z][XYZ]-?[\d.]", re.IGNORECASE)


class Recorded:
    """An emulator whose machine records every line it takes, with the machine time."""

    def __init__(self, settings=STOCK_XY, faults=(), speedup=SPEEDUP):
        self.emu = GrblEmulator(EmulatorConfig(speedup=speedup, settings=tuple(settings)),
                                faults=faults)
        self.taken: list[tuple[float, str]] = []
        machine = self.emu.machine
        take = machine.take_line

        def recording(raw: str) -> None:
            self.taken.append((machine.time, raw))
            take(raw)

        machine.take_line = recording

    def __enter__(self):
        self.emu.start()
        return self

    def __exit__(self, *exc):
        self.emu.stop()

    @property
    def lines(self) -> list[str]:
        return [text for _, text in self.taken]


def stream_cli(emu: GrblEmulator, path: Path, *more: str) -> int:
    return main(["stream", str(path), "--port", emu.port, "--time-scale",
                 str(emu.config.speedup), *more])


def assert_streamed_whole(rec: Recorded, path: Path, capsys) -> tuple[float, float]:
    """Every line of the file taken in order, no byte lost, every line answered ok; returns
    (the job's machine time [s], the printed estimate [s])."""
    emu, job = rec.emu, read_gcode_file(path)
    assert emu.wait_idle(timeout_s=10.0)
    assert emu.stats.bytes_dropped == 0
    assert emu.stats.lines == SETUP_LINES + len(job.lines)
    assert rec.lines[SETUP_LINES:] == list(job.lines)
    replies = list(emu.stats.replies)
    assert [r for r in replies if r.startswith(("error", "ALARM"))] == []
    assert replies.count("ok") == emu.stats.lines
    out = capsys.readouterr().out
    assert f"{len(job.lines)} lines, {job.bytes} bytes" in out
    estimate = float(re.search(r"estimated ([\d.]+) s \(", out).group(1))
    assert re.search(r"done: \d+ lines, \d+ bytes in [\d.]+ s \(estimated", out)
    machine_s = emu.stats.idle_since_s - rec.taken[SETUP_LINES][0]
    return machine_s, estimate


@pytest.mark.hardware_emulated
def test_a_vpype_job_streams_whole_in_the_planners_time(capsys):
    with Recorded(speedup=TIMED_SPEEDUP) as rec:
        assert stream_cli(rec.emu, QUICK_JOB, "--quiet") == 0
        machine_s, estimate = assert_streamed_whole(rec, QUICK_JOB, capsys)
    assert machine_s == pytest.approx(estimate, rel=0.02)


@pytest.mark.slow
@pytest.mark.hardware_emulated
def test_a_5000_line_vpype_job_streams_with_no_byte_lost_within_2_percent(capsys):
    """The issue's bar: 5,080 lines of vpype-gcode, 0 bytes lost, the machine time within 2 %
    of the planner's estimate (about 730 machine seconds, 15 s of wall time)."""
    assert len(read_gcode_file(LONG_JOB).lines) >= 5000
    with Recorded(speedup=2 * TIMED_SPEEDUP) as rec:
        assert stream_cli(rec.emu, LONG_JOB, "--quiet") == 0
        machine_s, estimate = assert_streamed_whole(rec, LONG_JOB, capsys)
    assert machine_s == pytest.approx(estimate, rel=0.02)
    assert estimate > 600


def first_line_beyond(path: Path, axis: str, limit: float) -> tuple[int, float]:
    """The first line of an absolute-mode file whose ``axis`` word exceeds ``limit``."""
    for number, line in enumerate(path.read_text().splitlines(), start=1):
        m = re.search(rf"{axis}(-?[\d.]+)", line)
        if m and float(m.group(1)) > limit:
            return number, float(m.group(1))
    raise AssertionError("no such line")


@pytest.mark.hardware_emulated
def test_a_move_outside_the_travel_is_refused_before_anything_moves(capsys):
    number, x = first_line_beyond(LONG_JOB, "X", 150.0)
    with Recorded(settings=(*STOCK_XY, (130, 150.0))) as rec:
        assert stream_cli(rec.emu, LONG_JOB) == 2
        err = capsys.readouterr().err
        assert f"{LONG_JOB}: line {number}: " in err
        assert f"X {x:.3f}" in err and "X 0 to 150 mm ($130)" in err
        assert not [line for line in rec.lines if MOVES.search(line)
                    and not line.startswith(("$", "G10"))], rec.lines
        assert rec.emu.machine.position.tolist() == [0.0, 0.0, 0.0]


@pytest.mark.hardware_emulated
def test_a_homed_machine_refuses_the_z_of_a_file_above_machine_zero(capsys):
    """With homing and soft limits ($22=1, $20=1) GRBL's space is [-travel, 0] on every axis:
    vpype-gcode's ninja profile lifts to Z 3 and 6 above G54's Z 0, an ALARM:2 on the device:
    refused before homing."""
    number, z = first_line_beyond(QUICK_JOB, "Z", 0.0)
    with Recorded(settings=(*STOCK_XY, (22, 1), (20, 1))) as rec:
        assert stream_cli(rec.emu, QUICK_JOB) == 2
        err = capsys.readouterr().err
    assert f"line {number}: " in err and f"Z {z:.3f}" in err and "($132)" in err
    assert "$H" not in rec.lines


def servo_job(tmp_path: Path, strokes: int = 40) -> Path:
    """A job for a servo pen (M3 S1000 down, M5 up), one short stroke after another."""
    lines = ["; a servo-pen job", "G21 G90 G94", "M5"]
    for k in range(strokes):
        y = 10.0 + k
        lines += [f"G0 X10 Y{y:g}", "M3 S1000", "G4 P0.15"]
        lines += [f"G1 X{10 + 2 * j:g} Y{y:g} F1200" for j in range(1, 8)]
        lines += ["M5", "G4 P0.15"]
    path = tmp_path / "servo.gcode"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.hardware_emulated
@pytest.mark.parametrize("kind, code, answer", [("error", 20, "error:20"),
                                                ("alarm", 1, "ALARM:1")])
def test_an_error_or_alarm_mid_file_stops_names_the_line_and_lifts_the_pen(
        tmp_path, capsys, kind, code, answer):
    path = servo_job(tmp_path)
    job = read_gcode_file(path)
    k = next(i for i, line in enumerate(job.lines)
             if i > 100 and line.startswith("G1") and job.lines[i - 2].startswith("G1"))
    with Recorded(faults=[Fault(kind, SETUP_LINES + k + 1, code)]) as rec:
        touching = []
        machine = rec.emu.machine
        take = machine.take_line

        def watch(raw):  # the pen is down when the faulty line arrives
            touching.append(machine.pen_touching)
            take(raw)

        machine.take_line = watch
        assert stream_cli(rec.emu, path, "--quiet") == 1
        err = capsys.readouterr().err
        assert rec.emu.wait_idle(5.0)
        assert not machine.pen_touching
        assert rec.lines[-len(PEN_UP):] == PEN_UP  # after the reset
    assert touching[SETUP_LINES + k - 1]
    assert f"{path}: line {job.numbers[k]}: " in err and answer in err
    assert "pen up" in err


@pytest.mark.hardware_emulated
def test_ctrl_c_holds_resets_and_lifts_the_pen(tmp_path, monkeypatch, capsys):
    import inkarm.commands.stream as command

    path = servo_job(tmp_path)

    def interrupt(self, p: Progress) -> None:
        if p.acked > 150:
            raise KeyboardInterrupt

    monkeypatch.setattr(command.ProgressPrinter, "__call__", interrupt)
    with Recorded() as rec:
        assert stream_cli(rec.emu, path) == 130
        assert rec.emu.wait_idle(5.0)
        assert not rec.emu.machine.pen_touching
        assert rec.lines[-len(PEN_UP) - 1:] == ["$X", *PEN_UP]
        taken = len(rec.lines)
    assert taken < SETUP_LINES + len(read_gcode_file(path).lines)
    assert "interrupted at line" in capsys.readouterr().err


@pytest.mark.hardware_emulated
def test_the_library_call_reports_lines_bytes_and_times(tmp_path):
    path = servo_job(tmp_path, strokes=3)
    seen: list[Progress] = []
    with Recorded(speedup=TIMED_SPEEDUP) as rec:  # (wall time: each M3/M5/G4 a round trip)
        report = stream_file(path, rec.emu.port, time_scale=TIMED_SPEEDUP,
                             progress=seen.append)
    job = read_gcode_file(path)
    assert report.ok and report.lines == len(job.lines) == report.acked
    assert report.bytes == job.bytes == sum(len(line) + 1 for line in job.lines)
    assert report.measured_s == pytest.approx(report.estimate_s, rel=0.05)
    assert [p.acked for p in seen] == sorted(p.acked for p in seen)
    assert seen[-1].acked == seen[-1].total and seen[-1].remaining_s == 0.0


# -- refused before the port is opened ---------------------------------------------------------


@pytest.mark.parametrize("text, expected", [
    ("G21\nG1 X5 Y5 F100 Q3\n", "line 2: GRBL 1.1h refuses 'G1 X5 Y5 F100 Q3': error:20"),
    ("G21\n\nG1 X1." + "0" * 80 + " F100\n", "line 3: 89 characters"),
    ("G21\nG1 X1 (" + "c" * 140 + ")\nG1 X" + "1" * 130 + "\n", "line 3: 133 characters"),
    ("G21\n$H\nG0 X1\n", "line 2: '$H' is a GRBL system command"),
    ("Hello, this is not G-code.\n", "line 1: GRBL 1.1h refuses"),
    ("G21\nG0 X1\n\x89PNG\n", "line 3: byte 0x89 is not G-code text"),
    ("; only a comment\n\n%\n", "no G-code line in it"),
    ("G21\nG1 X10\n", "line 2: GRBL 1.1h refuses 'G1 X10': error:22"),
])
def test_bad_files_are_refused_naming_the_file_and_line(tmp_path, capsys, text, expected):
    path = tmp_path / "job.gcode"
    path.write_bytes(text.encode("latin-1"))
    assert main(["stream", str(path), "--port", str(tmp_path / "no-port")]) == 2
    err = capsys.readouterr().err
    assert f"{path}: " in err and expected in err, err
    assert "cannot open" not in err  # (refused before the port)


def test_a_missing_file_is_refused(tmp_path, capsys):
    assert main(["stream", str(tmp_path / "none.gcode"), "--port", "x"]) == 2
    assert "none.gcode: no such file" in capsys.readouterr().err


def test_comments_blank_lines_and_tape_markers_are_not_sent(tmp_path):
    path = tmp_path / "job.gcode"
    path.write_text("%\n(header)\nG21 ; mm\n\n  G0 X1 (go) Y2  \n%\n")
    job = read_gcode_file(path)
    assert job.lines == ("G21", "G0 X1  Y2") and job.numbers == (3, 5)
    assert job.drawing == (False, False)


def test_progress_text():
    p = Progress(acked=1234, total=5080, elapsed_s=192.4, remaining_s=3601.0, estimate_s=4000)
    assert progress_line(p) == ("1234/5080 lines   24.3 %  elapsed 3:12  remaining "
                                "1:00:01")
    assert clock_text(59.6) == "1:00" and clock_text(-1) == "0:00"


@pytest.mark.hardware_emulated
def test_a_machine_with_homing_is_homed_and_draws_from_the_travels_corner(tmp_path, capsys):
    path = servo_job(tmp_path, strokes=2)
    with Recorded(settings=(*STOCK_XY, (22, 1), (20, 1))) as rec:
        assert stream_cli(rec.emu, path, "--quiet") == 0
        assert rec.emu.wait_idle(5.0)
        assert rec.lines[:6] == ["$$", "$#", "$$", "$H", "G10 L2 P1 X-300.000 Y-300.000",
                                 "G54"]
        # the last move, G1 X24 Y11, from the page origin at machine (-300, -300)
        assert rec.emu.machine.position[:2].tolist() == pytest.approx([-276.0, -289.0])
    assert "page origin at machine (-300, -300) mm, homed" in capsys.readouterr().out


@pytest.mark.parametrize("tty", [True, False])
def test_progress_is_one_updating_line_on_a_terminal_and_sparse_lines_elsewhere(tty):
    import io

    from inkarm.commands.stream import ProgressPrinter

    class Stream(io.StringIO):
        def isatty(self) -> bool:
            return tty

    stream = Stream()
    printer = ProgressPrinter(stream)
    printer._clock = iter(range(10_000)).__next__  # one second between calls
    for acked in range(1001):
        printer(Progress(acked, 1000, acked * 0.1, 100 - acked * 0.1, 100.0))
    printer.end()
    text = stream.getvalue()
    if tty:
        assert text.count("\n") == 1 and text.count("\r") == 1001
        assert text.rstrip().endswith("1000/1000 lines  100.0 %  elapsed 1:40  remaining "
                                      "0:00\x1b[K")
    else:
        assert "\r" not in text and len(text.splitlines()) == 11  # 0 %, 10 %, ..., 100 %


@pytest.mark.hardware_emulated
def test_a_disconnect_mid_file_exits_1_naming_the_line(tmp_path, capsys):
    path = servo_job(tmp_path, strokes=10)
    job = read_gcode_file(path)
    with Recorded(faults=[Fault("disconnect", SETUP_LINES + 50)]) as rec:
        assert stream_cli(rec.emu, path, "--quiet") == 1
    err = capsys.readouterr().err
    acked = int(re.search(r"; (\d+) of 122 lines answered ok", err).group(1))
    assert acked < 50  # the 50th line never reached the machine
    # named: the oldest line not answered (the first not known to be done)
    assert f"{path}: line {job.numbers[acked]}: the plotter stopped: the device " \
        "disconnected" in err, err
    assert "nothing more could be sent" in err


def test_an_svg_given_as_g_code_is_named_for_what_it_is(tmp_path):
    svg = tmp_path / "drawing.svg"
    svg.write_text('<?xml version="1.0"?>\n<svg xmlns="http://www.w3.org/2000/svg"/>\n')
    with pytest.raises(Exception, match=r"XML \(an SVG\?\), not G-code.*inkarm gcode"):
        read_gcode_file(svg)
