"""One driver per serial port: an advisory lock taken before a port is opened, refused at once
with a message naming the holder.

Two conventions serial tools share on Linux, both taken:

* ``flock(LOCK_EX | LOCK_NB)`` on the device itself, as pyserial's ``exclusive=True`` and
  ModemManager take it: the kernel drops it when the holder dies, so it is never stale;
* a UUCP lock file ``LCK..<device>`` in ``/run/lock`` (``/var/lock``) holding the holder's
  process id as ten ASCII characters and a newline (the Filesystem Hierarchy Standard's form,
  which minicom, picocom and cu write): it names the holder for the refusal. A lock file whose
  process is gone is stale and is replaced; where the folder cannot be written (a user without
  the ``dialout``/``lock`` group), only the ``flock`` is taken.

A second driver on the same port (inkarm or another tool) is refused with
:class:`PortBusyError` before it writes a byte, instead of two streams interleaving on one
device (the second GRBL driver waited 240 s for replies the first one took).
:func:`open_locked` takes the lock and opens the port, as the GRBL and EBB drivers do.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
from collections.abc import Callable, Iterator
from pathlib import Path

from inkarm.errors import InputError

LOCK_DIRS = (Path("/run/lock"), Path("/var/lock"))


class PortBusyError(InputError):
    """The port is held by another driver; ``holder`` is its process id where known."""

    def __init__(self, message: str, *, port: str, holder: int | None = None):
        super().__init__(message, key="--port", value=port)  # the command line's option
        self.port, self.holder = port, holder


def lock_file_name(port: str | os.PathLike) -> str:
    """``LCK..`` and the device's name below ``/dev`` with ``/`` as ``_`` (``/dev/ttyUSB0`` ->
    ``LCK..ttyUSB0``, ``/dev/pts/5`` -> ``LCK..pts_5``)."""
    path = Path(os.path.realpath(port))
    name = str(path.relative_to("/dev")) if path.is_relative_to("/dev") else path.name
    return "LCK.." + name.replace("/", "_")


def _lock_dir() -> Path | None:
    return next((d for d in LOCK_DIRS if d.is_dir() and os.access(d, os.W_OK | os.X_OK)), None)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process: alive
        return True
    return True


def _read_pid(path: Path) -> int | None:
    try:
        text = path.read_bytes()[:64].decode("ascii", "replace").strip()
        return int(text) if text else None
    except (OSError, ValueError):
        return None


def describe_holder(pid: int | None) -> str:
    """``process N (its command line)``, or a phrase saying it is unknown."""
    if pid is None:
        return "another process (no lock file names it)"
    try:
        raw = Path(f"/proc/{pid}/cmdline").read_bytes()
        command = " ".join(raw.replace(b"\0", b" ").decode("utf-8", "replace").split())
        command = "".join(c if c.isprintable() else "?" for c in command)  # one line, always
    except OSError:
        command = ""
    return f"process {pid}" + (f" ({command[:120]})" if command else "")


def _busy(port: str, pid: int | None) -> PortBusyError:
    return PortBusyError(f"{port} is in use by {describe_holder(pid)}; stop it first (one "
                         "driver per port)", port=port, holder=pid)


def _take_lock_file(folder: Path, port: str) -> Path | None:
    """Write our lock file, replacing a stale one; None when another live process holds it."""
    path = folder / lock_file_name(port)
    for _ in range(2):
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        except FileExistsError:
            pid = _read_pid(path)
            if pid is not None and pid != os.getpid() and _alive(pid):
                raise _busy(port, pid) from None
            path.unlink(missing_ok=True)  # stale: its process is gone
            continue
        except OSError:
            return None
        with os.fdopen(fd, "w") as f:
            f.write(f"{os.getpid():>10d}\n")
        return path
    return None


@contextlib.contextmanager
def port_lock(port: str | os.PathLike) -> Iterator[None]:
    """Hold ``port`` for the ``with`` block (module docstring); :class:`PortBusyError` at once
    when another driver holds it. A path that is not a device (a test's file) is held by its
    lock file alone."""
    port = str(port)
    fd = -1
    try:
        fd = os.open(port, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    except OSError:
        fd = -1  # not openable here: the driver's own open names the problem
    lock_path = None
    try:
        if fd >= 0:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as e:
                if e.errno not in (errno.EWOULDBLOCK, errno.EACCES):
                    raise InputError(f"cannot lock {port}: {e}", key="--port",
                                     value=port) from None
                folder = _lock_dir()
                pid = _read_pid(folder / lock_file_name(port)) if folder else None
                raise _busy(port, pid if pid is not None and _alive(pid) else None) from None
        folder = _lock_dir()
        if folder is not None:
            lock_path = _take_lock_file(folder, port)
        yield
    finally:
        if lock_path is not None and _read_pid(lock_path) == os.getpid():
            lock_path.unlink(missing_ok=True)
        if fd >= 0:
            os.close(fd)  # releases the flock


def open_locked(port: str, baudrate: int, error: Callable[[str], Exception]):
    """Take ``port``'s lock (:func:`port_lock`), then open it (pyserial, 2 ms read timeout, 2 s
    write timeout): the lock (an :class:`~contextlib.ExitStack`; closing it releases the port)
    and the open :class:`serial.Serial`. A port that does not open raises ``error(message)``
    (``cannot open PORT: why``) with the lock released."""
    import serial

    lock = contextlib.ExitStack()
    lock.enter_context(port_lock(port))
    try:
        return lock, serial.Serial(port, baudrate, timeout=0.002, write_timeout=2.0)
    except (serial.SerialException, ValueError, OSError) as e:
        lock.close()
        raise error(f"cannot open {port}: {e}") from None


__all__ = ["PortBusyError", "describe_holder", "lock_file_name", "open_locked", "port_lock"]
