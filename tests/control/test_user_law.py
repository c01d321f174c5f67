"""A user's own law (README, "Bring your own controller"): the README shows the code that
``tests/userlaw/`` holds, and that law runs unchanged, named by import path, in ``inkarm draw``,
``inkarm regress``, ``inkarm sweep``, a batched ensemble and a hardware-in-the-loop run on the
Dynamixel emulator; the README's watchdog, scenario table and entry points work as written.

The package is imported as ``userlaw``, with ``tests/`` on the path (``sys.path`` here,
``PYTHONPATH`` for the sweep's worker processes), as a user's package on their path would be.
Not as ``tests.userlaw``: in a fresh process the name ``tests`` is an installed distribution's
own top-level package (Hershey-Fonts ships one), and a sweep's workers are fresh processes.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from inkarm.cli import main
from inkarm.control.laws import LawSpec, make_law
from inkarm.control.watchdogs import make_watchdog
from inkarm.errors import InputError
from inkarm.jobs.scenario import load_scenario, parse_scenario

ROOT = Path(__file__).resolve().parents[2]
TESTS = ROOT / "tests"
README = ROOT / "README.md"
QUICK = ROOT / "scenarios" / "quick_stroke.toml"
WX250S = ROOT / "scenarios" / "wx250s_letter_N.toml"
LAW = "userlaw.feedforward:FeedForward"
WATCHDOG = "userlaw.watch:PenOffPath"


@pytest.fixture(autouse=True)
def user_package(monkeypatch):
    """``tests/`` on the path of this process and of the processes it starts."""
    monkeypatch.setattr(sys, "path", [*sys.path, str(TESTS)])
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(
        p for p in (str(TESTS), os.environ.get("PYTHONPATH", "")) if p))


def user_scenario(folder: Path, source: Path = QUICK, name: str = "user_law",
                  extra: str = "", watchdog: str = "") -> Path:
    """``source`` with ``[controller] law`` the user's law and its settings table (and the
    user's watchdog with ``watchdog``'s settings), written to ``folder/name.toml``."""
    text = source.read_text()
    assert "[controller]\n" in text
    lines = [f'law = "{LAW}"']
    if watchdog:
        lines.append(f'watchdogs = ["{WATCHDOG}"]')
    text = text.replace("[controller]\n", "[controller]\n" + "\n".join(lines) + "\n", 1)
    text += f'\n[controller."{LAW}"]\ngravity_scale = 1.0\n'
    if watchdog:
        text += f'\n[controller."{WATCHDOG}"]\n{watchdog}\n'
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.toml"
    path.write_text(text + extra)
    return path


def _section() -> str:
    text = README.read_text()
    start = text.index("**Bring your own controller.**")
    end = text.index("\n**", start + 10)  # the next bold-led paragraph
    return text[start:end]


# -- the README cannot rot ------------------------------------------------------------------------


def test_the_readme_shows_the_law_and_watchdog_that_run_here():
    python = re.findall(r"```python\n(.*?)```", _section(), flags=re.DOTALL)
    assert python[0] == (TESTS / "userlaw" / "feedforward.py").read_text()
    assert python[1] == (TESTS / "userlaw" / "watch.py").read_text()
    assert 25 <= len(python[0].splitlines()) <= 40  # "a complete law of about 30 lines"


def test_the_readme_scenario_table_names_the_law_and_watchdog_with_their_settings():
    tomls = re.findall(r"```toml\n(.*?)```", _section(), flags=re.DOTALL)
    table = tomllib.loads(tomls[0].replace("mylab.laws:", "userlaw.feedforward:")
                          .replace("mylab.watch:", "userlaw.watch:"))
    scenario = parse_scenario({"source": {"kind": "text", "text": "a"}, **table},
                              source="README.md")
    assert scenario.law == LawSpec(LAW, (("gravity_scale", 1.1),))
    [watchdog] = scenario.watchdogs
    assert watchdog.name == WATCHDOG and watchdog.make().limit_mm == 0.5


def test_the_readme_entry_points_give_the_law_a_short_name(tmp_path):
    """The README's ``[project.entry-points."inkarm.plugins"]`` as an installed package's
    metadata: ``law = "feedforward"`` then names the user's law."""
    from inkarm.plugins import GROUP, reload_entry_points

    tomls = re.findall(r"```toml\n(.*?)```", _section(), flags=re.DOTALL)
    points = tomllib.loads(tomls[1])["project"]["entry-points"][GROUP]
    assert points == {"law.feedforward": "mylab.laws:FeedForward",
                      "watchdog.pen_off_path": "mylab.watch:PenOffPath"}
    dist = tmp_path / "mylab-0.1.dist-info"  # (mylab's modules: userlaw's, on the path)
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: mylab\nVersion: 0.1\n")
    lines = [f"{name} = {value}".replace("mylab.laws", "userlaw.feedforward")
             .replace("mylab.watch", "userlaw.watch") for name, value in points.items()]
    (dist / "entry_points.txt").write_text(f"[{GROUP}]\n" + "\n".join(lines) + "\n")
    sys.path.insert(0, str(tmp_path))
    reload_entry_points()
    try:
        from userlaw.feedforward import FeedForward
        from userlaw.watch import PenOffPath

        assert type(make_law("feedforward", {"gravity_scale": 0.5})) is FeedForward
        assert type(make_watchdog("pen_off_path")) is PenOffPath
    finally:
        sys.path.remove(str(tmp_path))
        reload_entry_points()  # (the next lookup forgets mylab)


def test_a_bad_setting_of_the_users_law_is_refused_naming_it():
    with pytest.raises(InputError, match=r"gravity_scale: expected a number in \[0, 2\], "
                                         r"got 3") as info:
        make_law(LAW, {"gravity_scale": 3})
    assert info.value.key == f"controller.{LAW}"
    with pytest.raises(InputError, match=r"no setting 'gravity' \(did you mean "
                                         r"'gravity_scale'\?\)") as info:
        make_law(LAW, {"gravity": 1.0})
    assert info.value.key == f"controller.{LAW}.gravity"


# -- it runs, unchanged, wherever a law runs ------------------------------------------------------


@pytest.mark.sim
def test_inkarm_draw_runs_the_users_law_and_its_watchdog(tmp_path, capsys):
    scenario = user_scenario(tmp_path, watchdog="limit_mm = 1.0")
    out = tmp_path / "out"
    assert main(["draw", str(scenario), "--out", str(out), "--quiet"]) == 0
    status = json.loads((out / "status.json").read_text())
    assert status["status"] == "ok", status
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["tracking_rms_mm"] < 0.3 and metrics["gap_mm"] == 0.0  # measured 0.116 mm
    # the same watchdog, tighter than the pen keeps: it stops the run, named
    tight = user_scenario(tmp_path, name="tight", watchdog="limit_mm = 0.05")
    assert main(["draw", str(tight), "--out", str(tmp_path / "tight"), "--quiet"]) == 1
    status = json.loads((tmp_path / "tight" / "status.json").read_text())
    assert status["status"] == "failed"
    assert re.search(r"pen_off_path: the pen is 0\.0\d mm off its path \(limit 0\.05 mm\) at "
                     r"t = \d", status["reason"]), status


@pytest.mark.sim
def test_inkarm_regress_runs_the_users_law_against_its_baseline(tmp_path, capsys):
    scenario = user_scenario(tmp_path / "scenarios")
    baselines = tmp_path / "baselines"
    assert main(["regress", str(scenario), "--baselines", str(baselines), "--update"]) == 0
    assert "new baseline user_law" in capsys.readouterr().out
    assert main(["regress", str(scenario), "--baselines", str(baselines)]) == 0
    assert "PASS user_law" in capsys.readouterr().out
    # the law's settings are part of what is compared: no gravity feed-forward regresses
    scenario.write_text(scenario.read_text().replace("gravity_scale = 1.0",
                                                     "gravity_scale = 0.0"))
    assert main(["regress", str(scenario), "--baselines", str(baselines)]) == 1
    assert "FAIL user_law" in capsys.readouterr().out


@pytest.mark.sim
@pytest.mark.slow
def test_inkarm_sweep_runs_the_users_law_in_its_worker_processes(tmp_path):
    """``inkarm sweep`` as a user runs it, in a fresh process whose pool's workers import the
    law by name (``PYTHONPATH``)."""
    from inkarm.jobs.sweep.table import read_results

    scenario = user_scenario(tmp_path)
    out = tmp_path / "sweep"
    done = subprocess.run(
        [sys.executable, "-m", "inkarm.cli", "sweep", str(scenario), "--set",
         "controller.force_n=0.9:1.1:2", "--out", str(out), "--workers", "2", "--quiet"],
        capture_output=True, text=True, timeout=300, check=False, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    rows = sorted(read_results(out).to_pylist(), key=lambda r: r["index"])
    assert [r["controller.force_n"] for r in rows] == [0.9, 1.1]
    assert [r["status"] for r in rows] == ["ok", "ok"], [r["reason"] for r in rows]
    for row in rows:  # each point pressed with its own set point
        assert row["contact_force_mean_n"] == pytest.approx(row["controller.force_n"], abs=0.05)


@pytest.mark.sim
def test_a_batched_ensemble_runs_the_users_law_as_run_does_member_by_member(tmp_path):
    from inkarm.jobs.ensemble import batch_refusal, run_ensemble
    from inkarm.jobs.run import run

    scenario = load_scenario(user_scenario(tmp_path, extra=(
        "\n[sim.plant.random]\npaper_height_mm = [-2.0, 2.0]\nmass_scale = [0.9, 1.1]\n")))
    seeds = [3, 8]
    assert batch_refusal(scenario, seeds) is None  # position goals: one mujoco.batch
    runs = run_ensemble(scenario, seeds, processes=1)
    heights = {r.scenario.plant.realised().paper_height_mm for r in runs}
    assert len(heights) == 2  # two different plants
    for seed, batched in zip(seeds, runs):
        alone = run(scenario.with_overrides({"plant.seed": seed}))
        assert batched.ok and alone.ok, (batched.reason, alone.reason)
        assert batched.scenario.plant.seed == seed and batched.scenario.law.name == LAW
        assert len(batched.log) == len(alone.log)
        assert np.abs(batched.log.q - alone.log.q).max() < 1e-9
        assert np.abs(batched.log.force - alone.log.force).max() < 1e-9
        assert np.abs(batched.canvas.image - alone.canvas.image).max() < 1e-6
        for key, value in alone.metrics.items():
            if key != "realtime_factor":
                assert batched.metrics[key] == pytest.approx(value, rel=1e-9, abs=1e-9), key


@pytest.mark.sim
@pytest.mark.slow
@pytest.mark.hardware_emulated
def test_a_hardware_in_the_loop_run_on_the_dynamixel_emulator_runs_the_users_law():
    """The wx250s letter through dynamixel-sdk on a pty, the emulator's servos (the shipped
    profile: extended position mode, its own firmware loop) holding the law's goals; measured
    0.40 mm RMS, 0.19 mm chamfer (the scenario's servo bounds: 1 mm)."""
    from inkarm.jobs.backends.dynamixel import hil_run

    scenario = load_scenario(WX250S).with_overrides({"controller.law": LAW})
    # (a loaded machine's latency and dead-man, as tests/hardware/dynamixel/test_hil.py)
    hil = hil_run(scenario, latency_ms=50, watchdog_ms=500)
    assert hil.ok, hil.reason
    assert hil.scenario.law.name == LAW
    assert len(hil.canvas.ink_points_mm()) > 100
    assert hil.metrics["tracking_rms_mm"] < 1.0 and hil.metrics["ink_chamfer_mm"] < 1.0
