"""One driver per serial port: the second is refused at once, naming the holder, whether the
holder is inkarm, another process's lock file, or pyserial's exclusive mode; stale lock files
are replaced; everything is released on the way out."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import serial

from inkarm.hardware import port_lock as pl
from inkarm.hardware.pty import close_quietly, open_raw_pty


def _take(port: str) -> None:
    with pl.port_lock(port):
        pass


@pytest.fixture
def port(tmp_path, monkeypatch):
    monkeypatch.setattr(pl, "LOCK_DIRS", (tmp_path,))
    master, slave, path = open_raw_pty()
    yield path
    close_quietly(master, slave)


def test_lock_file_names_follow_the_uucp_convention():
    assert pl.lock_file_name("/dev/ttyUSB0") == "LCK..ttyUSB0"
    assert pl.lock_file_name("/dev/pts/5") == "LCK..pts_5"


def test_a_second_driver_is_refused_naming_the_first(port, tmp_path):
    with pl.port_lock(port):
        lock = tmp_path / pl.lock_file_name(port)
        assert lock.read_text() == f"{os.getpid():>10d}\n"  # ten characters and a newline
        with pytest.raises(pl.PortBusyError) as busy, pl.port_lock(port):
            pass
        assert busy.value.holder == os.getpid()
        assert f"{port} is in use by process {os.getpid()} (" in str(busy.value)
        assert "one driver per port" in str(busy.value)
    assert not lock.exists()
    with pl.port_lock(port):  # released: taken again
        pass


def test_a_stale_lock_file_is_replaced(port, tmp_path):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (tmp_path / pl.lock_file_name(port)).write_text(f"{dead.pid:>10d}\n")
    with pl.port_lock(port):
        assert (tmp_path / pl.lock_file_name(port)).read_text().strip() == str(os.getpid())


def test_a_live_lock_file_of_another_tool_is_respected(port, tmp_path):
    """minicom or cu hold a port by their lock file alone (no flock)."""
    other = subprocess.Popen(["sleep", "30"])
    while b"sleep" not in Path(f"/proc/{other.pid}/cmdline").read_bytes():
        pass  # right after exec the kernel may still show an empty command line
    try:
        (tmp_path / pl.lock_file_name(port)).write_text(f"{other.pid:>10d}\n")
        with pytest.raises(pl.PortBusyError, match=rf"process {other.pid} \(sleep 30\)"):
            _take(port)
    finally:
        other.kill()
        other.wait()


def test_a_flock_held_by_another_process_is_respected(port):
    code = ("import fcntl, os, sys, time; fd = os.open(sys.argv[1], os.O_RDWR | os.O_NOCTTY); "
            "fcntl.flock(fd, fcntl.LOCK_EX); print('held', flush=True); time.sleep(30)")
    other = subprocess.Popen([sys.executable, "-c", code, port], stdout=subprocess.PIPE,
                             text=True)
    try:
        assert other.stdout.readline().strip() == "held"
        with pytest.raises(pl.PortBusyError, match="in use by another process"):
            _take(port)
    finally:
        other.kill()
        other.wait()


def test_pyserials_exclusive_mode_and_ours_exclude_each_other(port):
    with serial.Serial(port, exclusive=True), pytest.raises(pl.PortBusyError):
        _take(port)
    with pl.port_lock(port), pytest.raises(serial.SerialException):
        serial.Serial(port, exclusive=True)


def test_an_unwritable_lock_folder_leaves_the_flock(port, monkeypatch, tmp_path):
    monkeypatch.setattr(pl, "LOCK_DIRS", (tmp_path / "missing",))
    with pl.port_lock(port), pytest.raises(pl.PortBusyError, match="another process"):
        _take(port)


def test_the_holder_is_named_on_one_line_whatever_its_command_line():
    code = "import time\nimport sys\ntime.sleep(30)  # \x1b[31m"
    other = subprocess.Popen([sys.executable, "-c", code])
    try:
        while b"time.sleep" not in Path(f"/proc/{other.pid}/cmdline").read_bytes():
            pass
        text = pl.describe_holder(other.pid)
        assert text.startswith(f"process {other.pid} (") and "\n" not in text
        assert all(c.isprintable() for c in text)
    finally:
        other.kill()
        other.wait()
