"""``inkarm plan``: outputs, exit codes, and every shipped example plan."""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from inkarm.cli import main
from inkarm.core.trajectory import Drawing
from inkarm.io.planfile import load_plan
from inkarm.plans.realise import realise_plan

PLANS = sorted((Path(__file__).resolve().parents[2] / "scenarios" / "plans").glob("*.toml"))

TWO_STROKES = """
title = "test"
cov = 4.0
[model]
segment_time = 0.2
[[strokes]]
targets = [{ mean = [0.0, 0.0] }, { mean = [10.0, 20.0] }, { mean = [20.0, 0.0] }]
[[strokes]]
kind = "human_line"
points = [[30.0, 0.0], [60.0, 0.0]]
human_line = { duration = 0.5 }
"""


@pytest.fixture
def plan_file(tmp_path: Path) -> Path:
    path = tmp_path / "plan.toml"
    path.write_text(TWO_STROKES)
    return path


def test_writes_mean_csv_samples_and_figures(plan_file, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["plan", str(plan_file), "--out", str(out), "--samples", "3", "--seed", "5"]) == 0
    assert "2 strokes" in capsys.readouterr().out
    drawing = Drawing.from_csv(out / "mean.csv")
    expected = realise_plan(load_plan(plan_file, seed=5), samples=3)
    assert len(drawing.strokes) == 2
    for got, want in zip(drawing.strokes, expected.drawing.strokes):
        np.testing.assert_allclose(got.pos, want.pos)
        np.testing.assert_allclose(got.t, want.t)
    with np.load(out / "samples.npz") as z:
        n = sum(s.n for s in drawing.strokes)
        assert z["pos"].shape == (3, n, 2)
        np.testing.assert_allclose(z["t"], np.concatenate([s.t for s in drawing.strokes]))
        np.testing.assert_allclose(z["pos"], expected.stacked_samples()["pos"])
        assert z["stroke"].tolist() == [0] * drawing.strokes[0].n + [1] * drawing.strokes[1].n
    assert (out / "plan.png").stat().st_size > 1000
    assert (out / "plan.svg").read_text().lstrip().startswith("<?xml")


def test_no_samples_no_npz_and_seed_changes_the_samples(plan_file, tmp_path):
    assert main(["plan", str(plan_file), "--out", str(tmp_path / "a"), "--no-figure"]) == 0
    assert not (tmp_path / "a" / "samples.npz").exists()
    assert not (tmp_path / "a" / "plan.png").exists()
    for name, seed in (("b", "1"), ("c", "1"), ("d", "2")):
        args = [
            "plan",
            str(plan_file),
            "--out",
            str(tmp_path / name),
            "--samples",
            "2",
            "--seed",
            seed,
        ]
        assert main([*args, "--no-figure"]) == 0
    pos = {k: np.load(tmp_path / k / "samples.npz")["pos"] for k in "bcd"}
    np.testing.assert_array_equal(pos["b"], pos["c"])
    assert not np.allclose(pos["b"], pos["d"])


@pytest.mark.parametrize(
    ("content", "args", "message"),
    [
        (
            "[[strokes]]\ntargets = [{ mean = [0.0, 0.0], cov = -1.0 }]\n",
            [],
            r"plan.toml: strokes\[0\].targets\[0\].cov: covariance is not positive definite",
        ),
        (
            "[model]\nsegement_time = 0.3\n",
            [],
            r"model.segement_time: unknown key \(did you mean 'segment_time'\?\)",
        ),
        ("[[strokes\n", [], r"plan.toml: not valid TOML"),
        (TWO_STROKES, ["--samples", "-2"], r"--samples: expected an integer >= 0, got -2"),
        (TWO_STROKES, ["--seed", "-1"], r"--seed: expected an integer >= 0, got -1"),
    ],
)
def test_bad_input_exits_2_with_the_message(tmp_path, capsys, content, args, message):
    path = tmp_path / "plan.toml"
    path.write_text(content)
    assert main(["plan", str(path), "--out", str(tmp_path / "out"), *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("inkarm plan: error: ")
    assert re.search(message, err)
    assert "Traceback" not in err


THREE_TARGETS = """
[[strokes]]
targets = [{ mean = [0.0, 0.0] }, { mean = [10.0, 20.0] }, { mean = [20.0, 0.0] }]
"""
HOSTILE = [
    # (plan, args, message): each refused with one line naming the file and key, exit 2
    (TWO_STROKES, ["--samples", "1000000"],
     (r"--samples: samples per stroke: about 1e\+06 samples, more than the limit of 1e\+04 "
     r"samples \(raise it with the environment variable INKARM_MAX_SAMPLES\)")),
    ("samples = 1000000\n" + TWO_STROKES, [], r"plan.toml: samples: .*INKARM_MAX_SAMPLES"),
    ("cov = 4.0\n[model]\ndt = 0.0001\nsegment_time = 3600.0\n" + THREE_TARGETS, [],
     (r"plan.toml: strokes\[0\]\.model\.dt: time steps of the stroke \(3 x segment_time 3600 s / "
     r"dt 0.0001 s\): about 1\.08e\+08 time steps, .*INKARM_MAX_STEPS")),
    ("cov = 4.0\n[model]\ndt = 1e-9\n" + THREE_TARGETS, [],
     r"plan.toml: model.dt: expected a number in \[0.0001, 1\] s, got 1e-09"),
    (("[[strokes]]\ntargets = [{ mean = [1e300, 0.0], cov = 1.0 }, "
     "{ mean = [-1e300, 0.0], cov = 1.0 }]\n"),
     [], (r"plan.toml: strokes\[0\].targets\[0\].mean: expected coordinates in \[-1e\+06, "
     r"1e\+06\] mm, got 1e\+300")),
    ("[model]\nd = 1e-300\n[[strokes]]\ntargets = [{ mean = [0.0, 0.0], cov = 1.0 }]\n", [],
     r"plan.toml: model.d: expected a number in \[1e-06, 1e\+06\] mm, got 1e-300"),
    ("[[strokes]]\ntargets = [{ mean = [0.0, 0.0], std = 1e300 }]\n", [],
     (r"plan.toml: strokes\[0\].targets\[0\].std: expected numbers in \[1e-06, 1e\+06\] mm, "
     r"got 1e\+300")),
    ("[[strokes]]\ntargets = [{ mean = [0.0, 0.0], cov = [[1e200, 0.0], [0.0, 1e-200]] }]\n", [],
     r"plan.toml: strokes\[0\].targets\[0\].cov: expected variances .*got 1e\+200"),
    ("[semi_tied]\nh = 1e300\n[[strokes]]\ntargets = [{ mean = [0.0, 0.0] }]\n", [],
     r"plan.toml: semi_tied.h: expected a number in \[1e-12, 1e\+12\] mm\^2, got 1e\+300"),
    (("[[strokes]]\nkind = 'human_line'\npoints = [[0.0, 0.0], [1.0, 0.0]]\n"
     "human_line = { duration = 1e300 }\n"), [],
     r"plan.toml: strokes\[0\].human_line.duration: expected a number in \[0, 3600\] s"),
    (("samples = 10000\n[model]\ndt = 0.001\n[[strokes]]\nkind = 'minjerk'\n"
     "points = [[0.0, 0.0], [1.0, 0.0]]\nminjerk = { duration = 100.0 }\n"), [],
     r"plan.toml: samples: memory of realising the plan .*INKARM_MAX_MEMORY_MB"),
]


@pytest.mark.parametrize(("content", "args", "message"), HOSTILE)
def test_hostile_input_exits_2_with_one_line_quickly(tmp_path, capsys, content, args, message):
    path = tmp_path / "plan.toml"
    path.write_text(content)
    start = time.perf_counter()
    assert main(["plan", str(path), "--out", str(tmp_path / "out"), *args]) == 2
    assert time.perf_counter() - start < 2.0
    err = capsys.readouterr().err
    assert err.startswith("inkarm plan: error: ") and err.count("\n") == 1
    assert re.search(message, err), err
    assert "Traceback" not in err and not (tmp_path / "out").exists()


def test_raising_the_sample_limit_lets_samples_through(plan_file, tmp_path, monkeypatch):
    monkeypatch.setenv("INKARM_MAX_SAMPLES", "3")
    assert main(["plan", str(plan_file), "--out", str(tmp_path / "a"), "--samples", "4",
                 "--no-figure"]) == 2
    monkeypatch.setenv("INKARM_MAX_SAMPLES", "4")
    assert main(["plan", str(plan_file), "--out", str(tmp_path / "b"), "--samples", "4",
                 "--no-figure"]) == 0


def test_out_must_be_a_directory(plan_file, tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["plan", str(plan_file), "--out", str(blocker)]) == 2
    assert "exists and is not a directory" in capsys.readouterr().err


def test_missing_file_in_a_subprocess_prints_one_line_and_exits_2(tmp_path):
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "inkarm.cli",
            "plan",
            str(tmp_path / "nope.toml"),
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().endswith("nope.toml: no such plan file")
    assert "Traceback" not in proc.stderr


def test_shipped_plans_exist():
    names = {p.stem for p in PLANS}
    assert {
        "A_facilitation",
        "A_full_covariances",
        "N_samples",
        "G_semi_tied_handstyles",
        "human_lines",
    } <= names


@pytest.mark.parametrize("plan", PLANS, ids=[p.stem for p in PLANS])
def test_every_shipped_plan_runs(plan, tmp_path):
    assert main(["plan", str(plan), "--out", str(tmp_path), "--samples", "2"]) == 0
    drawing = Drawing.from_csv(tmp_path / "mean.csv")
    assert len(drawing.strokes) == len(load_plan(plan).strokes)
    lo, hi = drawing.bounds()
    assert np.all(hi - lo < 300.0)  # fits on a page
    assert (tmp_path / "plan.png").exists() and (tmp_path / "samples.npz").exists()
