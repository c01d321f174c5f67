"""`inkarm draw` output folders: honest on failure, interruption and bad input."""

import json
from pathlib import Path

import pytest

from inkarm.cli import main
from inkarm.jobs.scenario import DEFAULT_SCENARIO

pytestmark = pytest.mark.sim


def _job(tmp_path, extra: str = "") -> str:
    path = tmp_path / "job.toml"
    path.write_text(DEFAULT_SCENARIO.read_text() + extra)
    return str(path)


def test_bad_input_creates_no_folder(tmp_path, capsys):
    job = _job(tmp_path, "\n[controller]\nforce_n = -1.0\n")
    assert main(["draw", job, "--quiet", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "controller.force_n: expected a number in (0, 50] N" in err[0]
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    "options, message",
    [
        (["--out", ""], r"--out: expected a folder name"),
        (["--fps", "0"], r"--fps: expected frames per second in \(0, 240\]"),
        (["--camera", "drawng"], r"--camera: unknown camera 'drawng' \(did you mean 'drawing'\?\)"),
        (["--video", "x.avi"], r"--video: x.avi: expected a .mp4 file name"),
        (["--video", "/no/such/dir/x.mp4"], r"--video: /no/such/dir/x.mp4: cannot write there"),
    ],
)
def test_options_are_checked_before_any_work(tmp_path, capsys, options, message):
    args = ["draw", "--quiet", "--out", str(tmp_path / "o"), *options]
    if options[0] == "--out":
        args = ["draw", "--quiet", *options]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert __import__("re").search(message, err[0]), err[0]
    assert not (tmp_path / "o").exists()


def test_the_scenarios_own_input_in_out_is_never_overwritten(tmp_path, capsys):
    (tmp_path / "reference.csv").write_text("t,x,y\n0,0,0\n0.1,10,0\n0.2,20,5\n")
    job = tmp_path / "job.toml"
    job.write_text("[source]\nkind = 'trajectory'\nfile = 'reference.csv'\n")
    assert main(["draw", str(job), "--quiet", "--out", str(tmp_path)]) == 2
    assert "holds the input" in capsys.readouterr().err
    assert (tmp_path / "reference.csv").read_text().startswith("t,x,y\n0,0,0")


def test_a_failed_run_over_a_good_one_leaves_one_honest_folder(tmp_path, capsys):
    out = tmp_path / "o"
    assert main(["draw", _job(tmp_path), "--quiet", "--out", str(out)]) == 0
    assert json.loads((out / "metrics.json").read_text())["tracking_rms_mm"] < 0.1
    bad = _job(tmp_path, "\n[robot.gains]\nkp = 1e7\nkd = 0.0\n")
    assert main(["draw", bad, "--quiet", "--out", str(out)]) == 1
    status = json.loads((out / "status.json").read_text())
    assert status["status"] == "failed" and status["reason"].startswith(("diverged", "torque_saturated"))
    assert not (out / "metrics.json").exists() and not (out / "report.png").exists()
    assert (out / "trace.npz").exists()


def test_ctrl_c_keeps_the_partial_run_and_exits_130(tmp_path, capsys, monkeypatch):
    from inkarm.commands import draw

    def interrupt(self, fraction, phase):
        if fraction > 0.3:
            raise KeyboardInterrupt

    monkeypatch.setattr(draw.ProgressBar, "__call__", interrupt)
    out = tmp_path / "o"
    assert main(["draw", _job(tmp_path), "--out", str(out)]) == 130
    status = json.loads((out / "status.json").read_text())
    assert status["status"] == "interrupted"
    assert (out / "trace.npz").exists() and not (out / "metrics.json").exists()


def test_metrics_json_is_strict_json_even_when_a_metric_is_undefined(tmp_path):
    from inkarm.jobs.outputs import strict_json

    text = strict_json({"a": float("nan"), "b": [float("inf"), 1.0]})
    assert json.loads(text, parse_constant=lambda c: pytest.fail(f"bare {c}")) == {
        "a": None, "b": [None, 1.0]}


def test_a_degraded_run_names_each_missed_bound_with_its_number(tmp_path, capsys):
    out = tmp_path / "o"
    job = _job(tmp_path, "\n[judge]\ntracking_rms_mm = 0.01\nforce_band_n = 0.001\n")
    assert main(["draw", job, "--quiet", "--out", str(out)]) == 0  # degraded is not an error
    captured = capsys.readouterr()
    warning = [line for line in captured.err.splitlines() if "warning" in line]
    assert len(warning) == 1 and "the drawing is degraded: tracking RMS " in warning[0]
    assert "above tracking_rms_mm = 0.01 mm; force " in warning[0]
    assert "outside 1 +- 0.001 N (force_band_n)" in warning[0]
    assert "N while drawing); joint margin" in captured.out  # the force band in the summary
    assert "not judged" not in captured.out  # the simulation senses every bound's quantity
    status = json.loads((out / "status.json").read_text())
    assert status["status"] == "degraded"
    assert [s["bound"] for s in status["shortfalls"]] == ["tracking_rms_mm", "force_band_n"]
    assert status["shortfalls"][0]["limit"] == 0.01 and status["unjudged"] == []
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["status"] == "degraded" and len(metrics["reasons"]) == 2
    assert metrics["force_p1_n"] < metrics["force_p99_n"]


@pytest.mark.hardware_emulated
def test_what_the_backend_cannot_sense_is_printed_as_not_judged(tmp_path, capsys):
    from inkarm.hardware.plotter.emulator import EmulatorConfig, GrblEmulator

    quick = str(Path(__file__).parents[2] / "scenarios" / "quick_stroke.toml")
    out = tmp_path / "o"
    with GrblEmulator(EmulatorConfig(speedup=4)) as emu:
        status = main(["draw", quick, "--backend", "plotter", "--port", emu.port,
                       "--time-scale", "4", "--quiet", "--out", str(out)])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    lines = captured.out.splitlines()
    for bound in ("force_band_n", "force_error_n"):
        assert f"{bound} not judged: a plotter senses no pen force (its pen is up or down)" \
            in lines
    # without an emulator's canvas the ink is on paper: the run's canvas is the status reports'
    assert ("ink_chamfer_mm not judged: the ink is on the paper; this run's canvas inks the "
            "5 Hz status reports") in lines
    written = json.loads((out / "status.json").read_text())
    assert [u.split(" not judged")[0] for u in written["unjudged"]] == [
        "ink_chamfer_mm", "force_band_n", "force_error_n"]
