"""The pytest plugin (entry point ``pytest11``): ``pytest --inkarm-regress DIR`` collects the
scenarios that have baselines as test items, runs them, and fails with the metric and amount."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from inkarm.jobs.scenario import load_scenario

pytest_plugins = ["pytester"]

SCENARIOS = Path(__file__).parents[1] / "scenarios"

pytestmark = pytest.mark.sim


def _copy_quick(folder: Path, extra: str = "") -> None:
    (folder / "baselines").mkdir(parents=True)
    shutil.copytree(SCENARIOS / "baselines" / "quick_stroke", folder / "baselines" / "quick_stroke")
    scenario = folder / "quick_stroke.toml"
    shutil.copyfile(SCENARIOS / "quick_stroke.toml", scenario)
    with scenario.open("a") as f:
        f.write(extra)


def test_the_plugin_passes_a_scenario_and_fails_a_regression_naming_metric_and_amount(pytester):
    _copy_quick(pytester.path / "good")
    (pytester.path / "good" / "no_baseline.toml").write_text("title = 'not collected'\n")
    kp = [float(k) * 0.8 for k in load_scenario(SCENARIOS / "quick_stroke.toml").robot.gains.kp]
    _copy_quick(pytester.path / "detuned", f"\n[robot.gains]\nkp = {kp}\n")
    # (in a subprocess: pytester restores sys.modules after an in-process run, and a second run
    # re-imports numpy's C extensions, which load once per process)
    result = pytester.runpytest_subprocess("--inkarm-regress", "-p", "no:cacheprovider", "-v",
                                           "good", "detuned")
    result.assert_outcomes(passed=1, failed=1)
    result.stdout.fnmatch_lines([
        "*good/quick_stroke.toml::quick_stroke PASSED*",
        "*detuned/quick_stroke.toml::quick_stroke FAILED*",
        "*scenario quick_stroke (*detuned/quick_stroke.toml) regressed against its baseline:*",
        "*tracking_rms_mm got worse by * mm (*; tolerance 0.02 mm)*",
    ])
    assert "Traceback" not in result.stdout.str()


def test_without_the_option_scenarios_are_not_collected(pytester):
    _copy_quick(pytester.path / "mine")
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "mine")
    assert result.ret == pytest.ExitCode.NO_TESTS_COLLECTED


@pytest.mark.slow
def test_the_plugin_runs_every_shipped_scenario_and_each_matches_its_baseline(pytester):
    result = pytester.runpytest_subprocess("--inkarm-regress", "-p", "no:cacheprovider", "-rf",
                                           str(SCENARIOS))
    shipped = sorted(SCENARIOS.glob("*.toml"))
    assert len(shipped) >= 9
    result.assert_outcomes(passed=len(shipped))
