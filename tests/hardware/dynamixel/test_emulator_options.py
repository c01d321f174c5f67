"""The emulator's options as a user gives them: ``--fault`` timed from the driver's first
torque-on (not from boot, which would fire a short fault before any driver connects), and
``--status-return-level`` (servos booting at that level)."""

from __future__ import annotations

import time

import pytest

from inkarm.cli import main
from inkarm.commands import _dynamixel
from inkarm.hardware.dynamixel.bus import DynamixelBus, DynamixelFault
from inkarm.hardware.dynamixel.config import with_dynamixel
from inkarm.hardware.dynamixel.emulator import Fault
from inkarm.hardware.dynamixel.plant import DynamixelPlant
from tests.hardware.waiting import eventually

pytestmark = pytest.mark.hardware_emulated



def test_a_fault_is_timed_from_the_drivers_torque_on_not_from_boot(wx250s, arm_emulator):
    """Servos that boot holding (as the twin's do) start no clock: an overload at 0.5 s fires
    0.5 s after the driver, connecting 1 s after boot, switched the torque on."""
    emu = arm_emulator(wx250s, faults=[Fault("overload", 4, 0.5)])
    for servo in emu.bus.servos:  # booted holding, as twin_emulator leaves them
        servo.memory.set("torque_enable", 1)
        emu.bank.on_write(servo, ["torque_enable"])
    with emu:
        time.sleep(1.0)  # no driver yet
        assert emu.stats.faults == [] and emu.torque_on_at is None
        plant = DynamixelPlant(emu.port, with_dynamixel(wx250s, latency_ms=50))  # starts: no
        # hardware error yet (the slack of the HIL tests for a loaded machine)
        try:
            assert emu.torque_on_at is not None and emu.torque_on_at >= 1.0
            assert eventually(lambda: emu.stats.faults)
            kind, at = emu.stats.faults[0].split("@")
            assert kind == "overload:4"
            assert float(at) - emu.torque_on_at == pytest.approx(0.5, abs=0.25)
            with pytest.raises(DynamixelFault, match=r"servo 4 \(elbow\): hardware error: "
                               "overload"):
                for _ in range(200):
                    plant.read()
                    plant.step()
        finally:
            plant.close()


def _serve_once(check):
    """``serve`` for the test: start the emulator, ``check`` it through a bus, stop it."""
    seen = []

    def serve(emulator, banner, out=None):
        with emulator:
            seen.append(check(emulator))

    return serve, seen


@pytest.mark.parametrize("level", [0, 1, 2])
def test_emulate_dynamixel_boots_the_servos_at_the_status_return_level(level, monkeypatch):
    def check(emulator):
        with DynamixelBus(emulator.port, retries=0, latency_ms=4) as bus:
            assert bus.ping(8) is not None  # every level answers PING
            if level == 0:
                with pytest.raises(DynamixelFault, match=r"servo 8: answers PING but not READ: "
                                   r"its Status Return Level \(68\) is 0"):
                    bus.status_return_level(8)
                return 0
            assert bus.status_return_level(8) == level
            bus.write(8, "led", 1)  # unanswered at 1: sent, then read back
            assert bus.read(8, "led") == 1
            return level

    serve, seen = _serve_once(check)
    monkeypatch.setattr(_dynamixel, "serve", serve)
    assert main(["emulate", "dynamixel", "--simple", "--robot", "wx250s",
                 "--status-return-level", str(level)]) == 0
    assert seen == [level]


def test_emulate_dynamixel_defaults_to_level_2_and_refuses_others(monkeypatch, capsys):
    serve, seen = _serve_once(lambda e: sorted({s.memory.get("status_return_level")
                                                for s in e.bus.servos}))
    monkeypatch.setattr(_dynamixel, "serve", serve)
    assert main(["emulate", "dynamixel", "--simple", "--robot", "wx250s"]) == 0
    assert seen == [[2]]
    with pytest.raises(SystemExit) as exit_:
        main(["emulate", "dynamixel", "--simple", "--status-return-level", "3"])
    assert exit_.value.code == 2
    assert "--status-return-level: invalid choice: 3 (choose from 0, 1, 2)" in \
        capsys.readouterr().err
