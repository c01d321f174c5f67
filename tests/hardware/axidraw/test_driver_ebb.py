"""The EBB command vocabulary (inkarm.hardware.axidraw.ebb): commands formatted as the EBB
command reference writes them, the firmware's parameter ranges refused before a byte is sent,
and replies parsed. Oracles: the reference's own examples (evil-mad ebb.html)."""

from __future__ import annotations

import pytest

from inkarm.errors import InputError
from inkarm.hardware.axidraw import ebb


@pytest.mark.parametrize("text, expected", [
    (ebb.sm(1000, 250, -766), "SM,1000,250,-766\r"),  # the SM example
    (ebb.xm(1000, 550, -1234), "XM,1000,550,-1234\r"),  # the XM example
    (ebb.lm(85899346, 10, 0, 17180814, 2, 0), "LM,85899346,10,0,17180814,2,0\r"),  # LM ex. 3
    (ebb.lm(3865471, 60, 1732, 0, 0, 0), "LM,3865471,60,1732,0,0,0\r"),  # LM example 1
    (ebb.em(1, 0), "EM,1,0\r"), (ebb.em(2), "EM,2\r"), (ebb.em(0, 0), "EM,0,0\r"),
    (ebb.sc(4, 8000), "SC,4,8000\r"), (ebb.sc(1, 1), "SC,1,1\r"),  # the SC examples
    (ebb.sp(True), "SP,1\r"), (ebb.sp(False, 146), "SP,0,146\r"), (ebb.sp(True, 130, 1),
                                                                   "SP,1,130,1\r"),
    (ebb.tp(), "TP\r"), (ebb.tp(500), "TP,500\r"),
    (ebb.hm(3000), "HM,3000\r"), (ebb.hm(3000, 100, -200), "HM,3000,100,-200\r"),
    (ebb.sr(60000, 1), "SR,60000,1\r"),  # the SR example
    (ebb.simple("QS"), "QS\r"), (ebb.simple("V"), "V\r"), (ebb.simple("ES"), "ES\r"),
])
def test_commands_are_written_as_the_reference_writes_them(text, expected):
    assert text == expected


@pytest.mark.parametrize("make, key, what", [
    (lambda: ebb.sm(0, 1, 1), "SM duration_ms", "1..16777215"),  # 0 is invalid
    (lambda: ebb.sm(16777216, 1, 1), "SM duration_ms", "1..16777215"),
    (lambda: ebb.sm(1000, 16777216, 0), "SM steps1", "-16777215..16777215"),
    (lambda: ebb.sm(10, 251, 0), "SM steps1", "25100 steps/s"),  # above 25 kHz
    (lambda: ebb.sm(10, 0, -251), "SM steps2", "25100 steps/s"),
    (lambda: ebb.sm(1000, 1, 0), "SM steps1", "1 steps/s"),  # below 1.31 steps/s
    (lambda: ebb.xm(10, 200, 60), "XM axis 1", "26000 steps/s"),  # checked on axes 1 and 2
    (lambda: ebb.lm(0, 10, 0, 0, 0, 0), "LM", "no axis can move"),
    (lambda: ebb.lm(2**31, 10, 0, 0, 0, 0), "LM rate1", "0..2147483647"),
    (lambda: ebb.lm(1, 1, 0, 0, 0, 0, 4), "LM clear", "0..3"),
    (lambda: ebb.sp(True, 65536), "SP duration_ms", "1..65535"),
    (lambda: ebb.sp(True, 10, 8), "SP pin", "0..7"),
    (lambda: ebb.sc(4, 0), "SC,4 value", "1..65535"),
    (lambda: ebb.sc(256, 1), "SC param", "0..255"),
    (lambda: ebb.em(6, 0), "EM enable1", "0..5"),
    (lambda: ebb.hm(1), "HM rate", "2..25000"),
    (lambda: ebb.hm(100, 1), "HM", "both positions"),
    (lambda: ebb.hm(100, 4294968, 0), "HM position1", "-4294967..4294967"),
    (lambda: ebb.sr(-1), "SR timeout_ms", "0..4294967295"),
    (lambda: ebb.sm(1.5, 1, 1), "SM duration_ms", "an integer"),
    (lambda: ebb.simple("SM"), "command", "argument-free"),
])
def test_out_of_range_parameters_are_refused_before_anything_is_sent(make, key, what):
    with pytest.raises(InputError) as caught:
        make()
    assert caught.value.key == key and what in str(caught.value)


def test_the_rate_limits_are_the_firmwares_both_ends_included():
    assert ebb.sm(10, 250, -250) == "SM,10,250,-250\r"  # exactly 25 kHz
    assert ebb.sm(1000, 2, 0) == "SM,1000,2,0\r"  # 2 steps/s
    assert ebb.sm(60000, 0, 0) == "SM,60000,0,0\r"  # a delay: no axis moves
    with pytest.raises(InputError, match="1.31"):
        ebb.sm(1000, 1, 0)


def test_a_command_longer_than_64_characters_is_refused():
    with pytest.raises(InputError, match="at most 64 characters"):
        ebb.command("ST", "x" * 70)
    assert len(ebb.sm(16777215, -16777215, -16777215)) <= ebb.MAX_COMMAND


def test_replies_are_split_on_either_line_ending_and_parsed():
    lines, rest = ebb.split_lines(b"1421,-429\n\rOK\r\nQM,1,1,0,1\n\r3E\r\nEB")
    assert lines == ["1421,-429", "OK", "QM,1,1,0,1", "3E"] and rest == b"EB"
    assert ebb.parse_steps("1421,-429") == (1421, -429)  # the QS example
    assert ebb.parse_pen_up("1") is True and ebb.parse_pen_up("0") is False
    assert ebb.parse_motors("QM,1,1,0,1") == ebb.Motors(True, True, False, True)
    assert ebb.parse_motors("QM,0,0,0,0").idle and ebb.parse_motors("QM,0,0,0").idle
    # the QG example: 3E = PRG pressed, pen down, command executing, both motors moving
    assert ebb.parse_general("3E") == {"FIFO": False, "MTR2": True, "MTR1": True, "CMD": True,
                                       "PEN": True, "PRG": True, "RB2": False, "RB5": False}
    assert ebb.parse_version("EBBv13_and_above EB Firmware Version 2.4.2") == (2, 4, 2)
    assert ebb.parse_stop("1,50,1200,18634,9848") == (1, 50, 1200, 18634, 9848)  # ES example
    assert ebb.parse_stop("0") == (0,)  # before v2.2.9
    assert ebb.is_error("!8 Err: Unknown command 'ZZ:5A5A'") and not ebb.is_error("OK")


@pytest.mark.parametrize("parse, line", [
    (ebb.parse_steps, "1421"), (ebb.parse_steps, "a,b"), (ebb.parse_pen_up, "2"),
    (ebb.parse_motors, "QM,1,x,0,0"), (ebb.parse_motors, "1,1,0,0"),
    (ebb.parse_general, "ZZ"), (ebb.parse_version, "Grbl 1.1h ['$' for help]"),
    (ebb.parse_stop, "1,2"),
])
def test_malformed_replies_are_refused_naming_what_was_expected(parse, line):
    with pytest.raises(ValueError, match="expected"):
        parse(line)


def test_each_command_knows_its_reply_shape():
    assert ebb.reply_shape("SM,10,1,1\r") == "ok"
    assert ebb.reply_shape("qs\r") == "value+ok"  # commands are case-insensitive
    assert ebb.reply_shape("V\r") == "value" and ebb.reply_shape("QM\r") == "value"
    assert ebb.reply_shape("QG\r") == "value" and ebb.reply_shape("ES\r") == "value+ok"


def test_a_delay_longer_than_firmware_3_runs_is_refused():
    assert ebb.sm(100000, 0, 0) == "SM,100000,0,0\r"
    with pytest.raises(InputError, match="a delay \\(no steps\\) of at most 100000 ms"):
        ebb.sm(100001, 0, 0)
