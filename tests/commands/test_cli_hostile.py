"""Hostile input to ``inkarm analyse``, ``restyle`` and ``tag``: each is refused with exit 2
and one line naming the file and the option or setting at fault, before any large allocation
or long computation (the cases below would otherwise take minutes or tens of GiB)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from inkarm.cli import main

SVG = '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">{}</svg>'
PATH = '<path d="M 10 10 L 90 10 L 90 90"/>'


def write_csv(path, n: int, rows: list[str] | None = None):
    """A smooth 2-D trace of ``n`` samples at 100 Hz (or the given rows under a header)."""
    if rows is None:
        t = np.arange(n) * 0.01
        x, y = 50 + 30 * np.cos(t), 50 + 20 * np.sin(2 * t)
        rows = [",".join(repr(float(v)) for v in row) for row in zip(t, x, y)]
    path.write_text("t,x,y\n" + "\n".join(rows) + "\n")
    return path


def refused(capsys, argv, *needles):
    """Run the CLI; it must exit 2 with one line on stderr holding every needle."""
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"inkarm {argv[0]}: error: ")
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])
    assert "Traceback" not in err
    return lines[0]


@pytest.fixture
def svg(tmp_path):
    path = tmp_path / "trace.svg"
    path.write_text(SVG.format(PATH))
    return path


# -- SVG traces: --speed and --rate ------------------------------------------------------


def test_svg_sampled_at_an_absurd_rate_is_refused_by_its_range(svg, tmp_path, capsys):
    # Once: 3.2e9 samples, 29 GiB of arrays.
    refused(capsys, ["restyle", svg, "--rate", "1e9", "--out", tmp_path / "o"],
            "trace.svg", "--rate", "must lie in [0.001, 1e+07] Hz", "got 1e+09")


def test_svg_samples_are_estimated_before_sampling(svg, tmp_path, capsys):
    line = refused(capsys, ["restyle", svg, "--rate", "1e6", "--out", tmp_path / "o"],
                   "trace.svg", "--rate", "160 mm of paths at 50 mm/s sampled at 1e+06 Hz",
                   "about 3.2e+06 time steps", "INKARM_MAX_STEPS")
    assert "lower the rate or raise the speed" in line
    assert not (tmp_path / "o").exists()  # refused before the output folder is made


@pytest.mark.parametrize("speed", ["1e-300", "1e300", "0", "nan", "-5"])
def test_svg_speed_out_of_range_is_refused(svg, capsys, speed):
    refused(capsys, ["analyse", svg, "--speed", speed], "trace.svg", "--speed",
            "must lie in [0.001, 100000] mm/s")


@pytest.mark.parametrize(
    ("body", "needles"),
    [
        ('<path d="M 0 0 L 1e300 0 L 1e300 1e300"/>',
         ["<path>: coordinates overflow", "1e+300 mm", "|x|, |y| <= 1e+06 mm"]),
        ('<path transform="rotate(1e400)" d="M 0 0 L 10 0 L 10 10"/>',
         ["<path>: transform 'rotate(1e400)': arguments must be numbers"]),
        ('<path id="big" transform="scale(1e300)" d="M 0 0 L 10 0"/>',
         ["<path> id='big': transform 'scale(1e300)'"]),
        ('<polyline points="0,0 1e-300,0 1e-300,1e-300"/>', ["no drawable"]),
    ],
)
def test_svg_finite_extremes_are_refused_naming_the_element(tmp_path, capsys, body, needles):
    path = tmp_path / "extreme.svg"
    path.write_text(SVG.format(body))
    for command in (["analyse", path], ["restyle", path, "--out", tmp_path / "o"]):
        refused(capsys, command, "extreme.svg", *needles)


def test_svg_page_larger_than_a_kilometre_is_refused(tmp_path, capsys):
    path = tmp_path / "page.svg"
    path.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="1e300mm" height="10mm">'
                    f"{PATH}</svg>")
    refused(capsys, ["analyse", path], "page.svg", "<svg width='1e300mm'>", "up to 1e+06 mm")


# -- CSV traces --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("rows", "needles"),
    [
        (["0,0,0", "1,1e300,0", "2,2,1"], ["c.csv:3: x = 1e+300 mm is outside |x| <= 1e+06 mm"]),
        (["0,0,0", "1,1,-2e6", "2,2,1"], ["c.csv:3: y = -2e+06 mm is outside"]),
        (["0,0,0", "1e300,1,0", "2e300,2,1"], ["c.csv:3: t = 1e+300 s is outside"]),
        (["0,0,0", "1,1e400,0"], ["c.csv:3: NaN or inf value"]),
        (["0,0,0", "1," + "9" * 5000 + ",0"], ["c.csv:3: line longer than 4096 characters"]),
        (["0,0,0", '1,"' + ("1" * 4000 + "\n") * 40 + '",0'], ["c.csv:", "not CSV (field larger"]),
    ],
)
def test_csv_extremes_are_refused_naming_the_line(tmp_path, capsys, rows, needles):
    path = write_csv(tmp_path / "c.csv", 0, rows)
    refused(capsys, ["analyse", path], *needles)


def test_csv_rows_are_counted_against_the_step_budget(tmp_path, capsys, monkeypatch):
    path = write_csv(tmp_path / "rows.csv", 5000)
    monkeypatch.setenv("INKARM_MAX_STEPS", "2000")
    refused(capsys, ["analyse", path], "rows.csv", "rows of samples (line 2002",
            "more than the limit of 2000 time steps", "INKARM_MAX_STEPS")
    # A file far too big for the budget is refused from its size, before it is parsed.
    monkeypatch.setenv("INKARM_MAX_STEPS", "10")
    refused(capsys, ["analyse", path], "rows.csv", "rows of a 0.", "MB CSV file",
            "INKARM_MAX_STEPS")


# -- analyse: the DPPLA budget -----------------------------------------------------------


def test_exact_dppla_over_the_step_budget_is_refused_with_a_hint(tmp_path, capsys):
    # Once: 29 s (8.6e9 DP steps) for 5,000 samples.
    path = write_csv(tmp_path / "five.csv", 5000)
    refused(capsys, ["analyse", path], "five.csv: stroke 0: exact DPPLA of 5000 samples in 832 "
            "segments", "DP steps", "INKARM_MAX_DPPLA_STEPS", "or use --banded")


def test_exact_dppla_over_the_memory_budget_is_refused(tmp_path, capsys):
    # Once: "Unable to allocate 12.4 GiB" for 100,000 samples, with or without --banded.
    path = write_csv(tmp_path / "big.csv", 100_000)
    refused(capsys, ["analyse", path], "big.csv: stroke 0: exact DPPLA of 100000 samples",
            "GB, more than the limit of 1 GB", "INKARM_MAX_MEMORY_MB", "or use --banded")


def test_banded_dppla_fits_a_small_memory_budget(tmp_path, capsys, monkeypatch):
    # The banded DP's estimate (and allocations) are O(k band): 20,000 samples in 32 MB,
    # where the full (k+1, w) tables alone took 1 GB.
    path = write_csv(tmp_path / "banded.csv", 20_000)
    monkeypatch.setenv("INKARM_MAX_MEMORY_MB", "32")
    assert main(["analyse", str(path), "--banded"]) == 0
    assert "3332 segments" in capsys.readouterr().out
    refused(capsys, ["analyse", path], "banded.csv", "INKARM_MAX_MEMORY_MB", "or use --banded")


def test_compression_out_of_range_names_the_option(tmp_path, capsys):
    path = write_csv(tmp_path / "c.csv", 50)
    refused(capsys, ["analyse", path, "--compression", "2"], "--compression: must lie in (0, 1)")


# -- restyle: LQT settings and budget ----------------------------------------------------


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("--d", "1e-300", "--d: must lie in [0.001, 10000] mm"),
        ("--d", "1e300", "--d: must lie in"),
        ("--dt", "1e-300", "--dt: must lie in [0.0001, 1] s"),
        ("--dt", "1e300", "--dt: must lie in"),
        ("--segment-time", "1e300", "--segment-time: must be positive seconds"),
        ("--segment-time", "-1", "--segment-time: must be positive seconds"),
        ("--along", "1e300", "--along: must be positive and at most 100"),
        ("--across", "nan", "--across: must be positive"),
        ("--order", "1000", "--order: expected an integer 1..7"),
    ],
)
def test_restyle_settings_out_of_range_name_the_option(svg, tmp_path, capsys, option, value,
                                                       message):
    refused(capsys, ["restyle", svg, "--out", tmp_path / "o", option, value], message)


def test_restyle_lqt_steps_are_estimated_before_any_work(svg, tmp_path, capsys):
    # 1000 s per target x 21 targets at dt = 0.01 s: 2.1e6 LQT steps (gigabytes).
    refused(capsys, ["restyle", svg, "--out", tmp_path / "o", "--segment-time", "1000"],
            "trace.svg: --segment-time: LQT of the restyled drawing", "about 2.1e+06 time steps",
            "INKARM_MAX_STEPS")


# -- tag: glyphs, GA and LQT -------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "needles"),
    [
        # Once: never ended (the GA at ~0.25 s a glyph).
        (["--glyphs", "100000"], ["--glyphs: a tag of 100000 glyphs", "INKARM_MAX_TEXT"]),
        (["--glyphs", "1000"], ["--glyphs: ordering GA of 1000 glyphs",
                                "about 2.04e+06 individuals", "INKARM_MAX_GA_INDIVIDUALS"]),
        (["--dt", "1e-300"], ["--dt: must lie in [0.0001, 1] s"]),
        (["--dt", "1e-4", "--glyphs", "200"], ["--dt: LQT of 200 glyphs", "INKARM_MAX_STEPS"]),
        (["--dt", "0"], ["--dt: must be a positive number of seconds"]),
        (["--dt", "nan"], ["--dt: must be a positive number of seconds"]),
        (["--size", "1e300"], ["--size: make_tag: glyph size must be in [0.1, 1000] mm"]),
        (["--size", "inf"], ["--size"]),
    ],
)
def test_tag_costs_are_bounded_before_the_ga_runs(tmp_path, capsys, args, needles):
    refused(capsys, ["tag", "--out", tmp_path / "o", *args], *needles)


def test_tag_budget_can_be_raised_by_its_setting(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("INKARM_MAX_GA_INDIVIDUALS", "1000")
    refused(capsys, ["tag", "--out", tmp_path / "o"], "--glyphs", "about 1.02e+04 individuals",
            "limit of 1000 individuals")


@pytest.mark.parametrize(
    "argv",
    [
        ["tag", "--glyphs", str(10**30)],
        ["tag", "--dt", "1e-4", "--glyphs", "20000"],
        ["restyle", "{svg}", "--segment-time", "10000"],
        ["restyle", "{svg}", "--speed", "0.001", "--rate", "1e7"],
    ],
)
def test_estimates_are_finite_numbers_in_the_message(svg, tmp_path, capsys, argv):
    # No estimate overflows to inf or NaN on the way to the message.
    argv = [str(svg) if a == "{svg}" else a for a in argv] + ["--out", tmp_path / "o"]
    line = refused(capsys, argv)
    number = float(line.split("about ")[1].split(" ")[0])
    assert math.isfinite(number)
