"""Every shipped scenario matches its shipped baseline (``inkarm regress scenarios``); the
quick scenario alone in the quick tier."""

from __future__ import annotations

from pathlib import Path

import pytest

from inkarm.cli import main
from inkarm.jobs.regress import find_scenarios, regress
from inkarm.jobs.scenario import load_scenario

SCENARIOS = Path(__file__).parents[2] / "scenarios"

pytestmark = pytest.mark.sim


def test_every_shipped_scenario_has_a_baseline():
    scenarios = sorted(SCENARIOS.glob("*.toml"))
    pairs = find_scenarios([SCENARIOS])
    assert [p for p, _ in pairs] == scenarios


def test_the_quick_scenario_matches_its_shipped_baseline(capsys):
    assert main(["regress", str(SCENARIOS / "quick_stroke.toml")]) == 0, capsys.readouterr().out


@pytest.mark.slow
def test_every_shipped_scenario_matches_its_shipped_baseline():
    failures = []
    for path, folder in find_scenarios([SCENARIOS]):
        c = regress(load_scenario(path), folder)
        if not c.passed:
            failures.append(f"{c.name}: {c.failure_message()}")
    assert not failures, "\n".join(failures)
