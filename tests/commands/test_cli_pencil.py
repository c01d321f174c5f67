"""`inkarm pencil extract` and `inkarm pencil show`: a real scan's profile round trip, the
figure, and each bad input in one line naming the file or option."""

from __future__ import annotations

import re

import numpy as np
import pytest
from PIL import Image

from inkarm.cli import main
from inkarm.ink.graphite import render_scan
from inkarm.ink.pencil_extract import extract_profile
from inkarm.ink.pencil_profile import load_profile


@pytest.fixture(scope="module")
def scan(tmp_path_factory):
    path = tmp_path_factory.mktemp("scans") / "my_6b.png"
    Image.fromarray(render_scan("6B", length_mm=15.0, rng=np.random.default_rng(1))).save(path)
    return path


def test_extract_writes_the_profile_of_the_scan(tmp_path, scan, capsys):
    out = tmp_path / "mine.npz"
    assert main(["pencil", "extract", str(scan), "--out", str(out), "--dpi", "600",
                 "--force-n", "1.5", "--levels", "16"]) == 0
    profile = load_profile(out)
    expected = extract_profile(np.asarray(Image.open(scan)), name="my_6b", levels=16)
    assert profile.name == "my_6b" and profile.source == "my_6b.png"
    assert profile.reference_force_n == 1.5 and profile.levels == 16
    assert np.array_equal(profile.glcm, expected.glcm)
    assert profile.px_per_mm == pytest.approx(600 / 25.4)
    assert f"profile written to {out}" in capsys.readouterr().out
    assert [p.name for p in tmp_path.iterdir()] == ["mine.npz"]  # no partial file left


@pytest.mark.parametrize(("make", "options", "message"), [
    (None, [], r"missing.png: no such scan file"),
    (lambda p: p.write_text("x"), [], r"bad.png: cannot read the scan as an image"),
    (lambda p: Image.fromarray(np.full((30, 30, 3), (200, 0, 0), np.uint8)).save(p), [],
     r"bad.png: a colour image \(mode RGB\)"),
    (lambda p: Image.fromarray(np.full((30, 30), 250, np.uint8)).save(p), [],
     r"bad.png: no pencil line found"),
    ("scan", ["--levels", "300"], r"my_6b.png: --levels: expected 2 to 256 grey-level bins"),
    ("scan", ["--dpi", "0"], r"--dpi: expected a resolution in \(0, 1e6\) dpi, got 0"),
    ("scan", ["--force-n", "-1"], r"--force-n: expected a force in \(0, 1000\) N, got -1"),
])
def test_extract_refuses_bad_input_in_one_line(tmp_path, scan, capsys, make, options, message):
    if make == "scan":
        source = scan
    else:
        source = tmp_path / ("missing.png" if make is None else "bad.png")
        if make is not None:
            make(source)
    out = tmp_path / "p.npz"
    assert main(["pencil", "extract", str(source), "--out", str(out), *options]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert re.search(message, err[0]), err[0]
    assert not out.exists()


def test_extract_refuses_a_folder_or_the_scan_as_out(tmp_path, scan, capsys):
    assert main(["pencil", "extract", str(scan), "--out", str(tmp_path)]) == 2
    assert "is a folder: expected a profile file name" in capsys.readouterr().err
    assert main(["pencil", "extract", str(scan), "--out", str(scan)]) == 2
    assert "expected a profile file name (.npz)" in capsys.readouterr().err
    assert main(["pencil", "extract", str(scan), "--out", "/no/such/dir/p.npz"]) == 2
    assert "is not a writable folder" in capsys.readouterr().err


def test_show_writes_the_figure_and_the_line(tmp_path, capsys):
    out = tmp_path / "show"
    assert main(["pencil", "show", "hb", "--out", str(out), "--length-mm", "5",
                 "--px-per-mm", "10"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["line.png", "profile.png"]
    line = np.asarray(Image.open(out / "line.png"))
    assert line.shape[1] == 50 and line.min() < 200  # 5 mm at 10 px/mm, along x, inked
    assert "repair sweeps changed" in capsys.readouterr().out


@pytest.mark.parametrize(("options", "message"), [
    (["HBB"], r"PROFILE: unknown pencil grade 'HBB' \(did you mean 'HB'\?\)"),
    (["HB", "--length-mm", "0"], r"--length-mm: expected a length in \(0, 1000\] mm"),
    (["HB", "--px-per-mm", "1000"], r"--px-per-mm: expected 0.5 to 200 px/mm"),
    (["HB", "--seed", "-2"], r"--seed: expected a seed >= 0, got -2"),
])
def test_show_refuses_bad_input_before_any_work(tmp_path, capsys, options, message):
    out = tmp_path / "show"
    assert main(["pencil", "show", *options[:1], "--out", str(out), *options[1:]]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.search(message, err[0]), err
    assert not out.exists()
