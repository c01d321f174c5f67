"""The emulated EiBotBoard (firmware 3.0.3) without a port: each command's reply and errors
against the firmware (EggBot repository ``EBB_firmware/app.X/source``, ``ebb.c``/``UBW.c``) and
its command reference (``docs/ebb.html``, the command's section), step generation against a
tick-by-tick reference of the ISR, the FIFO, the pen servo's timing and the ink."""

import numpy as np
import pytest

from inkarm.analysis.metrics import ink_chamfer_mm
from inkarm.errors import InputError
from inkarm.hardware.axidraw.ebb_machine import EbbMachine, travel_mm
from inkarm.hardware.axidraw.ebb_motion import TICK_S
from inkarm.hardware.axidraw.ebb_servo import BOOT_DOWN, BOOT_UP, height_pct
from inkarm.hardware.axidraw.geometry import STEPS_PER_MM
from inkarm.ink.canvas import Canvas

ONE = 1 << 31
VERSION = "EBBv13_and_above EB Firmware Version 3.0.3\r\n"


def send(m: EbbMachine, text: str, step_s: float = 0.005) -> str:
    """Run one command as the emulator's loop does (time passes while the parser waits for
    FIFO room) and return its whole reply."""
    while not m.accepts_line():
        m.advance(step_s)
    m.take_line(text)
    while not m.accepts_line():
        m.advance(step_s)
    reply = "".join(m.outbox)
    m.outbox.clear()
    return reply


def settle(m: EbbMachine, limit_s: float = 60.0) -> None:
    end = m.time + limit_s
    while not m.idle and m.time < end:
        m.advance(0.01)
    assert m.idle


@pytest.fixture
def m():
    return EbbMachine("V3")


# -- replies at boot (legacy syntax) ---------------------------------------------------------


@pytest.mark.parametrize("command, reply", [
    ("V", VERSION),  # "V": the version line, no OK
    ("QS", "0,0\n\rOK\r\n"),  # "QS": counters, then \n\r (code: kLE_REV), OK
    ("qs", "0,0\n\rOK\r\n"),  # case-insensitive ("Syntax and conventions")
    ("QP", "1\n\rOK\r\n"),  # "QP": the pen starts up
    ("QE", "0,0\n\rOK\r\n"),  # "QE": both drivers off at boot
    ("QB", "0\r\nOK\r\n"),  # "QB"
    ("QR", "0\n\rOK\r\n"),  # "QR": servo power off at boot ("SR")
    ("QG", "10\r\n"),  # "QG": only bit 4 (pen up), two hex digits, no OK
    ("QM", "QM,0,0,0,0\n\r"),  # "QM": no OK
    ("ES", "0\n\rOK\r\n"),  # "ES": nothing interrupted
    ("CS", "OK\r\n"),
    ("QU,2", "QU,32\r\nOK\r\n"),  # "QU": maximum FIFO length
    ("QU,3", "QU,1\r\nOK\r\n"),  # the FIFO is one command deep at boot ("CU", 4)
    ("QL,21", "0\r\nOK\r\n"),
    ("QN", "0\r\nOK\r\n"),
    ("QT", "\r\nOK\r\n"),  # "QT": an empty line when no nickname
    ("QC", "394,300\r\nOK\r\n"),  # "QC" (the code does not zero-pad)
    ("SC,4,20000", "OK\r\n"),
    ("SR,60000", "OK\r\n"),
    ("SL,7,3", "OK\r\n"),
    ("NI", "OK\r\n"),
    ("EM,1", ""),  # the code returns before replying when Enable2 is missing
    ("R", "OK\r\n"),
])
def test_reply_of_each_query_and_command_at_boot(m, command, reply):
    assert send(m, command) == reply


@pytest.mark.parametrize("command, reply", [
    ("XY", "!8 Err: Unknown command 'XY:5859'\r\n"),  # "Returned Errors", !8
    ("B", "!8 Err: Unknown command 'B:42'\r\n"),
    ("SM,100", "!4 Err: Missing parameter(s)\r\n"),  # !4
    ("SM,100A", "!5 Err: Need comma next, found: 'A'\r\n"),  # !5
    ("TP,-1", "!6 Err: Invalid parameter value\r\n"),  # !6: a sign on an unsigned value
    ("SM,0,10", "!6 Err: Invalid parameter value\r\n"),  # "SM": Duration 0 is invalid
    ("SM,10,1,1,4", "!6 Err: Invalid parameter value\r\n"),  # Clear 0..3
    ("SM,10,2147483648", "!6 Err: Invalid parameter value\r\n"),  # steps: signed 32 bits
    ("SC,256,1", "!6 Err: Invalid parameter value\r\n"),  # "SC": Value1 0..255
    ("SC,4,65536", "!6 Err: Invalid parameter value\r\n"),  # Value2 0..65535
    ("CU,1,2", "!6 Err: Invalid parameter value\r\n"),
    ("QU,7", "QU,!6 Err: Invalid parameter value\r\n"),  # QU echoes its name even in legacy
    ("V,1", VERSION + "!7 Err: Extra parameter\r\n"),  # !7, checked after the handler
    ("SM,1,100", "!0 Err: <axis1> step rate too high\n\r\r\n"),  # 100 kHz > 25 kHz
    ("SM,1000,0,30000", "!0 Err: <axis2> step rate too high\n\r\r\n"),
    ("SM,4294967295,1", "!0 Err: <axis1> step rate too slow\n\r\r\n"),  # < 1.164e-5 Hz
])
def test_errors_as_the_firmware_words_them(m, command, reply):
    assert send(m, command) == reply
    assert m.queue.idle  # nothing was queued


def test_an_extra_parameter_after_a_queued_move_follows_its_ok(m):
    assert send(m, "SM,10,1,1,0,0") == "OK\r\n!7 Err: Extra parameter\r\n"
    settle(m)
    assert m.queue.counters == [1, 1]


def test_future_syntax_mode_prefixes_replies_and_ends_them_with_newline(m):
    assert send(m, "CU,10,1") == "\n"  # "CU", 10: the switch itself answers <NL>
    assert send(m, "QS") == "QS,0,0\n"
    assert send(m, "V") == "V," + VERSION[:-2] + "\n"
    assert send(m, "SM,100") == "SM,!4 Err: Missing parameter(s)\n"  # the reference's examples
    assert send(m, "SM,100A") == "SM,!5 Err: Need comma next, found: 'A'\n"
    assert send(m, "TP,-1") == "TP,!6 Err: Invalid parameter value\n"
    assert send(m, "BB") == "BB,!8 Err: Unknown command 'BB:4242'\n"
    assert send(m, "QM") == "QM,0,0,0,0\n"
    assert send(m, "CU,10,0") == "CUOK\r\n"  # ... and back in legacy: CUOK<CR><NL>
    assert send(m, "R") == "OK\r\n"


def test_checksums_when_required(m):
    # "CU", 54: 0x100 minus the byte sum; the reference's examples: V,100 -> expected 170
    assert send(m, "CU,54,1") == "OK\r\n"
    assert send(m, "V,100") == "!9 Err: Checksum incorrect, expected 170\r\n"
    assert send(m, "V") == "!10 Err: No checksum found but required\r\n"
    assert send(m, "V,170") == VERSION
    assert send(m, "SM,1000,1000,1000,153") == "OK\r\n"
    assert send(m, "CU,54,0,0") == "!9 Err: Checksum incorrect, expected 119\r\n"
    assert send(m, "CU,10,1,126") == "\n"
    assert send(m, "V") == "V,!10 Err: No checksum found but required\n"
    assert send(m, "CU,54,0,119") == "CU\n"
    assert send(m, "QS") == "QS,0,0\n"


def test_ack_off_drops_ok_but_not_values(m):
    assert send(m, "CU,1,0") == "\r\n"
    assert send(m, "SM,10,0,0") == "\r\n"
    assert send(m, "QS") == "0,0\n\r\r\n"
    assert send(m, "R") == "\r\n"
    assert send(m, "CS") == "OK\r\n"  # R restores the power-on options


# -- steps and time --------------------------------------------------------------------------


def _wrap(v):
    return ((v + ONE) % (1 << 32)) - ONE


def isr_reference(moves, acc=(0, 0)):
    """The step ISR tick by tick, as ``high_ISR`` does it (unsigned 32-bit accumulators, bit 31
    means a step): (end tick of each move, counters, accumulators)."""
    acc, counters, tick, ends = list(acc), [0, 0], 0, []
    for kind, rates, steps, accels, signs, clear in moves:
        for axis in (0, 1):
            if clear & (1 << axis):
                acc[axis] = 0
        rate, accel, left = list(rates), list(accels), list(steps)
        active = [left[0] != 0, left[1] != 0]
        if kind == "LT":  # time-limited: steps[0] is the intervals, both axes run
            active = [left[0] != 0, left[0] != 0]
        while True:
            tick += 1
            for axis in (0, 1):
                if not active[axis]:
                    continue
                if kind in ("LM", "LT"):
                    rate[axis] = _wrap(rate[axis] + accel[axis])
                acc[axis] = (acc[axis] + rate[axis]) % (1 << 32)
                if acc[axis] & ONE:
                    acc[axis] &= ONE - 1
                    forward = signs[axis] > 0 if kind == "SM" else rate[axis] >= 0
                    counters[axis] += 1 if forward else -1
                    if kind != "LT":
                        left[axis] -= 1
                        active[axis] = left[axis] != 0
            if kind == "LT":
                left[0] -= 1
                active = [left[0] != 0, left[0] != 0]
            if not any(active):
                break
        ends.append(tick)
    return ends, counters, acc


def test_sm_steps_and_end_ticks_match_the_isr_tick_by_tick(m):
    rng = np.random.default_rng(7)
    moves, commands = [], []
    for _ in range(12):
        ms = int(rng.integers(150, 400))  # (at most 20 kHz)
        s1, s2 = (int(v) for v in rng.integers(-3000, 3000, 2))
        s1 = s1 or 1
        clear = int(rng.integers(0, 4))
        rate = [int(np.float32(abs(s)) * (np.float32(85899345.92) / np.float32(ms))) for s in
                (s1, s2)]
        moves.append(("SM", rate, (abs(s1), abs(s2)), (0, 0), (np.sign(s1), np.sign(s2)), clear))
        commands.append(f"SM,{ms},{s1},{s2},{clear}")
    ends, counters, acc = isr_reference(moves)
    assert send(m, "CU,4,32") == "OK\r\n"
    for text in commands:
        assert send(m, text) == "OK\r\n"
    start = m.queue.tick
    settle(m)
    assert m.queue.counters == counters
    assert m.queue.acc == acc
    assert m.queue.tick >= start + ends[-1]


def test_lm_with_acceleration_matches_the_isr(m):
    # LM,Rate1,Steps1,Accel1,Rate2,Steps2,Accel2,Clear: the ISR starts from Rate - Accel/2
    # (C division, towards zero)
    lm = [(42950000, 50, 13400, 8592000, 75, 687), (17179000, 75, -687, 8592000, 75, 687)]
    moves = [("LM", (r1 - int(a1 / 2), r2 - int(a2 / 2)), (s1, s2), (a1, a2), (1, 1), 3)
             for r1, s1, a1, r2, s2, a2 in lm]
    ends, counters, acc = isr_reference(moves)
    assert send(m, "CU,4,4") == "OK\r\n"
    start = m.queue.tick
    for r1, s1, a1, r2, s2, a2 in lm:
        assert send(m, f"LM,{r1},{s1},{a1},{r2},{s2},{a2},3") == "OK\r\n"
    settle(m)
    assert m.queue.counters == counters == [125, 150]
    assert m.queue.acc == acc
    # "LM" example 7: 75 steps from 200 to 100 steps/s (and 100 to 200) take 500 ms
    assert (ends[1] - ends[0]) * TICK_S == pytest.approx(0.5, abs=0.002)
    assert m.queue.tick - start >= ends[-1]


def test_lm_and_lt_backwards_and_through_zero_match_the_isr(m):
    # negative Steps with a positive Rate runs backwards ("LM" direction note); a rate that
    # decelerates through zero reverses (LT); Clear 3 starts a backwards move at 2^31 - 1
    rng = np.random.default_rng(3)
    assert send(m, "CU,4,32") == "OK\r\n"
    moves, start = [], m.queue.tick
    for _ in range(6):
        r1, r2 = (int(v) for v in rng.integers(1_000_000, 60_000_000, 2))
        s1, s2 = (int(v) for v in rng.integers(-300, 300, 2))
        a1, a2 = (int(v) for v in rng.integers(-2000, 2000, 2))
        assert send(m, f"LM,{r1},{s1 or 1},0,{r2},{s2},0") == "OK\r\n"
        sign1, sign2 = (-1 if s1 < 0 else 1), (-1 if s2 < 0 else 1)
        moves.append(("LM", (sign1 * r1, sign2 * r2), (abs(s1 or 1), abs(s2)), (0, 0), (1, 1),
                      0))
        ticks = int(rng.integers(100, 3000))
        assert send(m, f"LT,{ticks},{-r1},{a1},{r2},{-a2},3") == "OK\r\n"
        first = [-r1 - int(a1 / 2), r2 - int(-a2 / 2)]
        moves.append(("LT", tuple(first), (ticks, 0), (a1, -a2), (1, 1), 3))
    ends, counters, acc = isr_reference_negated(moves)
    settle(m)
    assert m.queue.counters == counters
    assert m.queue.acc == acc
    assert m.queue.tick - start >= ends[-1]


def test_moves_longer_than_a_computed_chunk_match_the_isr(m):
    # the emulator computes at most 25,000 ticks at once: an accelerating LT of 1.2 s and an SM
    # of 1.5 s cross that boundary
    assert send(m, "CU,4,4") == "OK\r\n"
    assert send(m, "LT,30000,-3000000,100,5000000,-150,3") == "OK\r\n"
    assert send(m, "SM,1500,-5000,7000") == "OK\r\n"
    rates = [int(np.float32(s) * (np.float32(85899345.92) / np.float32(1500))) for s in
             (5000, 7000)]
    ends, counters, acc = isr_reference_negated([
        ("LT", (-3000000 - 50, 5000000 + 75), (30000, 0), (100, -150), (1, 1), 3),
        ("SM", rates, (5000, 7000), (0, 0), (-1, 1), 0)])
    settle(m)
    assert (m.queue.counters, m.queue.acc) == (counters, acc)
    assert m.queue.tick >= ends[-1]


def isr_reference_negated(moves):
    """:func:`isr_reference`, with a cleared accumulator set to 2^31 - 1 when its axis starts
    backwards (``process_low_level_move``)."""
    acc, counters, ends, tick = [0, 0], [0, 0], [], 0
    for move in moves:
        kind, rates, steps, accels, signs, clear = move
        seed = list(acc)
        for axis in (0, 1):
            if clear & (1 << axis):
                seed[axis] = ONE - 1 if rates[axis] + accels[axis] < 0 else 0
        end, moved, acc = isr_reference([(kind, rates, steps, accels, signs, 0)], seed)
        tick += end[0]
        ends.append(tick)
        counters = [counters[0] + moved[0], counters[1] + moved[1]]
    return ends, counters, acc


@pytest.mark.parametrize("one, same", [
    # "TD": the two T3 moves it loads (the second without Clear, as the code does)
    (["TD,5000,30000000,9000000,-3000,2,20000000,4000000,1000,-1,3"],
     ["T3,5000,30000000,0,2,20000000,0,-1,3", "T3,5000,9000000,-3000,-2,4000000,1000,1"]),
    # "L3" with no jerk is "LM"; "T3" with no jerk is "LT"
    (["L3,42950000,50,13400,0,8592000,75,687,0,3"], ["LM,42950000,50,13400,8592000,75,687,3"]),
    (["T3,2000,-42950000,1340,0,8592000,-687,0,3"], ["LT,2000,-42950000,1340,8592000,-687,3"]),
])
def test_derived_low_level_moves_equal_their_definitions(one, same):
    results = []
    for commands in (one, same):
        m = EbbMachine("V3")
        assert send(m, "CU,4,8") == "OK\r\n"
        for text in commands:
            assert send(m, text) == "OK\r\n"
        settle(m)
        results.append((m.queue.counters, m.queue.acc, m.queue.tick))
    assert results[0] == results[1]
    assert results[0][0] != [0, 0]


def test_a_1000_ms_move_ends_at_one_second_of_machine_time(m):
    assert send(m, "SM,1000,1000,-500") == "OK\r\n"
    m.advance(0.999)
    while m.queue.status()[0]:
        m.advance(TICK_S)
    # the rate is truncated (float32), so the last step lands one 40 us tick late
    assert m.time == pytest.approx(1.0, abs=3 * TICK_S)
    assert send(m, "QS") == "1000,-500\n\rOK\r\n"


def test_delay_lasts_its_duration_and_is_capped_at_100_s(m):
    assert send(m, "SM,250,0,0") == "OK\r\n"
    m.advance(0.249)
    assert send(m, "QM") == "QM,1,0,0,0\n\r"
    m.advance(0.002)
    assert send(m, "QM") == "QM,0,0,0,0\n\r"
    assert send(m, "SM,200000,0") == "OK\r\n"
    m.advance(99.99)
    assert m.queue.status()[0] == 1
    m.advance(0.02)
    assert m.queue.status()[0] == 0


def test_fifo_is_one_deep_and_a_third_move_holds_the_parser(m):
    assert send(m, "SM,1000,100,100") == "OK\r\n"
    m.advance(0.01)  # the first one executes; the second waits in the FIFO
    assert send(m, "SM,1000,100,100") == "OK\r\n"
    assert send(m, "QM") == "QM,1,1,1,1\n\r"
    assert send(m, "QG") == "1F\r\n"  # pen up, command, both motors, FIFO
    m.take_line("SM,1000,100,100")  # the third: the parser spins, no reply yet
    assert not m.accepts_line() and m.outbox == []
    while not m.accepts_line():
        m.advance(0.001)
    assert m.time == pytest.approx(1.0, abs=0.002)  # queued when the first move ended
    assert m.outbox == ["OK\r\n"]


def test_cu_4_deepens_the_fifo_and_qu_6_counts_waiting_moves(m):
    assert send(m, "CU,4,3") == "OK\r\n"
    assert send(m, "QU,3") == "QU,3\r\nOK\r\n"
    assert send(m, "SM,100,10,10") == "OK\r\n"
    m.advance(0.001)  # the ISR takes the first one: three more fit
    for _ in range(2):
        assert send(m, "SM,100,10,10") == "OK\r\n"
    m.take_line("SM,100,10,10")
    assert m.accepts_line() and m.outbox == ["OK\r\n"]  # three wait, none spins
    m.outbox.clear()
    assert send(m, "QU,6") == "QU,3\r\nOK\r\n"
    assert send(m, "CU,4,99") == "OK\r\n"  # waits for the queue to empty; capped at 32
    assert m.idle and send(m, "QU,3") == "QU,32\r\nOK\r\n"


def test_es_stops_a_move_midway_and_flushes_the_fifo(m):
    assert send(m, "SM,1000,1000,0") == "OK\r\n"
    assert send(m, "SM,1000,1000,0") == "OK\r\n"
    m.advance(0.5)
    assert send(m, "ES") == "1\n\rOK\r\n"
    steps = m.queue.counters[0]
    assert 490 <= steps <= 510
    m.advance(1.0)
    assert m.queue.counters[0] == steps and send(m, "QM") == "QM,0,0,0,0\n\r"
    assert send(m, "ES,1") == "0\n\rOK\r\n" and send(m, "QE") == "0,0\n\rOK\r\n"


def test_hm_waits_for_motion_then_goes_home_at_its_step_rate(m):
    assert send(m, "SM,200,400,-100") == "OK\r\n"
    assert send(m, "HM,1000") == "OK\r\n"  # queued once the SM is done
    assert m.time >= 0.2
    start = m.time
    settle(m)
    assert send(m, "QS") == "0,0\n\rOK\r\n"
    assert m.time - start == pytest.approx(0.4, abs=0.02)  # 400 steps at 1 kHz
    assert send(m, "HM,25000,-50,50") == "OK\r\n"
    settle(m)
    assert send(m, "QS") == "-50,50\n\rOK\r\n"


def test_em_sets_microsteps_clears_counters_and_scales_the_carriage(m):
    assert send(m, "SM,100,80,80") == "OK\r\n"  # 80 sixteenth-steps on both: x 1 mm
    settle(m)
    assert m.position_mm() == pytest.approx((1.0, 0.0))
    assert send(m, "EM,2,1") == "OK\r\n"
    settle(m)
    assert send(m, "QE") == "8,8\n\rOK\r\n" and send(m, "QS") == "0,0\n\rOK\r\n"
    assert send(m, "XM,100,40,0") == "OK\r\n"  # A 40 -> 40,40 eighth-steps: x 1 mm more
    settle(m)
    assert m.position_mm() == pytest.approx((2.0, 0.0))
    assert send(m, "EM,0,5") == "OK\r\n"
    settle(m)
    assert send(m, "QE") == "0,8\n\rOK\r\n"  # Enable2 does not change the step mode


def test_geometry_mixing_matches_the_axidraw_software(m):
    # plotink/axidraw: steps1 = 2032/in * (dx + dy), steps2 = 2032/in * (dx - dy)
    dx, dy = 30.0, 20.0
    s1, s2 = round(STEPS_PER_MM * (dx + dy)), round(STEPS_PER_MM * (dx - dy))
    assert send(m, f"SM,500,{s1},{s2}") == "OK\r\n"
    settle(m)
    assert m.position_mm() == pytest.approx((dx, dy))


def test_the_frame_stops_the_carriage_and_the_steps_are_lost(m):
    assert send(m, "XM,500,-800,0") == "OK\r\n"  # 10 mm to the left of home
    settle(m)
    assert m.position_mm() == pytest.approx((0.0, 0.0)) and m.frame_hits > 0
    assert send(m, "XM,500,800,0") == "OK\r\n"
    settle(m)
    assert m.position_mm() == pytest.approx((10.0, 0.0))  # not back at 0: 10 mm were lost
    assert travel_mm("V3A3") == pytest.approx((430.0, 297.0), abs=0.1)
    with pytest.raises(InputError, match="V3A3"):
        EbbMachine("V4")


# -- pen servo -------------------------------------------------------------------------------


def test_pen_moves_at_the_configured_rate_every_24_ms(m):
    up, down, rate = 20000, 15000, 500
    for text in (f"SC,4,{up}", f"SC,5,{down}", f"SC,12,{rate}", "SP,1"):
        assert send(m, text) == "OK\r\n"
    m.advance(0.2)
    assert m.servo.value == up
    assert send(m, "SP,0") == "OK\r\n"
    m.advance(0.001)
    assert send(m, "QP") == "0\n\rOK\r\n"
    cycles = (up - down) // rate  # FAQ 1: (max - min) * 24 ms / rate
    m.advance(0.024 * (cycles - 1))
    assert m.servo.value > down
    m.advance(0.025)
    assert m.servo.value == down
    assert m.servo.height_pct == pytest.approx(height_pct(down), abs=1.0)


def test_sp_duration_delays_the_next_move_and_the_servo_powers_on(m):
    assert send(m, "QR") == "0\n\rOK\r\n"
    assert send(m, "SP,0,300") == "OK\r\n"
    assert send(m, "QR") == "1\n\rOK\r\n"
    assert send(m, "SM,100,10,10") == "OK\r\n"
    m.advance(0.299)
    assert m.queue.counters == [0, 0]
    m.advance(0.11)
    assert m.queue.counters == [10, 10]


def test_servo_power_times_out_and_sr_0_keeps_it_on(m):
    assert send(m, "SR,1000") == "OK\r\n"
    assert send(m, "SP,1") == "OK\r\n"
    m.advance(0.99)
    assert send(m, "QR") == "1\n\rOK\r\n"
    m.advance(0.02)
    assert send(m, "QR") == "0\n\rOK\r\n"
    assert send(m, "SR,0") == "OK\r\n" and send(m, "TP") == "OK\r\n"
    m.advance(100.0)
    assert send(m, "QR") == "1\n\rOK\r\n" and send(m, "QP") == "0\n\rOK\r\n"


def test_boot_servo_positions_and_sp_3_keeps_queued_pen_moves_up(m):
    assert (m.servo.up, m.servo.down) == (BOOT_UP, BOOT_DOWN)
    assert send(m, "SM,500,0,0") == "OK\r\n"
    assert send(m, "SP,0") == "OK\r\n"  # waits in the FIFO behind the delay
    assert send(m, "SP,3") == "OK\r\n"  # up now, down := up, the queued SP,0 re-aimed up
    settle(m)
    assert send(m, "QP") == "1\n\rOK\r\n" and m.servo.value == BOOT_UP


def test_s2_drives_the_pen_pin_and_s2_0_stops_it_at_once(m):
    assert send(m, "S2,18000,4,0,100") == "OK\r\n"  # RP4 = B1, the pen servo; 100 ms delay
    assert send(m, "SM,10,0,0") == "OK\r\n"
    m.advance(0.05)
    assert m.servo.value == 18000 and m.queue.status()[0] == 1
    assert send(m, "S2,0,4") == "OK\r\n"  # immediate, not queued
    assert m.servo.value == 0 and not m.servo.enabled
    assert send(m, "S2,1000,25") == "!6 Err: Invalid parameter value\r\n"  # pins 0..24


def test_button_press_is_reported_once_by_qb_and_by_qg(m):
    m.button = True
    assert send(m, "QG") == "30\r\n"  # bit 5 PRG and bit 4 pen up
    assert send(m, "QG") == "10\r\n"
    m.button = True
    assert send(m, "QB") == "1\r\nOK\r\n"
    assert send(m, "QB") == "0\r\nOK\r\n"


# -- ink -------------------------------------------------------------------------------------


def test_a_square_drawn_with_xm_lands_at_the_right_page_mm():
    canvas = Canvas(size_mm=(297.0, 210.0), px_per_mm=5)
    m = EbbMachine("V3", canvas)
    k = STEPS_PER_MM  # XM: A = k dx, B = k dy (steps1 = A + B, steps2 = A - B)

    def xm(dx, dy, ms):
        return send(m, f"XM,{ms},{round(k * dx)},{round(k * dy)}")

    for text in ("SC,4,20641", "SC,5,15248", "SC,11,1618", "SC,12,1078", "SP,1,300",
                 "EM,1,1"):
        assert send(m, text) == "OK\r\n"
    assert xm(40, 30, 400) == "OK\r\n"  # pen up to machine (40, 30)
    assert send(m, "SP,0,400") == "OK\r\n"
    for dx, dy in ((50, 0), (0, 50), (-50, 0), (0, -50)):
        assert xm(dx, dy, 1000) == "OK\r\n"
    assert send(m, "SP,1,300") == "OK\r\n" and xm(-40, -30, 400) == "OK\r\n"
    settle(m)
    assert m.position_mm() == pytest.approx((0.0, 0.0), abs=1e-9)
    # machine (x, y) -> page (x, 210 - y): the square spans page x 40..90, y 130..180
    square = np.array([[40, 180], [90, 180], [90, 130], [40, 130], [40, 180]], float)
    assert canvas.n_strokes == 1
    assert ink_chamfer_mm(canvas.image, canvas.px_per_mm, [square]) < 0.3
