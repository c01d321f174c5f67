"""``inkarm write`` and ``inkarm tag``: outputs, ligatures, fidelity, reproducibility, errors."""

from __future__ import annotations

import re

import pytest

from inkarm.cli import main
from inkarm.core.trajectory import Drawing


def test_write_inkarm_in_a_script_style_gives_ligatured_strokes(tmp_path, capsys):
    out = tmp_path / "w"
    assert main(["write", "inkarm", "--style", "cursive", "--out", str(out)]) == 0
    for name in ("drawing.csv", "drawing.svg", "write.png"):
        assert (out / name).stat().st_size > 0
    drawing = Drawing.from_csv(out / "drawing.csv")
    assert len(drawing.strokes) < len("inkarm")
    assert (out / "drawing.svg").read_text().count("<polyline") == len(drawing.strokes)
    assert (out / "write.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    out = capsys.readouterr().out
    assert "6 letters in 2 strokes" in out
    fidelity = _fidelity(out)
    assert fidelity["symmetric"] == max(fidelity["drawing->font"], fidelity["font->drawing"])


def _fidelity(out: str) -> dict[str, float]:
    """The figures ``inkarm write`` prints: drawing->font, font->drawing, symmetric [mm]."""
    found = re.search(
        r"from the font: drawing->font ([\d.]+) mm, font->drawing ([\d.]+) mm, "
        r"symmetric ([\d.]+) mm",
        out,
    )
    assert found, out
    return dict(zip(("drawing->font", "font->drawing", "symmetric"), map(float, found.groups())))


def test_write_faithful_reports_both_ways_from_the_font(tmp_path, capsys):
    args = ["write", "inkarm", "--style", "faithful", "--out", str(tmp_path), "--height", "10"]
    assert main(args) == 0
    fidelity = _fidelity(capsys.readouterr().out)
    assert fidelity["drawing->font"] < 1.0  # no ink more than 1 mm off the font (0.11 mm)
    # every letter target kept by the ligatures: the font is missed by 0.11 mm at most (seed 0;
    # seed 000's drop rule, applied until no junction was sharp, missed the top of the a by 3)
    assert fidelity["font->drawing"] <= 0.2
    assert fidelity["symmetric"] <= 0.2


def test_write_with_a_user_style_file(tmp_path, capsys):
    styles = tmp_path / "styles.toml"
    styles.write_text('[styles.mine]\nbase = "loose"\nslant = 15.0\n')
    assert (
        main(["write", "ab", "--styles", str(styles), "--style", "mine", "--out", str(tmp_path)])
        == 0
    )
    assert len(Drawing.from_csv(tmp_path / "drawing.csv").strokes) == 1


@pytest.mark.parametrize(
    "args, message",
    [
        (["write", ""], "text is empty"),
        (["write", "café"], r"font 'scripts' has no glyph for 'é' \(U\+00E9\)"),
        (["write", "inkar\rm"], r"text: control character U\+000D \(carriage return\) at index 5"),
        (["write", "ab\x1b[31m"], r"text: control character U\+001B \(escape\) at index 2"),
        (["write", "a\x00"], r"text: control character U\+0000 \(null\) at index 1"),
        (["write", "ab", "--style", "fancy"], r"unknown handstyle 'fancy'; available: .*faithful"),
        (["write", "ab", "--height", "0"], "letter height must be a positive number of mm"),
        (["write", "ab", "--font", "comic"], "unknown font 'comic'"),
        (["write", "ab", "--seed", "-1"], r"--seed: expected an integer >= 0, got -1"),
        (["write", "ab", "--dt", "0"], "dt: must be a positive number of seconds"),
        (["tag", "--style", "fancy"], r"unknown handstyle 'fancy'; available: .*graffiti"),
        (["tag", "--glyphs", "0"], "n_glyphs must be >= 1"),
        (["tag", "--size", "-3"], "glyph size must be in"),
        (["tag", "--size", "1e-300"], r"glyph size must be in \[0.1, 1000\] mm, got 1e-300"),
        (["tag", "--seed", "-2"], r"--seed: expected an integer >= 0, got -2"),
    ],
)
def test_errors_exit_2_with_the_message(tmp_path, capsys, args, message):
    assert main([*args, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"inkarm {args[0]}: error: ")
    assert re.search(message, err)
    assert "Traceback" not in err


def test_unknown_key_in_a_style_file_is_named(tmp_path, capsys):
    styles = tmp_path / "styles.toml"
    styles.write_text("[styles.mine]\nwobble = 2\n")
    assert (
        main(["write", "ab", "--styles", str(styles), "--style", "mine", "--out", str(tmp_path)])
        == 2
    )
    assert "styles.mine: unknown key 'wobble'" in capsys.readouterr().err


def test_out_must_be_a_directory(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["tag", "--out", str(blocker)]) == 2
    assert "exists and is not a directory" in capsys.readouterr().err


def test_tag_writes_files_and_a_seed_reproduces_it(tmp_path, capsys):
    a, b, c = (tmp_path / n for n in "abc")
    assert main(["tag", "--seed", "7", "--out", str(a)]) == 0
    assert main(["tag", "--seed", "7", "--out", str(b), "--style", "graffiti"]) == 0
    assert main(["tag", "--seed", "8", "--out", str(c)]) == 0
    for name in ("drawing.csv", "drawing.svg", "tag.png"):
        assert (a / name).stat().st_size > 0
    assert (a / "drawing.csv").read_bytes() == (b / "drawing.csv").read_bytes()
    assert (a / "drawing.csv").read_bytes() != (c / "drawing.csv").read_bytes()
    assert "5 glyphs" in capsys.readouterr().out


def test_write_takes_new_lines_and_tabs(tmp_path, capsys):
    assert main(["write", "an\\nmu\tno", "--out", str(tmp_path)]) == 0  # \\n as typed in a shell
    assert "6 letters in" in capsys.readouterr().out
    assert len(Drawing.from_csv(tmp_path / "drawing.csv").strokes) == 3  # three words


def test_a_handstyle_spacing_too_fine_to_plan_is_refused_at_once(tmp_path, capsys):
    """max_spacing = 1e-6 of the letter height would put a million targets on each letter
    (a run of minutes to hours): refused from the request, naming the style and key."""
    styles = tmp_path / "styles.toml"
    styles.write_text("[styles.fine]\nmax_spacing = 1e-6\n")
    code = main(["write", "hello", "--style", "fine", "--styles", str(styles),
                 "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert "max_spacing must be at least 0.01" in err[0] and "1e-06" in err[0]
