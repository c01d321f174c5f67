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
        {"robot.gains.kp": 1e9, "robot.gains.kd": 0.0}
    )
    result = run(scenario)
    assert result.status == "failed" and not result.ok
    assert result.reason and "diverged" in result.reason
    assert result.metrics == {} and len(result.log.time) > 0
    out = tmp_path / "out"
    out.mkdir()
    (out / "metrics.json").write_text("{}")  # a good run's, from before
    files = write_run(result, out)
    assert '"failed"' in (out / "status.json").read_text()
    assert (out / "trace.npz").is_file() and "trace.npz" in files
    assert (out / "canvas.png").is_file()
    assert not (out / "metrics.json").exists() and not (out / "report.png").exists()
