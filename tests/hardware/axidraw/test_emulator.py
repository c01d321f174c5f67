"""The AxiDraw (EBB firmware 3.0.3) emulator on a pseudo-terminal, driven through pyserial:
replies, the FIFO seen from the host, faults, ink, and ``inkarm emulate axidraw``."""

import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import serial

from inkarm.analysis.metrics import ink_chamfer_mm
from inkarm.errors import InputError
from inkarm.hardware.axidraw.emulator import EbbEmulator, Fault, fault_reply, parse_fault
from inkarm.hardware.axidraw.geometry import STEPS_PER_MM
from inkarm.ink.canvas import Canvas

pytestmark = pytest.mark.hardware_emulated


class Host:
    """A pyserial client that reads whole replies (up to OK, or one line for V/QG/QM)."""

    def __init__(self, port: str):
        self.s = serial.Serial(port, timeout=5)

    def ask(self, command: str, until: bytes = b"OK\r\n") -> bytes:
        self.s.write(command.encode("ascii") + b"\r")
        return self.s.read_until(until)

    def close(self):
        self.s.close()


@pytest.fixture
def emu():
    with EbbEmulator(speedup=20.0, canvas=Canvas(size_mm=(297.0, 210.0), px_per_mm=5)) as e:
        yield e


def test_version_queries_and_errors_over_the_port(emu):
    host = Host(emu.port)
    assert host.ask("V", b"\r\n") == b"EBBv13_and_above EB Firmware Version 3.0.3\r\n"
    assert host.ask("EM,1,1") == b"OK\r\n"
    assert host.ask("QE") == b"16,16\n\rOK\r\n"
    assert host.ask("xx", b"\r\n") == b"!8 Err: Unknown command 'XX:5858'\r\n"
    assert host.ask("SM,100", b"\r\n") == b"!4 Err: Missing parameter(s)\r\n"
    assert host.ask("QM", b"\n\r") == b"QM,0,0,0,0\n\r"
    host.s.write(b"QS\n")  # a line feed ends a command too
    assert host.s.read_until(b"OK\r\n") == b"0,0\n\rOK\r\n"
    host.s.write(b"QP\r\nQP\r\n")  # the LF after a CR is not an empty command
    assert host.s.read_until(b"OK\r\n") + host.s.read_until(b"OK\r\n") == b"1\n\rOK\r\n" * 2
    host.s.write(b"QX\bS\r")  # backspace: the firmware echoes " \b"
    assert host.s.read_until(b"OK\r\n") == b" \b0,0\n\rOK\r\n"
    host.close()


def test_moves_count_steps_and_the_third_waits_for_the_fifo(emu):
    host = Host(emu.port)
    assert host.ask("SM,1000,800,-400") == b"OK\r\n"
    assert host.ask("SM,1000,-800,400") == b"OK\r\n"
    assert emu.machine.time < 0.5
    assert host.ask("SM,1000,100,100") == b"OK\r\n"  # held until the first move ends
    assert emu.machine.time >= 1.0
    assert host.ask("SM,10,0,0") == b"OK\r\n"
    assert emu.wait_idle(5.0)
    assert host.ask("QS") == b"100,100\n\rOK\r\n"
    assert emu.stats.steps == 2600 and emu.stats.lines == 5
    assert emu.stats.machine_time_s >= 3.0
    host.close()


def _xm(dx: float, dy: float, ms: int) -> str:
    return f"XM,{ms},{round(STEPS_PER_MM * dx)},{round(STEPS_PER_MM * dy)}"


def test_a_square_drawn_over_the_port_is_inked_at_its_page_mm(emu):
    host = Host(emu.port)
    for text in ("SC,4,20641", "SC,5,15248", "SC,11,1618", "SC,12,1078", "SP,1,200", "EM,1,1",
                 _xm(100, 50, 500), "SP,0,300", _xm(30, 0, 300), _xm(0, 30, 300),
                 _xm(-30, 0, 300), _xm(0, -30, 300), "SP,1,200", _xm(-100, -50, 500)):
        assert host.ask(text) == b"OK\r\n"
    assert emu.wait_idle(10.0)
    host.close()
    emu.stop()
    canvas = emu.canvas
    square = np.array([[100, 160], [130, 160], [130, 130], [100, 130], [100, 160]], float)
    assert ink_chamfer_mm(canvas.image, canvas.px_per_mm, [square]) < 0.3


@pytest.mark.parametrize("fault, reply", [
    (Fault("drop", 2), b""),
    (Fault("error", 2), b"!6 Err: Invalid parameter value\r\n"),
    (Fault("error", 2, 8), b"!8 Err: Unknown command 'SM:534D'\r\n"),
])
def test_a_dropped_reply_or_an_error_at_the_kth_command(fault, reply):
    with EbbEmulator(speedup=20.0, faults=(fault,)) as emu:
        host = Host(emu.port)
        host.s.timeout = 0.5
        assert host.ask("EM,1,1") == b"OK\r\n"
        assert host.ask("SM,100,80,80", b"\r\n") == reply
        assert emu.wait_idle(5.0)
        moved = fault.kind == "drop"  # a dropped reply still runs; an error does not
        assert emu.machine.queue.counters == ([80, 80] if moved else [0, 0])
        assert host.ask("QS") == (b"80,80\n\rOK\r\n" if moved else b"0,0\n\rOK\r\n")
        host.close()


def test_a_disconnect_at_the_kth_command_closes_the_port():
    with EbbEmulator(speedup=20.0, faults=(Fault("disconnect", 2),)) as emu:
        host = Host(emu.port)
        assert host.ask("V", b"\r\n").startswith(b"EBBv13")
        host.s.write(b"QS\r")
        deadline = time.monotonic() + 3
        while emu.running and time.monotonic() < deadline:
            time.sleep(0.01)
        assert not emu.running
        with pytest.raises(serial.SerialException):
            for _ in range(50):
                host.s.write(b"V\r")
                host.s.read(1)
                time.sleep(0.01)
        host.close()


def test_fault_specs_and_replies():
    assert parse_fault("drop:3") == Fault("drop", 3)
    assert parse_fault("error:5:8") == Fault("error", 5, 8)
    assert parse_fault("disconnect:1") == Fault("disconnect", 1)
    for bad in ("drop", "drop:0", "error:2:11", "burn:2", "drop:2:1", "error:x"):
        with pytest.raises(InputError, match="--fault"):
            parse_fault(bad)
    with pytest.raises(InputError, match="kind"):
        Fault("burn", 1)
    assert fault_reply("SM,1,2", 4) == "!4 Err: Missing parameter(s)\r\n"
    assert fault_reply("SM,1,2", 5, future=True) == "SM,!5 Err: Need comma next, found: ','\n"
    # "CU", 54: the reference's checksums of SM,1000,1000,1000 and CU,54,0
    assert fault_reply("SM,1000,1000,1000", 9) == "!9 Err: Checksum incorrect, expected 153\r\n"
    assert fault_reply("CU,54,0", 9) == "!9 Err: Checksum incorrect, expected 119\r\n"


def test_default_canvas_is_the_models_sheet_and_bad_options_are_refused():
    assert EbbEmulator(model="V3A3").canvas.size_mm == (420.0, 297.0)
    assert EbbEmulator().canvas.size_mm == (297.0, 210.0)
    with pytest.raises(InputError, match="speed-up"):
        EbbEmulator(speedup=0)
    with pytest.raises(InputError, match="model"):
        EbbEmulator(model="SE/A1")


def test_inkarm_emulate_axidraw_serves_and_writes_its_canvas_on_ctrl_c(tmp_path):
    out = tmp_path / "canvas.png"
    proc = subprocess.Popen([sys.executable, "-m", "inkarm.cli", "emulate", "axidraw", "--model",
                             "V3A3", "--speedup", "20", "--px-per-mm", "2", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert "AxiDraw V3A3 (EBB firmware 3.0.3)" in proc.stdout.readline()
        host = Host(proc.stdout.readline().strip())
        for text in ("EM,1,1", "SP,0,200", _xm(30, 0, 300), "SP,1,200"):
            assert host.ask(text) == b"OK\r\n"
        while host.ask("QM", b"\n\r") != b"QM,0,0,0,0\n\r":
            time.sleep(0.01)
        host.close()
    finally:
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=10)
    assert proc.returncode == 0, err
    assert out.is_file() and "commands, 4800 motor steps" in err


def test_inkarm_emulate_axidraw_refuses_a_bad_fault(capsys):
    from inkarm.cli import main

    assert main(["emulate", "axidraw", "--fault", "drop:0"]) == 2
    assert "--fault" in capsys.readouterr().err
