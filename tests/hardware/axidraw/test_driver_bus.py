"""The EBB bus (inkarm.hardware.axidraw.bus) against the emulated EiBotBoard: the version check
on open, replies of each shape, and each fault a clear EbbError naming the command: an ``!``
error with the firmware's message, a lost reply after the stated time, a disconnect; one
driver per port."""

from __future__ import annotations

import time

import pytest

from inkarm.hardware.axidraw import ebb
from inkarm.hardware.axidraw.bus import EbbBus
from inkarm.hardware.axidraw.ebb import EbbError
from inkarm.hardware.axidraw.emulator import EbbEmulator, Fault
from inkarm.hardware.port_lock import PortBusyError

pytestmark = pytest.mark.hardware_emulated


def test_open_checks_the_firmware_and_each_reply_shape_is_read():
    with EbbEmulator(speedup=10.0, canvas=None) as emu:
        bus = EbbBus(emu.port)
        try:
            version = bus.hello()
            assert version >= (2, 4, 4) and bus.version_line.startswith("EBB")
            assert bus.transact(ebb.em(1, 1)) == []  # OK alone
            assert bus.transact(ebb.simple("CS")) == []
            assert bus.transact(ebb.sm(50, 100, -40), due_s=0.1) == []
            assert ebb.parse_motors(bus.transact(ebb.simple("QM"))[0])  # a value alone
            while not ebb.parse_motors(bus.transact(ebb.simple("QM"))[0]).idle:
                time.sleep(0.001)
            assert ebb.parse_steps(bus.transact(ebb.simple("QS"))[0]) == (100, -40)  # value+OK
            assert ebb.parse_pen_up(bus.transact(ebb.simple("QP"))[0]) is True
            with pytest.raises(EbbError) as caught:
                bus.hello(minimum=(99, 0, 0))
            assert "needs 99.0.0 or newer" in str(caught.value)
            assert caught.value.kind == "unexpected" and caught.value.key == "--port"
        finally:
            bus.close()
            bus.close()  # idempotent


def test_a_second_driver_on_the_port_is_refused_before_it_writes():
    with EbbEmulator(speedup=10.0, canvas=None) as emu:
        bus = EbbBus(emu.port)
        try:
            with pytest.raises(PortBusyError, match="in use by"):
                EbbBus(emu.port)
        finally:
            bus.close()
        EbbBus(emu.port).close()  # released


def test_a_firmware_error_names_the_command_and_the_firmwares_message():
    with EbbEmulator(speedup=10.0, canvas=None, faults=(Fault("error", 3, code=6),)) as emu:
        bus = EbbBus(emu.port)
        try:
            bus.hello()
            bus.transact(ebb.simple("CS"))
            with pytest.raises(EbbError) as caught:
                bus.transact(ebb.sc(4, 20000))
            e = caught.value
            assert e.kind == "refused" and e.command == "SC,4,20000"
            assert e.reply.startswith("!6 Err:")
            assert "the EBB refused 'SC,4,20000': !6 Err:" in str(e)
        finally:
            bus.close()
    # a real parameter error, found by the firmware itself: a step rate over 25 kHz
    with EbbEmulator(speedup=10.0, canvas=None) as emu:
        bus = EbbBus(emu.port)
        try:
            bus.hello()
            with pytest.raises(EbbError, match=r"'SM,1,100,0': !0 Err: <axis1> step rate"):
                bus.transact("SM,1,100,0\r")  # (ebb.sm refuses it before sending)
        finally:
            bus.close()


def test_a_lost_reply_is_a_timeout_after_the_stated_time():
    with EbbEmulator(speedup=10.0, canvas=None, faults=(Fault("drop", 2),)) as emu:
        bus = EbbBus(emu.port, reply_timeout_s=0.3)
        try:
            bus.hello()
            t0 = time.monotonic()
            with pytest.raises(EbbError) as caught:
                bus.transact(ebb.simple("QS"), due_s=0.1)
            waited = time.monotonic() - t0
            assert caught.value.kind == "timeout" and caught.value.command == "QS"
            assert "no reply to 'QS'" in str(caught.value) and "within 0.4 s" in str(caught.value)
            assert 0.4 <= waited < 1.5
        finally:
            bus.close()


def test_a_disconnect_is_named():
    with EbbEmulator(speedup=10.0, canvas=None, faults=(Fault("disconnect", 2),)) as emu:
        bus = EbbBus(emu.port, reply_timeout_s=0.5)
        try:
            bus.hello()
            t0 = time.monotonic()
            with pytest.raises(EbbError) as caught:
                bus.transact(ebb.simple("QS"))
            assert caught.value.kind == "disconnected" and time.monotonic() - t0 < 0.5
            assert "the EBB disconnected while waiting for the reply to 'QS'" in str(caught.value)
            with pytest.raises(EbbError, match="disconnected while 'QS' was sent"):
                bus.transact(ebb.simple("QS"))
        finally:
            bus.close()


def test_something_that_is_not_an_ebb_is_refused_on_open():
    from inkarm.hardware.plotter.emulator import EmulatorConfig, GrblEmulator

    with GrblEmulator(EmulatorConfig(speedup=10.0)) as grbl:
        bus = EbbBus(grbl.port, reply_timeout_s=0.3)
        try:
            with pytest.raises(EbbError) as caught:
                bus.hello()
            assert "answered 'V' with \"Grbl 1.1h" in str(caught.value)
            assert "not an EiBotBoard" in str(caught.value) and caught.value.kind == "unexpected"
        finally:
            bus.close()
