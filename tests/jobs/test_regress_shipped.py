"""Every shipped scenario has a baseline; the quick scenario matches its shipped one in the quick
tier (all of them: the plugin's slow test)."""

from __future__ import annotations

from pathlib import Path

import pytest

from inkarm.cli import main
from inkarm.jobs.regress import find_scenarios

SCENARIOS = Path(__file__).parents[2] / "scenarios"

pytestmark = pytest.mark.sim


def test_every_shipped_scenario_has_a_baseline():
    scenarios = sorted(SCENARIOS.glob("*.toml"))
    pairs = find_scenarios([SCENARIOS])
    assert [p for p, _ in pairs] == scenarios


def test_the_quick_scenario_matches_its_shipped_baseline(capsys):
    assert main(["regress", str(SCENARIOS / "quick_stroke.toml")]) == 0, capsys.readouterr().out


# Every shipped scenario against its baseline, through the pytest plugin (the same comparison):
# tests/test_plugin.py::test_the_plugin_runs_every_shipped_scenario_and_each_matches_its_baseline
# (slow).
