"""The emulated machine answers as GRBL 1.1h does (its report.c, gcode.c, system.c, settings.c,
limits.c and protocol.c read as facts), driven line by line without a port."""

import numpy as np
import pytest

from inkarm.errors import InputError
from inkarm.hardware.plotter.gcode_parser import MAX_LINE, filter_line, read_float
from inkarm.hardware.plotter.machine import GRBL_DEFAULTS, GrblMachine
from inkarm.hardware.plotter.settings import grbl_float, setting_lines


def fresh(**settings) -> GrblMachine:
    m = GrblMachine({int(k[1:]): v for k, v in settings.items()})
    m.outbox.clear()
    return m


def step(m: GrblMachine) -> None:
    dt = m.next_event_s()
    m.advance(max(min(dt, 1.0), 1e-9) if np.isfinite(dt) else 0.01)


def settle(m: GrblMachine, motion: bool = True) -> None:
    """Step machine time until the queued work is done (and, with ``motion``, the cycle)."""
    for _ in range(200_000):
        m.pump()
        if not m.work and (not motion or m.cycle_done or m.frozen):
            return
        step(m)
    raise AssertionError("the machine never settled")


def run(m: GrblMachine, line: str, settle_motion: bool = True) -> list[str]:
    """Send one line once the machine takes lines; step until its reply (and the motion)."""
    for _ in range(100_000):
        if m.accepts_line():
            break
        m.pump()
        step(m)
    m.take_line(line)
    settle(m, settle_motion)
    out = list(m.outbox)
    m.outbox.clear()
    return out


def test_power_up_banner_and_the_homing_lock():
    m = GrblMachine()
    assert m.outbox == ["", "Grbl 1.1h ['$' for help]"]
    m = GrblMachine({22: 1})
    assert m.outbox[-1] == "[MSG:'$H'|'$X' to unlock]" and m.state == "Alarm"
    m.outbox.clear()
    assert run(m, "G0 X-1") == ["error:9"]
    assert run(m, "$X") == ["[MSG:Caution: Unlocked]", "ok"]
    assert run(m, "$X") == ["ok"]  # no effect outside an alarm


def test_status_report_cadence_as_stock_grbl():
    """WCO on the first report after a reset, Ov on the next; then every 10th while idle;
    A: only with Ov:; a spindle change refreshes Ov: at once."""
    m = fresh()
    reports = [m.status_report() for _ in range(21)]
    wco = [i for i, r in enumerate(reports) if "|WCO:" in r]
    ov = [i for i, r in enumerate(reports) if "|Ov:" in r]
    assert wco == [0, 10, 20] and ov == [1, 11]
    assert reports[0] == "<Idle|MPos:0.000,0.000,0.000|FS:0,0|WCO:0.000,0.000,0.000>"
    assert reports[2] == "<Idle|MPos:0.000,0.000,0.000|FS:0,0>"
    run(m, "M3 S2000")  # clamped to $30
    assert m.status_report() == "<Idle|MPos:0.000,0.000,0.000|FS:0,1000|Ov:100,100,100|A:S>"
    assert "A:" not in m.status_report()
    run(m, "M8")
    assert m.status_report().endswith("|Ov:100,100,100|A:SF>")
    run(m, "M3 S0")  # S0: the PWM is off, so no S
    assert m.status_report().endswith("|FS:0,0|Ov:100,100,100|A:F>")
    m.take_line("G1 X-100 F3000")
    m.pump()
    m.advance(0.1)
    busy = [m.status_report() for _ in range(100)]
    assert np.all(np.diff([i for i, r in enumerate(busy) if "|Ov:" in r])[1:] == 20)
    assert np.all(np.diff([i for i, r in enumerate(busy) if "|WCO:" in r])[1:] == 30)
    assert busy[0].startswith("<Run|MPos:-") and "|FS:3000,0" in busy[0]


def test_report_mask_work_position_buffer_and_inches():
    m = fresh()
    run(m, "G10 L2 P1 X-100 Y-50")
    run(m, "G0 X10 Y5")
    run(m, "$10=2")
    assert m.status_report() == "<Idle|WPos:10.000,5.000,0.000|Bf:15,128|FS:0,0|" \
        "WCO:-100.000,-50.000,0.000>"
    assert m.status_report(rx_free=100) == "<Idle|WPos:10.000,5.000,0.000|Bf:15,100|FS:0,0|" \
        "Ov:100,100,100>"
    run(m, "$13=1")  # inches, and the work offset is refreshed at once
    assert m.status_report() == "<Idle|WPos:0.3937,0.1969,0.0000|Bf:15,128|FS:0.0,0|" \
        "WCO:-3.9370,-1.9685,0.0000>"


def test_work_coordinates_and_their_report():
    m = fresh()
    for line in ("G10 L2 P1 X-100 Y-50", "G0 X10 Y10", "G10 L20 P2 X0 Y0", "G56", "G92 X1",
                 "G28.1", "G0 X0 Y0", "G30.1"):
        assert run(m, line) == ["ok"], line
    assert m.position == pytest.approx([-91.0, 0.0, 0.0])
    assert run(m, "$#") == [
        "[G54:-100.000,-50.000,0.000]", "[G55:-90.000,-40.000,0.000]",
        "[G56:0.000,0.000,0.000]", "[G57:0.000,0.000,0.000]", "[G58:0.000,0.000,0.000]",
        "[G59:0.000,0.000,0.000]", "[G28:-90.000,-40.000,0.000]",
        "[G30:-91.000,0.000,0.000]", "[G92:-91.000,0.000,0.000]", "[TLO:0.000]",
        "[PRB:0.000,0.000,0.000:0]", "ok"]
    assert run(m, "$G") == ["[GC:G0 G56 G17 G21 G90 G94 M5 M9 T0 F0 S0]", "ok"]
    assert run(m, "G28 X5") == ["ok"]  # via X5 (work) to the stored G28 X, Y kept
    assert m.position == pytest.approx([-90.0, 0.0, 0.0])
    assert run(m, "G53 G0 X-5 Y-6") == ["ok"]
    assert m.position == pytest.approx([-5.0, -6.0, 0.0])
    m.soft_reset()  # keeps the stored systems, clears G92 and selects G54
    settle(m)
    m.outbox.clear()
    assert run(m, "$#")[8] == "[G92:0.000,0.000,0.000]"
    assert m.status_report().endswith("|WCO:-100.000,-50.000,0.000>")
    assert run(m, "$RST=#")[:2] == ["[MSG:Restoring defaults]", "ok"]
    assert run(m, "$#")[0] == "[G54:0.000,0.000,0.000]"


@pytest.mark.parametrize("line, reply", [
    ("G4", "error:28"), ("G4 P-1", "error:4"), ("F-100", "error:4"), ("G0 G1", "error:24"),
    ("G1 X1 P1 F1", "error:36"), ("G1 X1 R1 F1", "error:36"), ("G1 X1", "error:22"),
    ("G2 X1 R0.4 F100", "error:34"), ("G2 X0 R1 F100", "error:33"), ("G18 G2 Y1 I1 F100",
                                                                       "error:32"),
    ("G10 L3 P1 X0", "error:20"), ("G10 L2 P1 R1 X0", "error:20"), ("G59.1", "error:23"),
    ("G38.1 X1", "error:20"), ("M7", "error:20"), ("M3.5", "error:23"), ("G54 G55", "error:21"),
    ("M3 M5", "error:21"), ("G92", "error:26"), ("G43.1 Z1 X1", "error:37"),
    ("G17 G40 G49 G80 G94 G90 G21 G54 M5 M9 T1 S0 N5", "ok"), ("G4 P0", "ok"), ("M1", "ok"),
    ("G91.1", "ok"), ("G61", "ok"), ("G43.1 Z1", "ok"), ("G1", "error:22"), ("G0", "ok"),
    ("$", "[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]"),
    ("$I", "[VER:1.1h.20190830:]"), ("$N5", "error:3"), ("$N=G0", "error:2"),
    ("$10", "error:3"), ("$10=", "error:2"), ("$10=1x", "error:3"), ("$256=1", "error:3"),
    ("$100=-1", "error:4"), ("$0=2.9", "error:6"), ("$20=1", "error:10"), ("$H", "error:5"),
    ("$HX", "error:5"), ("$SLPX", "error:3"), ("$RST=x", "error:3"), ("$J=X1", "error:22"),
    ("$J=M3 X1 F10", "error:16"), ("$J=X1 S1 F10", "error:36"), ("$CX", "error:3")])
def test_replies_and_error_codes(line, reply):
    m = fresh()
    assert run(m, line, settle_motion=False)[0] == reply


def test_line_limit_after_filtering():
    kept, overflow = filter_line("g1 x1 (a comment) /y2 ; tail")
    assert (kept, overflow) == ("G1X1Y2", False)
    assert filter_line("G0X" + "0" * (MAX_LINE - 3))[1] is False
    assert filter_line("G0X" + "0" * (MAX_LINE - 2))[1] is True
    m = fresh()
    assert run(m, "G0 " + " " * 60 + "X" + "0" * 76) == ["ok"]
    assert run(m, "G0X" + "0" * 77) == ["error:11"]
    assert read_float("1.5.2", 0) == (1.5, 3) and read_float("-.", 0) is None


def test_settings_defaults_print_and_checks():
    lines = setting_lines(GRBL_DEFAULTS)
    assert lines[:11] == ["$0=10", "$1=25", "$2=0", "$3=0", "$4=0", "$5=0", "$6=0", "$10=1",
                          "$11=0.010", "$12=0.002", "$13=0"]
    assert "$30=1000" in lines and "$100=250.000" in lines and "$132=200.000" in lines
    assert grbl_float(-0.0, 3) == "0.000" and grbl_float(-0.0004, 3) == "-0.000"
    assert grbl_float(0.0125, 3) == "0.013" and grbl_float(1234.5, 0) == "1235"
    m = fresh()
    assert run(m, "$22=1") == ["ok"] and run(m, "$20=1") == ["ok"]
    assert run(m, "$22=0") == ["ok"] and "$20=0" in run(m, "$$")  # homing off: limits off
    assert run(m, "$1=25.9") == ["ok"] and "$1=25" in run(m, "$$")
    with pytest.raises(InputError, match=r"\$20=1: GRBL 1.1h refuses it \(error:10"):
        GrblMachine({20: 1})
    GrblMachine({20: 1, 22: 1})  # in either order


def test_startup_lines_run_at_reset_and_after_homing():
    m = fresh()
    assert run(m, "$N0=G21 G91") == ["ok"] and run(m, "$N1=G20G0") == ["ok"]
    assert run(m, "$N") == ["$N0=G21G91", "$N1=G20G0", "ok"]
    m.soft_reset()
    settle(m)
    assert m.outbox == ["", "Grbl 1.1h ['$' for help]", ">G21G91:ok", ">G20G0:ok"]
    m.outbox.clear()
    assert run(m, "$N0=G5") == ["error:20"]
    run(m, "$22=1")
    assert run(m, "$H")[-3:] == [">G21G91:ok", ">G20G0:ok", "ok"]


def test_soft_limit_alarm_freezes_until_reset():
    m = fresh(**{"$22": 1, "$20": 1})
    assert m.state == "Alarm"
    assert run(m, "$H") == ["ok"]
    assert m.position == pytest.approx([-1.0, -1.0, -1.0])
    assert run(m, "G0 X-50") == ["ok"]
    assert run(m, "G1 X10 F1000") == ["ALARM:2", "[MSG:Reset to continue]"]
    assert m.frozen and m.status_report() is None and not m.accepts_line()
    m.soft_reset()
    assert m.outbox == ["ok"]  # the held line's ok at once; the banner once reset (30 ms)
    settle(m)
    assert m.outbox == ["ok", "", "Grbl 1.1h ['$' for help]", "[MSG:'$H'|'$X' to unlock]"]
    m.outbox.clear()
    assert run(m, "$X") == ["[MSG:Caution: Unlocked]", "ok"]
    assert run(m, "$J=X1 F100") == ["error:15"]  # a jog outside: refused, no alarm
    assert run(m, "$J=G91 X-1 F600") == ["ok"] and m.position[0] == pytest.approx(-51.0)


def test_soft_reset_during_motion_raises_alarm_3_and_keeps_position():
    m = fresh()
    m.take_line("G1 X-100 F3000")
    m.pump()
    m.advance(0.5)
    m.soft_reset()
    assert m.outbox == ["ok", "ALARM:3"]
    m.advance(0.5)
    m.pump()
    assert m.outbox == ["ok", "ALARM:3"]  # GRBL waits 0.5 s after an alarm, then resets
    settle(m)
    assert m.outbox[2:] == ["", "Grbl 1.1h ['$' for help]", "[MSG:'$H'|'$X' to unlock]"]
    assert m.state == "Alarm" and -100 < m.position[0] < 0


def test_check_mode_runs_nothing_and_ends_with_a_reset():
    m = fresh()
    assert run(m, "$C") == ["[MSG:Enabled]", "ok"]
    assert run(m, "G0 X-100") == ["ok"] and run(m, "G4 P100") == ["ok"]
    assert m.position[0] == 0.0 and m.time < 1.0 and m.state == "Check"
    assert run(m, "M2") == ["[MSG:Pgm End]", "ok"]
    assert run(m, "$C") == ["[MSG:Disabled]", "ok", "", "Grbl 1.1h ['$' for help]"]
    assert m.state == "Idle"


def test_jogging_and_its_cancel_byte():
    m = fresh()
    assert run(m, "$J=G91 X-100 F600", settle_motion=False) == ["ok"]
    assert m.state == "Jog" and run(m, "G0 X1", settle_motion=False) == ["error:9"]
    m.advance(1.0)
    m.jog_cancel_byte()
    m.advance(1.0)
    m.pump()
    assert m.state == "Idle" and -11 < m.position[0] < -9
    assert m.gc.position[0] == pytest.approx(m.position[0], abs=0.02)  # synced to the stop
    assert run(m, "$SLP") == ["ok", "[MSG:Sleeping]"] and not m.accepts_line()
    m.soft_reset()
    settle(m)
    assert m.outbox[-1] == "[MSG:'$H'|'$X' to unlock]"


def test_dwell_is_idle_and_program_end_resets_the_modes():
    m = fresh()
    m.take_line("G4 P0.5")
    m.pump()
    assert m.state == "Idle" and not m.accepts_line()
    run(m, "G91 G1 X-1 F100 M3 S500")
    assert run(m, "M2") == ["[MSG:Pgm End]", "ok"]
    assert run(m, "$G") == ["[GC:G1 G54 G17 G21 G90 G94 M5 M9 T0 F100 S500]", "ok"]
    m.take_line("M0")  # a program pause: Hold:0, its ok only after the resume
    for _ in range(3):
        m.pump()
    assert m.state == "Hold:0" and m.outbox == []
    m.cycle_start()
    settle(m)
    assert m.outbox == ["ok"] and m.state == "Idle"


def test_overrides_rescale_the_queued_motion_and_refresh_ov():
    m = fresh()
    m.take_line("G1 X-100 F3000")
    m.pump()
    m.advance(1.0)
    m.status_report(), m.status_report()  # (WCO, then Ov: the counters are spent)
    m.override(0x92)
    m.override(0x92)  # feed -20 %
    m.advance(0.5)
    assert m.planner.speed == pytest.approx(40.0)
    assert m.status_report().endswith("|FS:2400,0|Ov:80,100,100>")
    m.override(0x94)
    assert "|Ov:79,100,100" in m.status_report()
    for _ in range(30):
        m.override(0x92)
    assert m.overrides[0] == 10  # GRBL's floor
    m.override(0x97)
    m.override(0x9A)
    assert m.overrides == [10, 25, 110]


def test_limit_switches_pins_and_homing_failures():
    m = GrblMachine({22: 1, 25: 3000.0}, home_distance_mm=5.0)
    m.outbox.clear()
    assert run(m, "$X")[-1] == "ok"
    assert run(m, "G0 X6") == ["ok"]
    assert "|Pn:X|" in m.status_report()  # past the + switch, 5 mm from power-up
    assert run(m, "G0 X0")
    assert run(m, "$H") == ["ok"]
    assert m.position == pytest.approx([-1.0, -1.0, -1.0]) and m.pins() == ""
    assert m.physical() == pytest.approx([4.0, 4.0, 4.0], abs=0.01)
    far = GrblMachine({22: 1, 130: 2.0, 131: 2.0, 132: 2.0}, home_distance_mm=50.0)
    far.outbox.clear()
    assert run(far, "$H") == ["ALARM:9", "ok", "", "Grbl 1.1h ['$' for help]",
                              "[MSG:'$H'|'$X' to unlock]"]  # no switch within 1.5 x travel
    assert far.state == "Alarm"


def test_hard_limit_alarm_freezes():
    m = GrblMachine({21: 1, 22: 1}, home_distance_mm=5.0)
    m.outbox.clear()
    assert run(m, "$X")[-1] == "ok"
    m.outbox.clear()
    assert run(m, "G1 X10 F600") == ["ok", "ALARM:1", "[MSG:Reset to continue]"]
    assert m.frozen and 4.98 <= m.position[0] < 5.1
    m.soft_reset()
    settle(m)
    assert m.outbox[-2:] == ["[MSG:Check Limits]", "[MSG:'$H'|'$X' to unlock]"]


def test_dwell_waits_whole_50_ms_steps_and_the_cycle_ends_after_idle_lock():
    m = fresh()
    t0 = m.time
    run(m, "G4 P0.151")
    assert m.time - t0 == pytest.approx(0.2)  # ceil(20 x 0.151) x 50 ms
    m.take_line("G0 X-1")
    m.pump()
    while not m.planner.empty:
        step(m)
    assert m.state == "Run"  # GRBL's st_go_idle waits $1 = 25 ms
    m.advance(0.026)
    assert m.state == "Idle"


def test_amass_levels_and_step_counts_rounded_while_moving_floored_at_a_hold():
    """stepper.c: AMASS levels 3/2/1/0 below 2/4/8 kHz and above; a moving stepper has taken
    the steps its continuous progress has passed half-way (Bresenham counters at half); a
    stopped hold has taken whole steps only, a step boundary to float precision not."""
    from inkarm.hardware.plotter.planner import Planner
    from inkarm.hardware.plotter.stepper import amass_level, step_position

    assert [amass_level(r) for r in (1999, 2000, 3999, 4000, 7999, 8000)] == [3, 2, 2, 1, 1, 0]
    spm = np.array([250.0, 250.0, 250.0])
    planner = Planner(accel=[10.0] * 3, max_rate=[8.0] * 3, deviation_mm=0.01)
    planner.add(np.zeros(3), np.array([10.0, 0.0, 0.0]), 5.0)
    block = planner.blocks[0]
    planner.speed, block.entry_sqr = 5.0, 25.0  # 1250 steps/s: level 3 (entered moving)
    for done_steps, taken in ((0.4, 0), (0.6, 1), (699.4, 699), (699.6, 700)):
        block.length = 10.0 - done_steps / 250.0
        assert step_position(planner, np.zeros(3), spm)[0] == pytest.approx(taken / 250.0)
    planner.speed, block.entry_sqr = 0.0, 0.0  # a finished hold
    for done_steps, taken in ((699.9, 699), (700.0, 699), (700.01, 700)):
        block.length = 10.0 - done_steps / 250.0
        assert step_position(planner, np.zeros(3), spm)[0] == pytest.approx(taken / 250.0)


def test_a_hold_ends_when_its_last_whole_step_is_done():
    """The braking segments of a hold run whole steps at the rate of their fractional ones:
    the hold ends up to a segment before the continuous stop, never after it."""
    from inkarm.hardware.plotter.planner import Planner
    from inkarm.hardware.plotter.stepper import hold_tail_s

    spm = np.array([250.0, 250.0, 250.0])
    planner = Planner(accel=[10.0] * 3, max_rate=[8.0] * 3, deviation_mm=0.01)
    planner.add(np.zeros(3), np.array([20.0, 0.0, 0.0]), 5.0)
    block = planner.blocks[0]
    tails = []
    for stop_mm in np.linspace(2.0, 2.004, 9):  # the stop anywhere within a step
        block.length = 20.0 - stop_mm
        tails.append(hold_tail_s(block, spm, 0.0, 0.5))
    assert all(0.0 <= t <= 0.05 for t in tails) and max(tails) > 0.005
    assert hold_tail_s(block, spm, 0.5, 0.5) == 0.0


def test_an_override_in_motion_acts_after_the_prepared_segments():
    """protocol.c re-plans at once but stepper.c re-prepares only from the end of the ready
    segments: the speed holds until then, then rises toward the new feed."""
    m = fresh()
    run(m, "G1 X50 F300", settle_motion=False)
    m.advance(1.0)  # cruising at 5 mm/s
    assert m.planner.speed == pytest.approx(5.0)
    m.override(0x91)  # +10 %
    assert m.pending_override == (110, 100) and m.override_at > m.time
    m.advance(m.override_at - m.time - 1e-4)
    assert m.planner.speed == pytest.approx(5.0)
    m.advance(0.02)
    assert 5.0 < m.planner.speed <= 5.5 and m.pending_override is None


def test_spindle_stop_in_a_hold_reports_the_overrides_next():
    """spindle_control.c spindle_set_state zeroes the override report counter: after 0x9E the
    next report carries Ov: and A: without the spindle."""
    m = fresh()
    run(m, "M3 S500")
    run(m, "M8")
    m.status_report(), m.status_report()  # (WCO, then Ov)
    m.feed_hold()
    settle(m)
    assert m.state == "Hold:0"
    m.status_report()
    m.toggle_spindle_stop()
    report = m.status_report()
    assert "|Ov:100,100,100|A:F>" in report and "FS:0,0" in report
