"""Hostile input against every input format: exit 0 with a result, or exit 2 with one line.

Each case runs ``inkarm ...`` in a forked child under a memory limit and a timeout
(:mod:`conftest`). Strategies start from the shipped files and replace values with extremes
(huge, tiny, negative, non-finite, wrong types, control characters), add unknown keys, nest
deeply, or flip bytes. ``INKARM_FUZZ_EXAMPLES=500`` runs a longer campaign.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.fuzz.strategies import FUZZ, check, mutated

ROOT = Path(__file__).resolve().parents[2]
DEFAULT = tomllib.loads((ROOT / "inkarm" / "data" / "default.toml").read_text())
PLANS = sorted((ROOT / "scenarios" / "plans").glob("*.toml"))
SVG = (ROOT / "scenarios" / "traces" / "signature.svg").read_text()
HANDSTYLES = tomllib.loads((ROOT / "inkarm" / "data" / "handstyles.toml").read_text())

pytestmark = [pytest.mark.slow, pytest.mark.fuzz]


SCENARIO_BASE = {**DEFAULT, "cell": {"timestep": 0.002, "paper_size_mm": [210.0, 297.0]},
                 "controller": {"force_n": 1.0, "descend_s": 0.3}, "robot": {"name": "iiwa14"}}


@FUZZ
@given(scenario=mutated(SCENARIO_BASE))
def test_scenarios(run_cli, toml_text, tmp_path, scenario):
    (tmp_path / "job.toml").write_text(toml_text(scenario))
    check(run_cli(["draw", "job.toml", "--check", "--quiet", "--out", "o"]))


@FUZZ
@given(plan=st.sampled_from(PLANS).map(lambda p: tomllib.loads(p.read_text())).flatmap(mutated),
       samples=st.sampled_from(["0", "1", "3", "-1", "1000000", "1e9", "x"]))
def test_plan_files(run_cli, toml_text, tmp_path, plan, samples):
    (tmp_path / "plan.toml").write_text(toml_text(plan))
    check(run_cli(["plan", "plan.toml", "--out", "o", "--samples", samples]))


@FUZZ
@given(styles=mutated({"styles": {"mine": dict(next(iter(HANDSTYLES.get("styles",
                                                                       HANDSTYLES).values())))}}),
       text=st.sampled_from(["ab", "inkarm", "a b\nc"]))
def test_handstyle_files(run_cli, toml_text, tmp_path, styles, text):
    (tmp_path / "styles.toml").write_text(toml_text(styles))
    check(run_cli(["write", text, "--styles", "styles.toml", "--style", "mine", "--out", "o"]))


NUMBER_TEXT = st.one_of(
    st.sampled_from(["0", "1", "-5", "1e300", "-1e300", "1e-300", "1e400", "nan", "inf", "",
                     "1.5.5", "--1", "1e", ".", "9" * 400]),
    st.floats(allow_nan=False, allow_infinity=False).map(repr),
)


@st.composite
def svg_documents(draw):
    commands = []
    for _ in range(draw(st.integers(1, 6))):
        letter = draw(st.sampled_from(list("MmLlHhVvCcSsQqTtAaZzX")))
        numbers = " ".join(draw(st.lists(NUMBER_TEXT, max_size=8)))
        commands.append(f"{letter} {numbers}")
    d = "M 0 0 " + " ".join(commands)
    transform = draw(st.sampled_from([
        "", "rotate(1e400)", "scale(1e300)", "scale(0)", "translate(nan)", "matrix(1 0 0 1 0)",
        "skewX(90)", "rotate(45 1e300 0)", "scale(-1e-300)"]))
    depth = draw(st.sampled_from([0, 1, 50, 5000]))
    body = f'<path d="{d}" transform="{transform}"/>'
    body = "<g>" * depth + body + "</g>" * depth
    size = draw(st.sampled_from(['width="100mm" height="50mm"', 'width="1e300mm" height="1"',
                                 'width="0" height="0"', 'viewBox="0 0 0 0"', ""]))
    return f'<svg xmlns="http://www.w3.org/2000/svg" {size}>{body}</svg>'


@FUZZ
@given(svg=st.one_of(svg_documents(), st.binary(max_size=200).map(
    lambda b: SVG[: len(SVG) // 2] + b.decode("latin-1") + SVG[len(SVG) // 2:])),
       command=st.sampled_from(["restyle", "analyse"]),
       rate=st.sampled_from(["100", "1e9", "0", "-5", "nan"]))
def test_svg_traces(run_cli, tmp_path, svg, command, rate):
    (tmp_path / "t.svg").write_text(svg, errors="replace")
    args = [command, "t.svg", "--rate", rate]
    args += ["--out", "o"] if command == "restyle" else []
    check(run_cli(args))


@st.composite
def csv_documents(draw):
    header = draw(st.sampled_from(["t,x,y", "t,x,y,stroke", "\ufefft,x,y", "x,y", "t;x;y", ""]))
    rows = [",".join(draw(st.lists(NUMBER_TEXT, min_size=2, max_size=4)))
            for _ in range(draw(st.integers(0, 12)))]
    if draw(st.booleans()):  # a well-formed path with one extreme value in it
        rows = [f"{0.01 * i},{i},{i % 7}" for i in range(60)]
        rows[draw(st.integers(0, 59))] = f"0.3,{draw(NUMBER_TEXT)},1"
    return "\n".join([header, *rows]) + "\n"


@FUZZ
@given(csv=csv_documents(), command=st.sampled_from(["restyle", "analyse"]))
def test_csv_traces(run_cli, tmp_path, csv, command):
    (tmp_path / "t.csv").write_text(csv)
    args = [command, "t.csv"] + (["--out", "o"] if command == "restyle" else [])
    check(run_cli(args))


@FUZZ
@given(text=st.text(max_size=40), style=st.sampled_from(["cursive", "faithful", "graffiti"]),
       height=st.sampled_from(["10", "0", "-1", "1e300", "nan", "1e-300"]))
def test_write_text(run_cli, tmp_path, text, style, height):
    check(run_cli(["write", text, "--style", style, "--height", height, "--out", "o"]))


@FUZZ
@given(seed=st.sampled_from(["0", "-1", "1e9", "x", str(2**70)]),
       glyphs=st.sampled_from(["1", "3", "0", "-2", "100000", "1e9"]))
def test_tags(run_cli, tmp_path, seed, glyphs):
    check(run_cli(["tag", "--seed", seed, "--glyphs", glyphs, "--out", "o"]))
