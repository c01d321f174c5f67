"""Third-party GRBL senders from the package index stream a real vpype-gcode job
(tests/data/gcode, vpype-gcode's ``ninja`` profile: ``G21 G17 G90 G28`` preamble) through the
emulator, driven as their own documentation tells a user to drive them.

* grbl-streamer 2.0.x (``gerbil``, GPL; a test dependency only, never imported by inkarm): on
  the boot banner it sends ``$$``, then its poll thread sends ``$#`` and ``$G`` and ``?`` every
  0.2 s; any ``error`` reply (also to its own ``$#``) halts the job. Its preprocessor
  (gcode-machine) comments out commands not on its whitelist and removes spaces and pads
  numbers (``G01X70.0000Y40.0000F10000``, ``M02``): GRBL takes such words as they are.
* pygrbl-streamer 1.0.x (MIT): soft reset, waits for the ``Grbl`` banner, ``$X``, then streams
  by character counting against GRBL's 128-byte receive buffer (blank lines and comments
  stripped), no ``?`` while streaming, then polls ``?`` until ``Idle``.

Each run asserts what a user with a real plotter would need: 0 errors seen by the sender and by
the emulator, every line the sender wrote answered ``ok``, no byte dropped by the receive buffer,
and the machine (as the emulator holds it and as the sender's last status report shows it)
idle at the job's last target.
"""

from __future__ import annotations

import re
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from inkarm.hardware.plotter.emulator import EmulatorConfig, GrblEmulator

pytestmark = pytest.mark.hardware_emulated

DATA = Path(__file__).resolve().parents[2] / "data" / "gcode"
QUICK_JOB = DATA / "compass_quick.gcode"  # 183 lines
LONG_JOB = DATA / "icons_tiled_5k.gcode"  # 5,081 lines
SPEEDUP = 1000.0  # machine seconds per wall second (the emulator's largest)
WORD = re.compile(r"([A-Z])\s*([-+]?\d*\.?\d+)")


def job_lines(path: Path) -> list[str]:
    """The job's lines as a sender sends them: stripped, blank lines left out."""
    return [line.strip() for line in path.read_text().splitlines() if line.strip()]


def last_target(lines: list[str]) -> np.ndarray:
    """Where an absolute-mode (G90) job ends [mm]: the last X, Y, Z words, a bare ``G28`` going
    to the stored G28 position (zero at power-up, GRBL 1.1 ``settings_read_coord_data``)."""
    target = np.zeros(3)
    for line in lines:
        words = WORD.findall(line.upper())
        axes = {w: float(v) for w, v in words if w in "XYZ"}
        if ("G", 28.0) in [(w, float(v)) for w, v in words] and not axes:
            target[:] = 0.0
        for i, axis in enumerate("XYZ"):
            if axis in axes:
                target[i] = axes[axis]
    return target


def report_position(report: str) -> np.ndarray:
    """The work position [mm] in a GRBL 1.1 status report (``WPos``, or ``MPos - WCO``)."""
    fields = dict(f.split(":", 1) for f in report.strip("<>").split("|")[1:] if ":" in f)
    if "WPos" in fields:
        return np.array([float(v) for v in fields["WPos"].split(",")])
    wco = fields.get("WCO", "0,0,0")
    return (np.array([float(v) for v in fields["MPos"].split(",")])
            - np.array([float(v) for v in wco.split(",")]))


def wait_for(condition: Callable[[], bool], timeout_s: float,
             what: str | Callable[[], str]) -> None:
    end = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > end:
            pytest.fail(f"timed out after {timeout_s} s waiting for "
                        f"{what() if callable(what) else what}")
        time.sleep(0.02)


@pytest.fixture
def emulator():
    emu = GrblEmulator(EmulatorConfig(speedup=SPEEDUP))
    emu.start()
    yield emu
    emu.stop()


def assert_emulator_clean(emu: GrblEmulator, lines_written: int, target: np.ndarray) -> None:
    """Every written line taken (``lines_written`` in all) and answered ``ok``, no error, no
    byte lost, idle at target."""
    assert emu.wait_idle(timeout_s=10.0), "the emulator never became idle"
    replies = list(emu.stats.replies)
    errors = [r for r in replies if r.startswith(("error", "ALARM"))]
    assert errors == [], f"the emulator answered {errors[:5]}"
    assert emu.stats.bytes_dropped == 0
    assert emu.stats.lines == lines_written
    assert replies.count("ok") == lines_written
    assert emu.machine.position == pytest.approx(target, abs=1e-3)


# -- grbl-streamer (gerbil) ------------------------------------------------------------------


def run_grbl_streamer(emu: GrblEmulator, job: Path) -> None:
    grbl_streamer = pytest.importorskip(
        "grbl_streamer", reason="grbl-streamer is not installed (pip install -e '.[test]')")
    lock = threading.Lock()
    events: list[tuple[str, tuple]] = []

    def callback(event: str, *data) -> None:  # the module's documented callback signature
        with lock:
            events.append((event, data))

    def seen(name: str) -> list[tuple]:
        with lock:
            return [d for e, d in events if e == name]

    def written() -> list[str]:  # lines through its buffer-managed writer (not ? or 0x18)
        return [d[0] for d in seen("on_write")]

    def answered() -> int:
        return sum(1 for r in list(emu.stats.replies) if r == "ok" or r.startswith("error"))

    def since_boot() -> list[str]:
        with lock:
            boots = [i for i, (e, _) in enumerate(events) if e == "on_boot"]
            return [d[0] for e, d in events[boots[-1]:] if e == "on_write"] if boots else []

    def settled() -> bool:
        # Booted, and what it sends on its own after the (last) banner -- $$, then $# and $G
        # from its poll thread, $G again when the first report changes its state -- sent and
        # answered, so that no stray 'ok' counts against the job's receive-buffer accounting.
        # (It answers each banner with $$: the emulator's power-up banner and the one after its
        # 0x18 may both reach it, and a line that reaches GRBL with the 0x18 is flushed by the
        # reset, unanswered, as GRBL 1.1 does: the lines are counted from the job on.)
        return ({"$$\n", "$#\n", "$G\n"} <= set(since_boot())
                and emu.stats.lines == answered() and emu.wait_idle(timeout_s=0.05)
                and not grbl.hash_state_requested and not grbl.gcode_parser_state_requested
                and grbl.cmode == "Idle")

    def quiet() -> bool:  # settled, and nothing more written two poll intervals later
        if not settled():
            return False
        count = len(written())
        time.sleep(2.5 * grbl.poll_interval)
        return settled() and len(written()) == count

    grbl = grbl_streamer.GrblStreamer(callback, name="test")
    grbl.setup_logging()
    grbl.cnect(emu.port, 115200)
    try:
        wait_for(lambda: bool(seen("on_boot")), 10.0, "grbl-streamer to see GRBL's banner")
        grbl.poll_start()  # (a no-op before the banner: it polls only once connected)
        wait_for(lambda: quiet() or bool(seen("on_error")), 10.0,
                 lambda: f"grbl-streamer's boot handshake ({written()}; the emulator took "
                         f"{emu.stats.lines} lines, answered {answered()})")
        assert seen("on_error") == [], (
            f"grbl-streamer got {seen('on_error')} in its handshake {written()}; the emulator "
            f"answered {list(emu.stats.replies)[-8:]}")
        taken_before, written_before = emu.stats.lines, len(written())
        lines = job_lines(job)
        target = last_target(lines)
        grbl.load_file(str(job))
        grbl.job_run()
        wait_for(lambda: grbl.job_finished or bool(seen("on_error")), 120.0,
                 lambda: f"grbl-streamer to finish the job ({len(seen('on_processed_command'))}"
                         f" of {grbl.buffer_size} lines confirmed)")
        assert seen("on_error") == [] and seen("on_alarm") == []
        # every buffered line was sent and confirmed by an 'ok'
        assert grbl.buffer_size >= len(lines)
        assert len(seen("on_processed_command")) == grbl.buffer_size
        wait_for(lambda: grbl.cmode == "Idle" and np.allclose(grbl.cmpos, target, atol=1e-3),
                 10.0, lambda: f"grbl-streamer to report Idle at {target} (it shows "
                               f"{grbl.cmode} {grbl.cmpos})")
        grbl.poll_stop()  # (joins its poll thread: it writes nothing more on its own)
        wait_for(lambda: emu.stats.lines - taken_before == len(written()) - written_before,
                 5.0, "the emulator to take every line grbl-streamer wrote")
        assert len(written()) - written_before >= grbl.buffer_size
        assert_emulator_clean(emu, taken_before + len(written()) - written_before, target)
    finally:
        grbl.disconnect()


def test_grbl_streamer_streams_a_vpype_job(emulator):
    run_grbl_streamer(emulator, QUICK_JOB)


@pytest.mark.slow
def test_grbl_streamer_streams_a_5000_line_vpype_job(emulator):
    run_grbl_streamer(emulator, LONG_JOB)


# -- pygrbl-streamer ---------------------------------------------------------------------------


def run_pygrbl_streamer(emu: GrblEmulator, job: Path) -> None:
    pygrbl_streamer = pytest.importorskip(
        "pygrbl_streamer", reason="pygrbl-streamer is not installed (pip install -e '.[test]')")
    errors: list[str] = []
    alarms: list[str] = []

    class Streamer(pygrbl_streamer.GrblStreamer):  # callbacks as its docstring says: override
        def error_callback(self, line: str) -> None:
            errors.append(line)

        def alarm_callback(self, line: str) -> None:
            alarms.append(line)

        def progress_callback(self, percent: int, command: str) -> None:
            if (percent, command) == (100, "completed"):
                completed.set()

    completed = threading.Event()
    lines = job_lines(job)
    target = last_target(lines)
    with Streamer(emu.port) as g:  # connects: soft reset, waits for the banner, $X
        done = g.send_file(str(job), stop_on_error=True, ack_timeout=30, completion_timeout=60)
        status = g.last_status.get("raw", "")
        # Its callbacks run on their own thread, in order, and disconnecting drops those not
        # yet run: wait for the last one (the 100 % 'completed' event, or the errors). (It
        # drops raw-traffic and progress events when its queue of 500 is full, never errors
        # or alarms: what it wrote is counted on the emulator's side.)
        end = time.monotonic() + 5.0
        while not completed.is_set() and time.monotonic() < end and not (errors or alarms):
            time.sleep(0.02)
        time.sleep(0.1)
    assert errors == [] and alarms == [], (
        f"pygrbl-streamer got {errors or alarms}; the emulator answered "
        f"{list(emu.stats.replies)[-4:]} to {emu.stats.lines} lines")
    assert done, f"send_file() did not complete (last status {status!r})"
    assert status.startswith("<Idle"), status
    assert report_position(status) == pytest.approx(target, abs=1e-3)
    assert_emulator_clean(emu, 1 + len(lines), target)  # $X on connecting, then the job


def test_pygrbl_streamer_streams_a_vpype_job(emulator):
    run_pygrbl_streamer(emulator, QUICK_JOB)


@pytest.mark.slow
def test_pygrbl_streamer_streams_a_5000_line_vpype_job(emulator):
    run_pygrbl_streamer(emulator, LONG_JOB)


# -- the oracles themselves --------------------------------------------------------------------


def test_the_jobs_are_the_committed_vpype_jobs():
    quick, long = job_lines(QUICK_JOB), job_lines(LONG_JOB)
    assert len(quick) == 182 and len(long) == 5080  # (one blank line each left out)
    for lines in (quick, long):
        assert lines[:4] == ["G21", "G17", "G90", "G28"]  # vpype-gcode's ninja preamble
        assert lines[-3:] == ["G1 Z0 F1000", "G1 X0 Y0 F1000", "M2"]
        assert last_target(lines) == pytest.approx([0.0, 0.0, 0.0])


def test_last_target_follows_words_and_a_bare_g28():
    assert last_target(["G1 X5 Y6 Z1", "G1X7"]) == pytest.approx([7, 6, 1])
    assert last_target(["G1 X5 Y6 Z1", "G90 G28"]) == pytest.approx([0, 0, 0])
    assert last_target(["G1 X5 Y6 Z1", "G28 G90"]) == pytest.approx([0, 0, 0])
    assert last_target(["G1 X5 Y6", "G1 Z-1.5"]) == pytest.approx([5, 6, -1.5])


def test_report_position_reads_wpos_or_mpos_less_wco():
    assert report_position("<Idle|WPos:1.000,2.000,3.000|FS:0,0>") == pytest.approx([1, 2, 3])
    assert report_position("<Idle|MPos:5.000,5.000,0.000|FS:0,0|WCO:1.000,2.000,0.000>") \
        == pytest.approx([4, 3, 0])
    assert report_position("<Run|MPos:5.000,6.000,7.000|Bf:15,128>") == pytest.approx([5, 6, 7])
