"""Emulators on pseudo-terminals for the Dynamixel tests (real dynamixel-sdk on the other end)."""

from __future__ import annotations

import sys

import dynamixel_sdk as sdk
import numpy as np
import pytest

from inkarm.hardware.dynamixel.bus import _PortHandler
from inkarm.hardware.dynamixel.config import DynamixelConfig
from inkarm.hardware.dynamixel.emulator import (
    DynamixelEmulator,
    ServoSpec,
    simple_emulator,
    specs_for_profile,
)
from inkarm.hardware.dynamixel.physics import Mount, SimpleJoints
from inkarm.robots.registry import load_robot


@pytest.fixture(autouse=True)
def _fast_thread_switch():
    """The emulator answers from a thread of this process: hand it the GIL promptly."""
    previous = sys.getswitchinterval()
    sys.setswitchinterval(2e-4)
    yield
    sys.setswitchinterval(previous)


@pytest.fixture
def emulator():
    """Three servos (XM430, XL430, XM540) on simple joints, answering at once."""
    specs = [ServoSpec(1, "XM430-W350", Mount(0)), ServoSpec(2, "XL430-W250", Mount(1)),
             ServoSpec(3, "XM540-W270", Mount(2))]
    emu = DynamixelEmulator(specs, SimpleJoints.at(np.zeros(3)), byte_timing=False)
    emu.start()
    yield emu
    emu.stop()


@pytest.fixture
def sdk_port(emulator):
    """(PortHandler, PacketHandler) of dynamixel-sdk on the emulator's pty."""
    port = _PortHandler(emulator.port)  # the SDK's, waiting in select() between bytes
    assert port.openPort() and port.setBaudRate(1_000_000)
    yield port, sdk.PacketHandler(2.0)
    port.closePort()


@pytest.fixture
def wx250s():
    return load_robot("wx250s")


@pytest.fixture
def arm_emulator():
    """A factory: the profile's servos (shadows included) on simple joints at its home pose."""

    def make(profile, byte_timing=False, faults=(), **kw) -> DynamixelEmulator:
        specs = specs_for_profile(DynamixelConfig.of(profile), profile.n, **kw)
        return simple_emulator(specs, profile.home_q, faults, byte_timing=byte_timing)

    return make
