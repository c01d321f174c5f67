"""One driver per Dynamixel port (issue 21, item 5): a second plant, bus, calibration or
`inkarm draw` on a port that a run holds is refused at once with PortBusyError naming the
holder, the first run going on untouched; the lock goes with the port on every way out."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from inkarm.cli import main
from inkarm.core.plant import PositionCommand
from inkarm.errors import InputError
from inkarm.hardware import port_lock as pl
from inkarm.hardware.dynamixel.bus import DynamixelBus
from inkarm.hardware.dynamixel.calibration import calibrate_arm
from inkarm.hardware.dynamixel.config import with_dynamixel
from inkarm.hardware.dynamixel.plant import DynamixelPlant
from inkarm.hardware.port_lock import PortBusyError

pytestmark = pytest.mark.hardware_emulated
SCENARIO = Path(__file__).parents[3] / "scenarios" / "wx250s_letter_N.toml"


@pytest.fixture
def lock_dir(tmp_path, monkeypatch):
    """Lock files in a folder of the test's own (the flock on the pty is the kernel's)."""
    folder = tmp_path / "lock"
    folder.mkdir()
    monkeypatch.setattr(pl, "LOCK_DIRS", (folder,))
    return folder


def _held_by_us(busy: PortBusyError, port: str) -> None:
    assert busy.holder == os.getpid()
    assert busy.key == "--port"
    assert f"--port: {port} is in use by process {os.getpid()} (" in str(busy)
    assert "one driver per port" in str(busy)


def test_a_second_driver_is_refused_naming_the_first_which_goes_on(wx250s, arm_emulator,
                                                                    lock_dir):
    arm = with_dynamixel(wx250s, latency_ms=50, watchdog_ms=500)  # a loaded machine's slack
    with arm_emulator(arm) as emu:
        first = DynamixelPlant(emu.port, arm)
        packets = emu.stats.packets
        with pytest.raises(PortBusyError) as busy:
            DynamixelPlant(emu.port, wx250s)
        _held_by_us(busy.value, emu.port)
        with pytest.raises(PortBusyError):
            calibrate_arm(emu.port, wx250s, ask=lambda prompt: "", say=lambda text: None)
        with pytest.raises(PortBusyError):
            DynamixelBus(emu.port)
        assert emu.stats.packets == packets  # refused before a byte went out
        # the first run is untouched: it reads, commands and closes as before
        q0 = first.read().q
        first.command(PositionCommand(q0 + np.radians([1.0, 0, 0, 0, 0, 0])))
        assert first.read().q == pytest.approx(q0, abs=0.05)
        assert first.fault is None
        assert (lock_dir / pl.lock_file_name(emu.port)).read_text().strip() == str(os.getpid())
        first.close()
        assert list(lock_dir.iterdir()) == []
        DynamixelPlant(emu.port, arm).close()  # released: the port is free again


def test_the_lock_goes_on_every_way_out(wx250s, arm_emulator, lock_dir, monkeypatch):
    with arm_emulator(wx250s) as emu:
        wrong = with_dynamixel(wx250s, models=["XL430-W250"] * 6)
        with pytest.raises(InputError, match="do not match robot"):  # refused at start-up
            DynamixelPlant(emu.port, wrong)
        assert list(lock_dir.iterdir()) == []

        def interrupted(self):  # Ctrl-C during start-up
            raise KeyboardInterrupt

        with monkeypatch.context() as m:
            m.setattr(DynamixelPlant, "_start", interrupted)
            with pytest.raises(KeyboardInterrupt):
                DynamixelPlant(emu.port, wx250s)
        assert list(lock_dir.iterdir()) == []
        with pytest.raises(InputError, match="cannot open"):  # the SDK refuses the baud rate
            DynamixelBus(emu.port, baudrate=-1)
        assert list(lock_dir.iterdir()) == []
        with DynamixelBus(emu.port) as bus:
            assert bus.ping(1) is not None
        assert list(lock_dir.iterdir()) == []


@pytest.mark.sim
def test_draw_on_a_held_port_exits_2_in_one_line_naming_the_holder(wx250s, arm_emulator,
                                                                   lock_dir, tmp_path, capsys):
    out = tmp_path / "run"
    with arm_emulator(wx250s) as emu, DynamixelBus(emu.port):
        code = main(["draw", str(SCENARIO), "--backend", "dynamixel", "--port", emu.port,
                     "--out", str(out), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2, err
    errors = [line for line in err if "error" in line]
    assert len(errors) == 1 and "Traceback" not in "".join(err), err
    assert f"--port: {emu.port} is in use by process {os.getpid()} (" in errors[0]
    assert "servos do not match" not in errors[0]
    assert not out.exists()
