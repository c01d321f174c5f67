"""No command writes or replaces anything outside its declared outputs (issue 21): at every
output path of every command a test plants what a careless user or an attacker would leave
there (a link to a file elsewhere, a named pipe, a link loop, the command's own input) and
checks that the command either refuses in one line (exit 2) or writes its own regular file
in place of the link, and that nothing planted or pointed to changed."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from inkarm.cli import main

ROOT = Path(__file__).resolve().parents[2]
QUICK = ROOT / "scenarios" / "quick_stroke.toml"
SIGNATURE = ROOT / "scenarios" / "traces" / "signature.svg"
COMPASS = ROOT / "tests" / "data" / "gcode" / "compass_quick.gcode"

# (command line with {out}, the files it writes in a folder --out, or None for a file --out)
FOLDER_COMMANDS = {
    "write": (["write", "hi", "--out", "{out}"], "write.png"),
    "tag": (["tag", "--seed", "1", "--glyphs", "2", "--out", "{out}"], "tag.png"),
    "restyle": (["restyle", str(SIGNATURE), "--out", "{out}"], "signature_restyled.csv"),
    "analyse": (["analyse", str(SIGNATURE), "--out", "{out}"], None),
    "pencil show": (["pencil", "show", "HB", "--out", "{out}"], None),
    "draw": (["draw", str(QUICK), "--quiet", "--out", "{out}"], "canvas.png"),
    "sweep": (["sweep", str(QUICK), "--set", "controller.force_n=1", "--quiet", "--workers", "1",
               "--out", "{out}"], "figures/ink_overlay.png"),
    "regress --report": (["regress", str(QUICK), "--report", "{out}"], "report.md"),
}
FILE_COMMANDS = {
    "gcode": (["gcode", str(SIGNATURE), "--out", "{out}"], ".gcode", str(SIGNATURE)),
    "preview": (["preview", str(COMPASS), "--out", "{out}"], ".png", str(COMPASS)),
    "primitives learn": (["primitives", "learn", "letter:a", "--samples", "3", "--chains", "2",
                          "--states", "3", "--iterations", "1", "--quiet", "--out", "{out}"],
                         ".npz", None),
    "regress --junit": (["regress", str(QUICK), "--junit", "{out}"], ".xml", str(QUICK)),
}

pytestmark = pytest.mark.slow


def _run(template: list[str], out: Path) -> int:
    try:
        return main([a.replace("{out}", str(out)) for a in template])
    except SystemExit as e:  # argparse
        return int(e.code or 0)


@pytest.mark.parametrize("name", sorted(FOLDER_COMMANDS))
def test_a_link_planted_in_an_output_folder_is_replaced_not_followed(name, tmp_path, capsys):
    template, output = FOLDER_COMMANDS[name]
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    out = tmp_path / "out"
    out.mkdir()
    planted = out / (output or "planted.png")
    planted.parent.mkdir(exist_ok=True)
    os.symlink(victim, planted)
    code = _run(template, out)
    capsys.readouterr()
    assert code == 0
    assert victim.read_text() == "precious"
    if output is not None:  # the command's own file took the link's place
        assert planted.is_file() and not planted.is_symlink()


@pytest.mark.parametrize("name", sorted(FOLDER_COMMANDS))
@pytest.mark.parametrize("plant", ["pipe", "loop", "file"])
def test_an_output_folder_that_is_not_a_folder_is_refused(name, plant, tmp_path, capsys):
    template, _ = FOLDER_COMMANDS[name]
    out = tmp_path / "out"
    if plant == "pipe":
        os.mkfifo(out)
    elif plant == "loop":
        os.symlink(out, out)
    else:
        out.write_text("a file the user keeps")
    before = sorted(os.listdir(tmp_path))
    assert _run(template, out) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert sorted(os.listdir(tmp_path)) == before
    if plant == "file":
        assert out.read_text() == "a file the user keeps"
    if plant == "pipe":
        assert out.is_fifo()


@pytest.mark.parametrize("name", sorted(FILE_COMMANDS))
@pytest.mark.parametrize("plant", ["pipe", "loop", "dangling", "folder", "input"])
def test_an_output_file_path_that_is_not_a_new_file_is_refused(name, plant, tmp_path, capsys):
    template, suffix, input_file = FILE_COMMANDS[name]
    out = tmp_path / f"result{suffix}"
    if plant == "pipe":
        os.mkfifo(out)
    elif plant == "loop":
        os.symlink(out, out)
    elif plant == "dangling":
        os.symlink(tmp_path / "nowhere" / "x", out)
    elif plant == "folder":
        out.mkdir()
    else:
        if input_file is None:
            pytest.skip("this command reads no file it could overwrite")
        out = tmp_path / Path(input_file).name  # the command's input, given as its output
        shutil.copy(input_file, out)
        template = [str(out) if a == input_file else a for a in template]
    before = {p: (p.is_symlink(), p.is_fifo(), p.is_dir()) for p in tmp_path.iterdir()}
    contents = out.read_bytes() if plant == "input" else None
    assert _run(template, out) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert {p: (p.is_symlink(), p.is_fifo(), p.is_dir()) for p in tmp_path.iterdir()} == before
    if contents is not None:
        assert out.read_bytes() == contents
