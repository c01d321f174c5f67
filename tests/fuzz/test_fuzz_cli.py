"""Hostile input against every input format: exit 0 with a result, or exit 2 with one line.

Each case runs ``inkarm ...`` in a forked child under a memory limit and a timeout
(:mod:`conftest`). Strategies start from the shipped files and replace values with extremes
(huge, tiny, negative, non-finite, wrong types, control characters), add unknown keys, nest
deeply, or flip bytes. ``INKARM_FUZZ_EXAMPLES=500`` runs a longer campaign.
"""

from __future__ import annotations

import copy
import math
import os
import tomllib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

# A few hundred cases in CI; INKARM_FUZZ_EXAMPLES=N for a longer run (per test).
EXAMPLES = int(os.environ.get("INKARM_FUZZ_EXAMPLES", "30"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None,
                derandomize="INKARM_FUZZ_EXAMPLES" not in os.environ,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                                       HealthCheck.data_too_large])

ROOT = Path(__file__).resolve().parents[2]
DEFAULT = tomllib.loads((ROOT / "inkarm" / "data" / "default.toml").read_text())
PLANS = sorted((ROOT / "scenarios" / "plans").glob("*.toml"))
SVG = (ROOT / "scenarios" / "traces" / "signature.svg").read_text()
HANDSTYLES = tomllib.loads((ROOT / "inkarm" / "data" / "handstyles.toml").read_text())

pytestmark = [pytest.mark.slow, pytest.mark.fuzz]

EXTREME_NUMBERS = st.sampled_from([
    0, -1, 1, 2**31, 2**63 - 1, -(2**63), 0.0, -0.0, 1e-300, -1e-300, 5e-324, 1e300, -1e300,
    math.inf, -math.inf, math.nan, 1e6, 1e9, -1e9, 0.5, 1e-9, 123456.789,
])
WEIRD_VALUES = st.one_of(
    EXTREME_NUMBERS,
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(2**63), max_value=2**63 - 1),
    st.booleans(),
    st.text(max_size=12),
    st.sampled_from(["", "\r", "\x00", "a\x1bb", "../../etc/passwd", "NaN", "💥"]),
    st.lists(EXTREME_NUMBERS, max_size=4),
    st.lists(st.lists(EXTREME_NUMBERS, max_size=3), max_size=3),
    st.fixed_dictionaries({}, optional={"x": EXTREME_NUMBERS}),
)


def _paths(data, prefix=()):
    """Every path to a leaf or list element of nested TOML data."""
    if isinstance(data, dict):
        for k, v in data.items():
            yield (*prefix, k)
            yield from _paths(v, (*prefix, k))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            yield (*prefix, i)
            yield from _paths(v, (*prefix, i))


def _set(data, path, value):
    node = data
    for part in path[:-1]:
        node = node[part]
    node[path[-1]] = value


@st.composite
def mutated(draw, base: dict, extra_keys=("unknown", "force_n", "kp", "px_per_mm")):
    """``base`` with a few values replaced by weird ones, keys added or removed."""
    data = copy.deepcopy(base)
    paths = list(_paths(data))
    for _ in range(draw(st.integers(1, 3))):
        action = draw(st.sampled_from(["replace", "replace", "replace", "delete", "add"]))
        path = draw(st.sampled_from(paths))
        try:
            if action == "replace":
                _set(data, path, draw(WEIRD_VALUES))
            elif action == "delete":
                node = data
                for part in path[:-1]:
                    node = node[part]
                del node[path[-1]]
            else:
                node = data
                for part in path[:-1]:
                    node = node[part]
                if isinstance(node, dict):
                    node[draw(st.sampled_from(extra_keys))] = draw(WEIRD_VALUES)
        except (KeyError, IndexError, TypeError):
            pass  # an earlier mutation removed the path
        paths = list(_paths(data))
        if not paths:
            break
    return data


def _check(outcome):
    assert outcome.verdict() is None, (
        f"{outcome.verdict()}: inkarm {' '.join(outcome.argv)}\n{outcome.stderr[-2000:]}")


SCENARIO_BASE = {**DEFAULT, "cell": {"timestep": 0.002, "paper_size_mm": [210.0, 297.0]},
                 "controller": {"force_n": 1.0, "descend_s": 0.3}, "robot": {"name": "iiwa14"}}


@FUZZ
@given(scenario=mutated(SCENARIO_BASE))
def test_scenarios(run_cli, toml_text, tmp_path, scenario):
    (tmp_path / "job.toml").write_text(toml_text(scenario))
    _check(run_cli(["draw", "job.toml", "--check", "--quiet", "--out", "o"]))


@FUZZ
@given(plan=st.sampled_from(PLANS).map(lambda p: tomllib.loads(p.read_text())).flatmap(mutated),
       samples=st.sampled_from(["0", "1", "3", "-1", "1000000", "1e9", "x"]))
def test_plan_files(run_cli, toml_text, tmp_path, plan, samples):
    (tmp_path / "plan.toml").write_text(toml_text(plan))
    _check(run_cli(["plan", "plan.toml", "--out", "o", "--samples", samples]))


@FUZZ
@given(styles=mutated({"styles": {"mine": dict(next(iter(HANDSTYLES.get("styles",
                                                                       HANDSTYLES).values())))}}),
       text=st.sampled_from(["ab", "inkarm", "a b\nc"]))
def test_handstyle_files(run_cli, toml_text, tmp_path, styles, text):
    (tmp_path / "styles.toml").write_text(toml_text(styles))
    _check(run_cli(["write", text, "--styles", "styles.toml", "--style", "mine", "--out", "o"]))


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
    _check(run_cli(args))


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
    _check(run_cli(args))


@FUZZ
@given(text=st.text(max_size=40), style=st.sampled_from(["cursive", "faithful", "graffiti"]),
       height=st.sampled_from(["10", "0", "-1", "1e300", "nan", "1e-300"]))
def test_write_text(run_cli, tmp_path, text, style, height):
    _check(run_cli(["write", text, "--style", style, "--height", height, "--out", "o"]))


@FUZZ
@given(seed=st.sampled_from(["0", "-1", "1e9", "x", str(2**70)]),
       glyphs=st.sampled_from(["1", "3", "0", "-2", "100000", "1e9"]))
def test_tags(run_cli, tmp_path, seed, glyphs):
    _check(run_cli(["tag", "--seed", seed, "--glyphs", glyphs, "--out", "o"]))
