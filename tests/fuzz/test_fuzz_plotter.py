"""Hostile input against the plotter's surfaces (issue 21): G-code lines into the emulated GRBL
(every line answered ``ok`` or ``error:N`` as GRBL does, never an exception, and the machine
still answering ``?`` afterwards), pen profiles through ``inkarm gcode``, and ``inkarm emulate``
options (refused in one line, or serving)."""

from __future__ import annotations

import math
import re
import tomllib
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.fuzz.strategies import FUZZ, check, mutated

ROOT = Path(__file__).resolve().parents[2]
PROFILES = {p.stem: tomllib.loads(p.read_text())
            for p in sorted((ROOT / "inkarm" / "hardware" / "plotter" / "profiles").glob("*.toml"))}
SIGNATURE = ROOT / "scenarios" / "traces" / "signature.svg"
REPLY = re.compile(r"(|ok|error:\d+|ALARM:\d+|\[MSG:.*\]|\[.*\]|>.*|\$\d+=.*|Grbl 1\.1h.*)")

pytestmark = [pytest.mark.slow, pytest.mark.fuzz]

WORD = st.one_of(
    st.sampled_from(["G0", "G1", "G2", "G3", "G4", "G10", "G17", "G20", "G21", "G28", "G28.1",
                     "G30", "G38.2", "G53", "G54", "G59", "G80", "G90", "G91", "G92", "G92.1",
                     "G93", "M0", "M2", "M3", "M5", "M8", "M9", "M30", "T1", "L2", "L20", "P1",
                     "$J=", "$H", "$X", "$C", "$#", "$G", "$I", "$$", "$N0=", "$RST=#", "$130=",
                     "$22=1", "$20=1", "(", ")", ";", "%"]),
    st.builds(lambda letter, number: f"{letter}{number}",
              st.sampled_from(list("XYZIJKRFSPNLTGM")),
              st.one_of(st.sampled_from(["1e9", "-0", "nan", "inf", "", ".", "--1", "1.2.3",
                                         "9" * 30, "-1e-300", "0x10"]),
                        st.floats(allow_nan=False, allow_infinity=False, width=32).map(
                            lambda v: f"{v:.4f}"))),
    st.text(alphabet=st.characters(codec="ascii"), max_size=6),
)


@st.composite
def gcode_lines(draw):
    return "".join(draw(st.lists(WORD, min_size=1, max_size=8)))[:200]


@FUZZ
@given(lines=st.lists(gcode_lines(), min_size=1, max_size=20),
       settings=st.sampled_from([{}, {22: 1}, {22: 1, 20: 1}]))
def test_gcode_lines_into_the_emulated_grbl(lines, settings):
    from inkarm.hardware.plotter.machine import GrblMachine

    machine = GrblMachine(settings)
    for line in lines:
        before = machine.lines_done
        machine.take_line(line)
        for _ in range(200):  # run the line's work; a long move need not finish
            machine.pump()
            if not machine.work:
                break
            dt = machine.next_event_s() - machine.time
            machine.advance(min(max(dt, 1e-4), 1.0) if math.isfinite(dt) else 0.01)
        assert machine.lines_done == before + 1
    for reply in machine.outbox:
        assert REPLY.fullmatch(reply), f"not a GRBL reply: {reply!r} (lines {lines!r})"
    machine.soft_reset()
    for _ in range(50):
        machine.pump()
        machine.advance(0.01)
    report = machine.status_report()
    assert report is None or report.startswith("<"), report


@FUZZ
@given(profile=st.sampled_from(sorted(PROFILES)).map(PROFILES.get).flatmap(
    lambda p: mutated(p, extra_keys=("unknown", "pen_down", "header", "page_origin",
                                     "homing"))),
       control=st.sampled_from(["", "\x18", "\x85", "?", "!", "\x00", "é"]))
def test_pen_profiles(run_cli, toml_text, tmp_path, profile, control):
    if control and isinstance(profile.get("pen_down"), list) and profile["pen_down"]:
        profile["pen_down"] = [f"{profile['pen_down'][0]}{control}"]
    (tmp_path / "pen.toml").write_text(toml_text(profile))
    outcome = run_cli(["gcode", str(SIGNATURE), "--profile", "pen.toml", "--out", "o.gcode"])
    check(outcome)
    if outcome.code == 0:
        text = (tmp_path / "o.gcode").read_text(encoding="ascii")
        assert all(c.isprintable() or c in "\n" for c in text), "a control byte in the G-code"


@FUZZ
@given(args=st.lists(st.sampled_from([
    ["--speedup", "0"], ["--speedup", "-1"], ["--speedup", "1e9"], ["--speedup", "nan"],
    ["--setting", "20=1"], ["--setting", "999=1"], ["--setting", "x"], ["--setting", "110=-5"],
    ["--setting", "110=nan"], ["--page", "0,0"], ["--page", "1e9,1"], ["--page", "a"],
    ["--px-per-mm", "1e9"], ["--px-per-mm", "0"], ["--fault", "error:0"],
    ["--fault", "alarm:-1:2"], ["--fault", "silent:1"], ["--fault", "disconnect:1e9"],
    ["--out", "/proc/x.png"], ["--out", "c.jpg"], ["--pen", "laser"]]), max_size=3).map(
        lambda groups: [a for g in groups for a in g]))
def test_emulate_grbl_options(run_cli, tmp_path, args):
    outcome = run_cli(["emulate", "grbl", *args], timeout_s=4)
    if outcome.timed_out:  # options accepted: it serves until Ctrl-C, the port printed
        assert "/dev/" in outcome.stdout, outcome.stderr[-500:]
        return
    check(outcome)
