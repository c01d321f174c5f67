"""The `inkarm` command itself: help, and errors that are not inkarm's own."""

from __future__ import annotations

from inkarm.cli import build_parser, main


def test_help_lists_every_command(capsys):
    assert main([]) == 0
    out = capsys.readouterr().out
    for command in ("draw", "plan", "write", "tag", "restyle", "analyse"):
        assert command in out
    assert {a.dest for a in build_parser()._actions} >= {"command"}


def test_out_folder_that_is_a_file_is_one_line_exit_2(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("")
    code = main(["tag", "--out", str(blocker / "sub")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("inkarm tag: error: ")
    assert "file" in err[0]
