"""Hostile input against the surfaces added since 0.1 (issue 21): robot profiles, regression
baselines, sweep tables and designs, motor-primitive options and models, pencil scans and
profiles. Every case: exit 0 with a result (or 1 for an honest regression failure), or exit 2
with one line; never a traceback, a hang or a memory blow-up; and never a failure reported as
success (a damaged baseline never passes).

``INKARM_FUZZ_EXAMPLES=N`` runs N cases per test (``scripts/fuzz_campaign.py`` runs them all and
counts)."""

from __future__ import annotations

import json
import math
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.fuzz.strategies import EXAMPLES, EXTREME_NUMBERS, FUZZ, WEIRD_VALUES, check, mutated

ROOT = Path(__file__).resolve().parents[2]
ROBOTS = {p.stem: tomllib.loads(p.read_text())
          for p in sorted((ROOT / "inkarm" / "robots" / "data").glob("*.toml"))
          if not p.stem.startswith("menagerie")}
QUICK = ROOT / "scenarios" / "quick_stroke.toml"
BASELINE = ROOT / "scenarios" / "baselines" / "quick_stroke"
PENCIL = ROOT / "inkarm" / "data" / "pencils"
# cases that run a simulation or EM are a few seconds each: fewer of them in CI
FEW = settings(FUZZ, max_examples=max(3, EXAMPLES // 3))

pytestmark = [pytest.mark.slow, pytest.mark.fuzz]


def _fresh(folder: Path) -> Path:
    """Empty ``folder`` (hypothesis runs every example of a test in one tmp_path)."""
    for child in folder.iterdir():
        shutil.rmtree(child) if child.is_dir() and not child.is_symlink() else child.unlink()
    return folder


@FUZZ
@given(robot=st.sampled_from(sorted(ROBOTS)).map(ROBOTS.get).flatmap(mutated))
def test_robot_profiles(run_cli, toml_text, tmp_path, robot):
    _fresh(tmp_path)
    (tmp_path / "robot.toml").write_text(toml_text(robot))
    check(run_cli(["draw", str(QUICK), "--robot", "robot.toml", "--check", "--quiet",
                   "--out", "o"]))


def _finite_metrics(text: str) -> bool:
    """Whether a metrics.json text is a table of finite numbers (or nulls) with every metric a
    baseline records (the only kind a comparison may pass against)."""
    try:
        data = json.loads(text)
    except ValueError:
        return False
    from inkarm.jobs.regress.baseline import REQUIRED_METRICS

    def trusted(value) -> bool:
        return value is None or (isinstance(value, int | float) and not isinstance(value, bool)
                                 and math.isfinite(value))

    return isinstance(data, dict) and all(k in data for k in REQUIRED_METRICS) and all(
        trusted(v) for v in data.values())


@st.composite
def damaged_baselines(draw):
    """(file name, new bytes) for one file of the quick_stroke baseline."""
    name = draw(st.sampled_from(["metrics.json", "baseline.json", "canvas.png", "path.npz"]))
    original = (BASELINE / name).read_bytes()
    how = draw(st.sampled_from(["mutate", "truncate", "garbage", "empty"]))
    if how == "mutate" and name.endswith(".json"):
        data = json.loads(original)
        data = draw(mutated(data)) if isinstance(data, dict) and data else data
        return name, json.dumps(data, allow_nan=True).encode()
    if how == "truncate":
        return name, original[: draw(st.integers(0, max(0, len(original) - 1)))]
    if how == "garbage":
        return name, draw(st.binary(max_size=300))
    if how == "mutate":  # a binary file: flip a few bytes
        data = bytearray(original)
        for _ in range(draw(st.integers(1, 4))):
            data[draw(st.integers(0, len(data) - 1))] ^= draw(st.integers(1, 255))
        return name, bytes(data)
    return name, b""


@FEW
@given(damage=damaged_baselines())
def test_baselines(run_cli, tmp_path, damage):
    _fresh(tmp_path)
    name, content = damage
    shutil.copy(QUICK, tmp_path / "quick_stroke.toml")
    shutil.copytree(BASELINE, tmp_path / "baselines" / "quick_stroke")
    (tmp_path / "baselines" / "quick_stroke" / name).write_bytes(content)
    outcome = run_cli(["regress", "quick_stroke.toml", "--baselines", "baselines"],
                      timeout_s=60)
    check(outcome, allowed=(0, 1, 2))
    if name == "metrics.json" and not _finite_metrics(content.decode("utf-8", "replace")):
        assert outcome.code == 2, f"a damaged baseline passed:\n{outcome.stdout}"


@FEW
@given(content=st.one_of(st.binary(max_size=400), st.sampled_from(["other", "truncated"])))
def test_sweep_tables(run_cli, tmp_path, content):
    """A results.parquet that is garbage, truncated or of another scenario is refused; a
    resumed sweep never takes it as its finished rows."""
    _fresh(tmp_path)
    import pyarrow as pa
    import pyarrow.parquet as pq

    out = tmp_path / "o"
    out.mkdir()
    table = out / "results.parquet"
    if isinstance(content, bytes):
        table.write_bytes(content)
    else:
        pq.write_table(pa.Table.from_pylist([{"point_id": "x", "index": 0, "status": "ok",
                                              "scenario_digest": "0" * 16}]), table)
        if content == "truncated":
            table.write_bytes(table.read_bytes()[:-20])
    outcome = run_cli(["sweep", str(QUICK), "--set", "controller.force_n=1", "--out", "o",
                       "--quiet", "--workers", "1"], timeout_s=60)
    check(outcome)
    assert outcome.code == 2, "a table that is not this sweep's was taken"


COUNT = st.sampled_from(["0", "1", "2", "-1", "1000000000000", "1000000", "x", "1.5", ""])
VALUE = st.one_of(EXTREME_NUMBERS.map(str), st.sampled_from(["a", "", ",", "1,,2", ":", "1:2"]))


@st.composite
def sweep_arguments(draw):
    keys = ["controller.force_n", "controller.hover_mm", "placement.scale", "ink.model",
            "seed", "controller.forse_n", "nonsense", ""]
    args = []
    for _ in range(draw(st.integers(0, 3))):
        key = draw(st.sampled_from(keys))
        spec = draw(st.sampled_from(["range", "list", "one", "span"]))
        if spec == "range":
            value = f"{draw(VALUE)}:{draw(VALUE)}:{draw(COUNT)}"
        elif spec == "span":
            value = f"{draw(VALUE)}:{draw(VALUE)}"
        elif spec == "list":
            value = ",".join(draw(st.lists(VALUE, min_size=1, max_size=3)))
        else:
            value = draw(VALUE)
        args += ["--set", f"{key}={value}"]
    if draw(st.booleans()):
        args += ["--seeds", draw(st.sampled_from(["0:2", "0:1000000000", "5:1", "x", "-1:3",
                                                   "1,2", "0:100001"]))]
    design = draw(st.sampled_from([[], ["--zip"], ["--random", draw(COUNT)]]))
    return args + design


@FEW
@given(args=sweep_arguments())
def test_sweep_designs(run_cli, tmp_path, args):
    _fresh(tmp_path)
    outcome = run_cli(["sweep", str(QUICK), *args, "--out", "o", "--quiet", "--workers", "1"],
                      timeout_s=90)
    check(outcome)


OPTION = st.sampled_from(["0", "1", "2", "-1", "1000000000", "3", "x", "1e9", "nan"])


@FEW
@given(option=st.sampled_from(["--chains", "--states", "--iterations", "--sweeps",
                               "--restarts", "--samples"]), value=OPTION)
def test_primitives_learn_options(run_cli, tmp_path, option, value):
    _fresh(tmp_path)
    args = {"--chains": "2", "--states": "3", "--iterations": "2", "--sweeps": "2",
            "--restarts": "1", "--samples": "3"} | {option: value}
    check(run_cli(["primitives", "learn", "letter:a", *[x for kv in args.items() for x in kv],
                   "--out", "m.npz", "--quiet"], timeout_s=60))


@FUZZ
@given(arrays=st.fixed_dictionaries({}, optional={
    k: st.one_of(EXTREME_NUMBERS.map(np.array), st.just(np.zeros((0, 3))),
                 st.just(np.array(["text"])), st.just(np.full((3, 3), np.nan)))
    for k in ("version", "W", "advance", "C", "mu", "channels", "scale", "rate_hz")}))
def test_primitive_models(run_cli, tmp_path, arrays):
    _fresh(tmp_path)
    base = dict(np.load(ROOT / "inkarm" / "data" / "primitives_a.npz"))
    np.savez(tmp_path / "m.npz", **(base | arrays))
    check(run_cli(["primitives", "scribble", "m.npz", "--out", "o", "--duration", "1"]))


@FUZZ
@given(kind=st.sampled_from(["L", "RGB", "I;16", "F", "P", "1", "LA"]),
       shape=st.tuples(st.sampled_from([0, 1, 3, 40, 200]), st.sampled_from([0, 1, 5, 300])),
       fill=st.sampled_from(["random", "white", "black", "line"]))
def test_pencil_scans(run_cli, tmp_path, kind, shape, fill):
    _fresh(tmp_path)
    from PIL import Image

    rows, cols = shape
    rng = np.random.default_rng(rows * 1000 + cols)
    grey = {"random": rng.integers(0, 256, (rows, cols)), "white": np.full((rows, cols), 255),
            "black": np.zeros((rows, cols))}.get(fill, np.full((rows, cols), 255))
    if fill == "line" and rows > 2:
        grey[rows // 2 - 1: rows // 2 + 1] = 60
    if rows and cols:
        image = Image.fromarray(grey.astype(np.uint8)).convert(kind)
        image.save(tmp_path / "scan.png", format="PNG" if kind != "F" else "TIFF")
    else:
        (tmp_path / "scan.png").write_bytes(b"\x89PNG\r\n\x1a\n")
    check(run_cli(["pencil", "extract", "scan.png", "--out", "p.npz"]))


@FUZZ
@given(key=st.sampled_from(["format", "version", "name", "mid_hist", "full_hist", "glcm",
                            "offsets", "width_mm", "px_per_mm", "reference_force_n"]),
       value=WEIRD_VALUES.filter(lambda v: not isinstance(v, dict)))
def test_pencil_profiles(run_cli, tmp_path, key, value):
    _fresh(tmp_path)
    profile = next(iter(sorted(PENCIL.glob("*.npz"))))
    arrays = dict(np.load(profile))
    try:
        arrays[key] = np.array(value)
    except (ValueError, OverflowError):
        arrays[key] = np.array(str(value))
    if arrays[key].dtype == object:
        arrays[key] = np.array(str(value))
    np.savez(tmp_path / "p.npz", **arrays)
    check(run_cli(["pencil", "show", "p.npz", "--out", "o"]))
