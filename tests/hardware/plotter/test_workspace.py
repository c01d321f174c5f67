"""GrblPlant's set-up (settings, homing, work offset, check mode), GRBL 1.1h's report cadence
and the pen state from the ``ok``s, against a scripted device that answers as GRBL 1.1h does
(replies and reports copied from GRBL 1.1h run under grbl-sim)."""

import numpy as np
import pytest

from inkarm.core.plant import PenCommand, PositionCommand
from inkarm.errors import InputError
from inkarm.hardware.plotter import stream as stream_module
from inkarm.hardware.plotter import workspace
from inkarm.hardware.plotter.plant import GrblPlant
from inkarm.hardware.plotter.profiles import load_profile, parse_profile
from inkarm.hardware.plotter.stream import GrblStreamer, parse_status
from inkarm.hardware.plotter.workspace import Placement, check_reach, page_origin

# GRBL 1.1h's defaults ($$ of a fresh EEPROM), with homing and soft limits on
STOCK = {0: 10, 1: 25, 10: 1, 11: 0.01, 12: 0.002, 13: 0, 20: 1, 21: 0, 22: 1, 23: 0, 27: 1.0,
         30: 1000, 100: 250, 101: 250, 102: 250, 110: 500, 111: 500, 112: 500, 120: 10,
         121: 10, 122: 10, 130: 200, 131: 200, 132: 200}


class ScriptedGrbl:
    """A serial port with GRBL 1.1h's answers: ``$$``, ``$#``, ``$H`` (to machine -$27),
    ``$X``, ``$C`` (check mode; off = a reset), ``G10 L2 P1``, every other line ``ok``; a
    ``?`` gets a report with the stock cadence (``WCO:`` every 30th busy / 10th idle, ``Ov:``
    every 20th / 10th and right after a ``WCO:``, ``A:`` only with ``Ov:``)."""

    def __init__(self, settings=None, state="Alarm"):
        self.settings = dict(STOCK if settings is None else settings)
        self.state = state
        self.pos = [0.0, 0.0, 0.0]
        self.g54 = [0.0, 0.0, 0.0]
        self.spindle = False
        self.sent: list[str] = []
        self.out = b""
        self.partial = b""
        self.wco_count = self.ovr_count = 0
        self.in_waiting = 0

    # the pyserial surface GrblStreamer uses
    def write(self, data: bytes) -> int:
        for b in data:
            if b == ord("?"):
                self.reply(self.report())
            elif b == 0x18:
                if self.state == "Check":
                    self.state = "Idle"
                self.reply("", "Grbl 1.1h ['$' for help]")
            elif b == ord("\n"):
                line, self.partial = self.partial.decode(), b""
                self.sent.append(line)
                self.line(line)
            else:
                self.partial += bytes([b])
        return len(data)

    def read(self, n: int = 1) -> bytes:
        data, self.out = self.out, b""
        self.in_waiting = 0
        return data

    def reset_input_buffer(self) -> None:
        self.out = b""

    def close(self) -> None:
        pass

    def reply(self, *lines: str) -> None:
        self.out += b"".join(f"{line}\r\n".encode() for line in lines)
        self.in_waiting = len(self.out)

    def line(self, line: str) -> None:
        if line == "$$":
            self.reply(*(f"${k}={v:g}" for k, v in self.settings.items()))
        elif line == "$#":
            self.reply("[G54:{:.3f},{:.3f},{:.3f}]".format(*self.g54), "[G92:0.000,0.000,0.000]",
                       "[TLO:0.000]", "[PRB:0.000,0.000,0.000:0]")
        elif line == "$H":
            self.pos = [-self.settings[27]] * 3
            self.state = "Idle"
        elif line == "$X" and self.state == "Alarm":
            self.state = "Idle"
            self.reply("[MSG:Caution: Unlocked]")
        elif line == "$C":
            self.state = "Idle" if self.state == "Check" else "Check"
            self.reply("[MSG:Enabled]" if self.state == "Check" else "[MSG:Disabled]")
        elif line.startswith("G10 L2 P1"):
            words = {w[0]: float(w[1:]) for w in line.split()[3:]}
            self.g54[:2] = [words["X"], words["Y"]]
        elif line.startswith("M3"):
            self.spindle = True
        elif line.startswith("M5"):
            self.spindle = False
        elif line.startswith(("G0 ", "G1 ")) and self.state != "Check":
            words = {w[0]: float(w[1:]) for w in line.split()[1:] if w[0] in "XYZ"}
            for i, axis in enumerate("XYZ"):
                if axis in words:
                    self.pos[i] = words[axis] + self.g54[i]
        self.reply("ok")

    def report(self) -> str:
        fields = [self.state, "MPos:{:.3f},{:.3f},{:.3f}".format(*self.pos), "FS:0,0"]
        if self.wco_count > 0:
            self.wco_count -= 1
        else:
            self.wco_count = 9
            if self.ovr_count == 0:
                self.ovr_count = 1
            fields.append("WCO:{:.3f},{:.3f},{:.3f}".format(*self.g54))
        if self.ovr_count > 0:
            self.ovr_count -= 1
        else:
            self.ovr_count = 9
            fields.append("Ov:100,100,100")
            if self.spindle:
                fields.append("A:S")
        return "<" + "|".join(fields) + ">"


@pytest.fixture
def device(monkeypatch):
    grbl = ScriptedGrbl()
    monkeypatch.setattr(stream_module.serial, "Serial", lambda *a, **k: grbl)
    return grbl


def connected(device) -> GrblStreamer:
    streamer = GrblStreamer("/dev/fake")
    streamer.wake()
    return streamer


def test_reports_as_grbl_11h_writes_them():
    """Fields come and go with the firmware's cadence: a report without ``A:`` says nothing
    about the spindle, one with ``Ov:`` and no ``A:`` says it is off."""
    plain = parse_status("<Run|MPos:-150.000,-120.000,0.000|FS:500,1000>", 1.0,
                         wco=(-200.0, -200.0, 0.0))
    assert plain.accessories is None and plain.wco is None and plain.overrides is None
    assert plain.wpos == pytest.approx((50.0, 80.0, 0.0))
    with_ov = parse_status("<Run|MPos:0.000,0.000,0.000|FS:500,1000|Ov:100,100,100|A:S>", 0)
    assert with_ov.accessories == "S" and with_ov.spindle_on and with_ov.overrides == (100,) * 3
    off = parse_status("<Idle|MPos:-1.000,-1.000,-1.000|FS:0,0|Ov:100,100,100>", 0)
    assert off.accessories == "" and not off.spindle_on
    wco = parse_status("<Idle|MPos:1.000,2.000,0.000|FS:0,0|WCO:1.000,1.000,0.000>", 0,
                       wco=(9.0, 9.0, 9.0))
    assert wco.wco == (1.0, 1.0, 0.0) and wco.wpos == pytest.approx((0.0, 1.0, 0.0))
    work = parse_status("<Idle|WPos:5.000,6.000,0.000|Bf:15,128|Ln:42|FS:0,0>", 0,
                        wco=(-200.0, -200.0, 0.0))
    assert work.work and work.mpos == pytest.approx((-195.0, -194.0, 0.0))
    assert (work.planner_free, work.rx_free, work.line) == (15, 128, 42)
    assert parse_status("<Idle|Bf:15,x|MPos:0,0,0>", 0) is None


def test_page_origin_choices_on_a_homed_machine():
    page = (210.0, 297.0)
    assert page_origin(Placement(), STOCK, page, (0, 0)) == (-200.0, -200.0)
    assert page_origin(Placement("upper-right"), STOCK, page, (0, 0)) == (-210.0, -297.0)
    assert page_origin(Placement("lower-right"), STOCK, page, (0, 0)) == (-210.0, -200.0)
    assert page_origin(Placement("current"), STOCK, page, (-3.0, -4.0)) == (-3.0, -4.0)
    assert page_origin(Placement((-150.0, -120.0)), STOCK, page, (0, 0)) == (-150.0, -120.0)
    assert page_origin(Placement(), {**STOCK, 22: 0}, page, (5, 5)) == (0.0, 0.0)
    # GRBL's homed position: -$27 toward +, -$13x + $27 toward - ($23 bit set)
    assert workspace.homed_position({**STOCK, 23: 2}) == (-1.0, -199.0)


@pytest.mark.parametrize("origin, lo, hi, settings, message", [
    ((-200.0, -200.0), (10, 10), (150, 210), STOCK, (r"machine Y -190.00 to 10.00 mm .*"
     r"outside GRBL's homed travel \[-200, 0\] mm \(\$131, Y max travel\)")),
    ((-100.0, -200.0), (-110, 0), (50, 50), STOCK, r"machine X -210.00 .*\(\$130"),
    ((0.0, 0.0), (0, 0), (250, 10), {**STOCK, 22: 0}, (r"spans 250.00 mm in X, more than "
     r"the machine's travel \$130 = 200 mm")),
])
def test_a_job_beyond_the_travel_is_refused_naming_the_setting(origin, lo, hi, settings,
                                                                message):
    with pytest.raises(InputError, match=message):
        check_reach(origin, np.array(lo), np.array(hi), settings, bool(settings[22]))
    check_reach((-200.0, -200.0), np.array((0, 0)), np.array((200, 200)), STOCK, True)


def test_set_up_homes_then_puts_the_page_origin_in_g54(device):
    streamer = connected(device)
    ws = workspace.set_up(streamer, Placement(), (210, 297), (np.zeros(2), np.full(2, 150.0)))
    assert device.sent[:5] == ["$$", "$H", "G10 L2 P1 X-200.000 Y-200.000", "G54", "$#"]
    assert ws.homed and ws.origin_mm == (-200.0, -200.0) and ws.offsets["G54"][:2] == (-200,
                                                                                       -200)
    assert streamer.wco == (-200.0, -200.0, 0.0)
    assert streamer.status().wpos == pytest.approx((199.0, 199.0, -1.0))  # home, on the page


def test_a_job_beyond_the_travel_moves_nothing(device):
    streamer = connected(device)
    with pytest.raises(InputError, match=r"\$131"):
        workspace.set_up(streamer, Placement(), (210, 297), (np.zeros(2), np.array([100, 250])))
    assert device.sent == ["$$"] and device.state == "Alarm"  # not homed, not unlocked


def test_without_homing_an_alarm_is_unlocked_and_work_is_machine(device):
    device.settings[22] = device.settings[20] = 0
    streamer = connected(device)
    ws = workspace.set_up(streamer, Placement(), (210, 297))
    assert "$H" not in device.sent and "$X" in device.sent and ws.origin_mm == (0.0, 0.0)
    with pytest.raises(InputError, match=r"reports inches \(\$13=1\)"):
        device.settings[13] = 1
        workspace.set_up(streamer, Placement(), (210, 297))


def test_the_pen_state_follows_the_oks_not_the_a_field(device):
    """The scripted device writes ``A:S`` only every 10th report; the plant's pen state is
    down from the pen-down dwell's ``ok`` to the pen-up line's, whatever the reports carry."""
    plant = GrblPlant(connected(device), load_profile("servo"), time_scale=1.0)
    plant.command(PositionCommand(q=np.array([0.010, 0.020])))
    plant.command(PenCommand(down=True))
    plant.step()
    down = [plant._state(plant.streamer.status()) for _ in range(12)]
    assert all(s.force > 0 and s.tip_mm[2] == 0.0 for s in down)
    seen = [r.accessories for r in plant.streamer.state.statuses[-12:]]
    assert seen.count(None) >= 10 and "S" in seen  # A:S in one report of ten, as GRBL writes
    assert down[0].q == pytest.approx([0.010, 0.020])  # work (page) coordinates, in [m]
    plant.command(PositionCommand(q=np.array([0.030, 0.020]), qd=np.array([0.05, 0.0])))
    plant.command(PenCommand(down=False))
    plant.step()
    assert plant.finish()
    up = plant._state(plant.streamer.status())
    assert up.force == 0.0 and np.isnan(up.tip_mm[2])
    assert plant.pen_marks == [(len(plant.profile.start_lines()) + 3, True),
                               (len(plant.profile.start_lines()) + 5, False)]


def test_check_mode_validates_without_moving_and_leaves_by_a_reset(device):
    plant = GrblPlant(connected(device), load_profile("servo"), check_mode=True)
    assert "$H" not in device.sent and "$X" in device.sent and device.sent[-1] == "$C"
    plant.command(PositionCommand(q=np.array([0.05, 0.05])))
    plant.step()
    assert plant.finish() and device.state == "Idle" and device.pos == [0.0, 0.0, 0.0]
    assert device.sent.count("$C") == 2


def test_profiles_carry_the_page_placement(tmp_path):
    profile = parse_profile({"page_origin": [-150.0, -120.0], "homing": "skip"}, "p.toml", "p")
    assert profile.placement == Placement((-150.0, -120.0), "skip")
    assert load_profile("servo").placement == Placement()
    with pytest.raises(InputError, match=r"page_origin: unknown value 'lower-lft' \(did you "
                                         r"mean 'lower-left'\?\)"):
        parse_profile({"page_origin": "lower-lft"}, "p.toml", "p")
    with pytest.raises(InputError, match="page_origin: expected one of auto, lower-left"):
        parse_profile({"page_origin": [1.0]}, "p.toml", "p")
    with pytest.raises(InputError, match="homing: unknown value 'never'"):
        parse_profile({"homing": "never"}, "p.toml", "p")
