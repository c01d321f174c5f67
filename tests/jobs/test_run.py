"""``run(scenario) -> Run``: pure (writes nothing), picklable, deterministic; a diverging run
comes back failed with its partial log instead of raising."""

from __future__ import annotations

import os
import pickle

import numpy as np
import pytest

from inkarm.jobs.outputs import write_run
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario, parse_scenario

pytestmark = pytest.mark.sim

LINE = {
    "source": {
        "kind": "plan",
        "plan": {
            "strokes": [
                {"targets": [{"mean": [0.0, 0.0], "cov": 1.0}, {"mean": [20.0, 5.0], "cov": 1.0}]}
            ]
        },
    },
    "ink": {"px_per_mm": 4.0},
}


@pytest.fixture(scope="module")
def default_run(tmp_path_factory):
    """The embedded default scenario, run in an empty working folder; (run, that folder)."""
    cwd = tmp_path_factory.mktemp("cwd")
    old = os.getcwd()
    os.chdir(cwd)
    try:
        return run(load_scenario()), cwd
    finally:
        os.chdir(old)


def test_run_writes_nothing_and_pickles(default_run):
    result, cwd = default_run
    assert result.ok and result.status == "ok" and result.reason == ""
    assert list(cwd.iterdir()) == []
    again = pickle.loads(pickle.dumps(result))
    assert again.status == "ok" and again.metrics == result.metrics
    assert np.array_equal(again.log.q, result.log.q)
    assert np.array_equal(np.asarray(again.canvas.image), np.asarray(result.canvas.image))


def test_same_scenario_and_seed_give_identical_canvas_and_metrics(default_run):
    first, _ = default_run
    second = run(load_scenario())
    assert np.array_equal(np.asarray(first.canvas.image), np.asarray(second.canvas.image))
    assert set(first.metrics) == set(second.metrics)
    for key, value in first.metrics.items():
        if key != "realtime_factor":
            assert second.metrics[key] == value, key


def test_a_diverging_run_fails_with_a_reason_and_keeps_its_partial_log(tmp_path):
    scenario = parse_scenario(LINE, "job.toml", tmp_path).with_overrides(
        {"robot.gains.kp": 1e7, "robot.gains.kd": 0.0}
    )
    result = run(scenario)
    assert result.status == "failed" and not result.ok
    # the torque watchdog may fire before the state blows up: either way a named fault
    assert result.reason.split(":")[0] in ("torque_saturated", "diverged", "joint_speed")
    assert result.metrics == {} and len(result.log.time) > 0
    out = tmp_path / "out"
    out.mkdir()
    (out / "metrics.json").write_text("{}")  # a good run's, from before
    files = write_run(result, out)
    assert '"failed"' in (out / "status.json").read_text()
    assert (out / "trace.npz").is_file() and "trace.npz" in files
    assert (out / "canvas.png").is_file()
    assert not (out / "metrics.json").exists() and not (out / "report.png").exists()


def test_a_run_longer_than_the_simulated_time_budget_is_refused_before_building(monkeypatch):
    from inkarm.core.budget import BudgetError
    from inkarm.jobs.preflight import check_budget
    from inkarm.jobs.run import run
    from inkarm.jobs.scenario import load_scenario, place, source_drawing
    from inkarm.sim.cell import Cell

    slow = load_scenario().with_overrides({"placement.time_scale": 100.0})
    monkeypatch.setenv("INKARM_MAX_SIM_S", "100")
    with pytest.raises(BudgetError, match=r"source: simulating 1 strokes: about 199.4 s, more "
                       r"than the limit of 100 s \(raise it with the environment variable "
                       r"INKARM_MAX_SIM_S\)") as info:
        run(slow)
    assert info.value.variable == "INKARM_MAX_SIM_S" and info.value.file == slow.path
    monkeypatch.setenv("INKARM_MAX_SIM_S", "5000")
    cell = Cell(slow.cell, slow.robot)
    check_budget(place(source_drawing(slow), slow.placement, cell.paper_size_mm), slow, cell)
