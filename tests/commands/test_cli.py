"""The `inkarm` command itself: help, and errors that are not inkarm's own."""

from __future__ import annotations

import json

import numpy as np
import pytest

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


# -- inkarm draw: robots and failed runs -----------------------------------------------------------

LINE_TOML = (
    "[source]\nkind = 'plan'\n[[source.plan.strokes]]\n"
    "targets = [{ mean = [0.0, 0.0], cov = 1.0 }, { mean = [20.0, 5.0], cov = 1.0 }]\n"
    "[ink]\npx_per_mm = 4.0\n"
)


def _job(tmp_path, extra: str = ""):
    path = tmp_path / "job.toml"
    path.write_text(LINE_TOML + extra)
    return path


def test_draw_with_an_unknown_robot_is_one_line_exit_2(tmp_path, capsys):
    code = main(["draw", str(_job(tmp_path)), "--robot", "nope", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert "robot.name: unknown value 'nope'" in err[0]
    assert not (tmp_path / "o" / "status.json").exists()


@pytest.mark.sim
def test_draw_with_a_user_profile_file(tmp_path, capsys):
    from inkarm.robots.registry import DATA

    profile = tmp_path / "my_arm.toml"
    profile.write_text((DATA / "wx250s.toml").read_text().replace('"wx250s"', '"my_arm"', 1))
    out = tmp_path / "o"
    job = _job(tmp_path, '\n[controller]\ncommand = "torque"\n'  # servos in current mode
               # the servo arm's bounds, as its shipped scenarios state them
               "[judge]\ntracking_rms_mm = 1.0\ntracking_max_mm = 2.0\nink_chamfer_mm = 1.0\n"
               "force_band_n = 0.2\n")
    code = main(["draw", str(job), "--robot", str(profile), "--out", str(out), "--quiet"])
    assert code == 0, capsys.readouterr().err
    status = json.loads((out / "status.json").read_text())
    assert status["status"] == "ok" and status["robot"] == "my_arm"
    with np.load(out / "trace.npz") as z:
        assert z["q"].shape[1] == 6
    assert (out / "metrics.json").is_file()


@pytest.mark.sim
def test_a_failed_run_exits_1_and_keeps_the_trace_but_no_metrics(tmp_path, capsys):
    out = tmp_path / "o"
    out.mkdir()
    (out / "metrics.json").write_text("{}")  # left by an earlier, good run
    job = _job(tmp_path, "[robot.gains]\nkp = 1e7\nkd = 0.0\n")
    assert main(["draw", str(job), "--out", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "the run failed" in err and ("diverged" in err or "torque_saturated" in err)
    status = json.loads((out / "status.json").read_text())
    assert status["status"] == "failed" and status["reason"]
    assert (out / "trace.npz").is_file() and (out / "canvas.png").is_file()
    assert not (out / "metrics.json").exists()
