"""Scenario.with_overrides: dotted keys checked exactly as the TOML would be."""

from __future__ import annotations

from pathlib import Path

import pytest

from inkarm.errors import ScenarioError
from inkarm.jobs.scenario import load_scenario, parse_scenario

LINE_TOML = (
    "[source]\nkind = 'plan'\n[[source.plan.strokes]]\n"
    "targets = [{ mean = [0.0, 0.0], cov = 1.0 }, { mean = [20.0, 5.0], cov = 1.0 }]\n"
    "[ink]\npx_per_mm = 4.0\n"
)


@pytest.fixture
def job(tmp_path) -> Path:
    path = tmp_path / "job.toml"
    path.write_text(LINE_TOML)
    return path


def test_overrides_change_the_typed_sections(job):
    scenario = load_scenario(job).with_overrides(
        {"controller.force_n": 1.5, "robot.gains.kp": 2000.0, "cell.timestep": 0.001}
    )
    assert scenario.controller.force_n == 1.5
    assert scenario.cell.timestep == 0.001
    assert list(scenario.robot.gains.kp) == [2000.0] * 7
    assert scenario.robot.name == "iiwa14"


def test_unknown_dotted_key_is_refused_with_the_closest(job):
    with pytest.raises(ScenarioError) as e:
        load_scenario(job).with_overrides({"controller.forc_n": 1.5})
    assert e.value.key == "controller.forc_n"
    assert "did you mean 'force_n'" in str(e.value)


def test_bad_value_gets_the_message_the_file_would(job, tmp_path):
    with pytest.raises(ScenarioError) as by_override:
        load_scenario(job).with_overrides({"controller.force_n": -1.0})
    bad = tmp_path / "bad.toml"
    bad.write_text(LINE_TOML + "[controller]\nforce_n = -1.0\n")
    with pytest.raises(ScenarioError) as by_file:
        load_scenario(bad)
    assert by_override.value.key == by_file.value.key == "controller.force_n"
    assert by_override.value.message == by_file.value.message
    assert str(by_override.value).split(": ", 1)[1] == str(by_file.value).split(": ", 1)[1]


def test_gains_of_the_wrong_length_name_the_key_and_the_joint_count(job):
    with pytest.raises(ScenarioError) as e:
        load_scenario(job).with_overrides({"robot.gains.kp": [1.0, 2.0]})
    assert e.value.key == "robot.gains.kp"
    assert "a list of 7" in e.value.message and "got 2" in e.value.message


def test_unknown_robot_name_suggests_the_closest():
    base = parse_scenario({"source": {"kind": "tag"}})
    with pytest.raises(
        ScenarioError,
        match=r"robot.name: unknown value 'wx250z' \(did you mean "
        r"'wx250s'\?\)",
    ):
        base.with_overrides({"robot.name": "wx250z"})
    assert base.with_overrides({"robot.name": "wx250s"}).robot.name == "wx250s"


def test_overrides_leave_the_original_alone_and_round_trip(job):
    scenario = load_scenario(job)
    changed = scenario.with_overrides({"controller.force_n": 1.5})
    assert scenario.controller.force_n != 1.5
    assert (
        parse_scenario(changed.to_dict(), "again", changed.base_dir).to_dict() == changed.to_dict()
    )


@pytest.mark.sim
def test_an_override_changes_the_run(job):
    from inkarm.jobs.run import run

    scenario = load_scenario(job)
    firm = run(scenario).metrics["contact_force_mean_n"]
    light = run(scenario.with_overrides({"controller.force_n": 0.5})).metrics
    assert light["contact_force_mean_n"] == pytest.approx(0.5, abs=0.1)
    assert light["contact_force_mean_n"] < firm - 0.3


def test_overrides_of_a_scenario_loaded_by_a_relative_path(monkeypatch):
    from pathlib import Path

    from inkarm.jobs.scenario import load_scenario

    root = Path(__file__).resolve().parents[2]
    monkeypatch.chdir(root)
    scenario = load_scenario("scenarios/letter_N.toml")
    changed = scenario.with_overrides({"controller.force_n": 1.5})
    assert changed.controller.force_n == 1.5
    assert changed.source == scenario.source
