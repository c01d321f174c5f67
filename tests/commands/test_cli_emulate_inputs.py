"""``inkarm emulate`` refuses what would fail late or never, before any emulator is built: an
--out it could not write when it stops, a baud rate no servo has, a fault on a servo the bus
does not have."""

from __future__ import annotations

import pytest

from inkarm.cli import main


@pytest.mark.parametrize(("args", "message"), [
    (["grbl", "--out", "/proc/x.png"], "cannot write /proc/x.png: /proc is not a writable folder"),
    (["grbl", "--out", "{tmp}"], "is a folder: expected a PNG file name (.png)"),
    (["grbl", "--out", "{tmp}/c.jpg"], "expected a PNG file name (.png)"),
    (["grbl", "--out", "/dev/null.png/x.png"], "is not a writable folder"),
    (["dynamixel", "--simple", "--out", "/proc/x.png"], "cannot write /proc/x.png"),
    (["dynamixel", "--simple", "--baudrate", "0"], ("--baudrate: expected one of the X series' "
                                                   "rates")),
    (["dynamixel", "--simple", "--baudrate", "1000001"], "got 1000001"),
])
def test_emulate_refuses_bad_options_in_one_line(tmp_path, capsys, args, message):
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    assert main(["emulate", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert list(tmp_path.iterdir()) == []  # the probe leaves nothing


@pytest.mark.sim
def test_a_fault_on_a_servo_the_bus_does_not_have_is_refused(capsys):
    assert main(["emulate", "dynamixel", "--simple", "--robot", "wx250s", "--fault",
                 "silent:99:1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--fault: no servo 99 on the bus of wx250s (its ids: " in err[0]
