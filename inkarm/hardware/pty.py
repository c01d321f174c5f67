"""The pseudo-terminal an emulator serves on: a raw pty whose slave end a host opens by name, as
it would a USB serial adapter (the Dynamixel emulator uses it, the GRBL and EBB ones through
:mod:`inkarm.hardware.pty_device`)."""

from __future__ import annotations

import contextlib
import os
import tty


def open_raw_pty() -> tuple[int, int, str]:
    """(master fd, slave fd, slave path) of a new pty, the slave in raw mode (no echo, no line
    discipline: bytes pass as they are)."""
    master, slave = os.openpty()
    tty.setraw(slave)
    return master, slave, os.ttyname(slave)


def close_quietly(*fds: int) -> None:
    """Close each file descriptor >= 0, ignoring one that is already gone."""
    for fd in fds:
        if fd >= 0:
            with contextlib.suppress(OSError):
                os.close(fd)


__all__ = ["close_quietly", "open_raw_pty"]
