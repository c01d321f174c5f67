"""The scenario's ``[axidraw]`` table: the AxiDraw profile and where the sheet lies, checked
when the scenario is read (errors name the file and key), used by the ``axidraw`` backend."""

from __future__ import annotations

import pytest

from inkarm.errors import ScenarioError
from inkarm.hardware.axidraw.profiles import load_profile
from inkarm.jobs.backends.axidraw import prepared
from inkarm.jobs.scenario import load_scenario

SOURCE = """
[source]
kind = "text"
text = "ab"

[placement]
page_size = "a3"
landscape = true
fit_to_margins_mm = 20
"""


def scenario_with(tmp_path, table: str):
    path = tmp_path / "job.toml"
    path.write_text(SOURCE + table)
    return load_scenario(path)


def test_the_profile_and_the_page_origin_come_from_the_table(tmp_path):
    scenario = scenario_with(tmp_path, '[axidraw]\nprofile = "v3_a3"\npage_origin = [5, 7.5]\n')
    profile, size, _drawing, _ = prepared(scenario, None)
    assert profile.model == load_profile("v3_a3").model != load_profile("v3").model
    assert profile.page_origin == (5.0, 7.5)
    assert size == (420.0, 297.0)
    assert scenario.to_dict()["axidraw"] == {"profile": "v3_a3", "page_origin": [5.0, 7.5]}


def test_the_command_line_profile_wins_over_the_table(tmp_path):
    scenario = scenario_with(tmp_path, '[axidraw]\nprofile = "v3"\n')
    # an A3 sheet does not fit a V3's travel: refused, naming the travel
    with pytest.raises(Exception, match="travel"):
        prepared(scenario, None)
    assert prepared(scenario, "v3_a3")[0].model == load_profile("v3_a3").model


@pytest.mark.parametrize("table, key, message", [
    ('[axidraw]\nprofile = "v4"\n', "axidraw.profile", "v4"),
    ('[axidraw]\npage_origin = [1]\n', "axidraw.page_origin", "two numbers"),
    ('[axidraw]\npage_origin = ["a", 2]\n', "axidraw.page_origin", "two numbers"),
    ('[axidraw]\nprofil = "v3"\n', "axidraw", "profile"),
])
def test_a_bad_table_names_the_file_and_key(tmp_path, table, key, message):
    with pytest.raises(ScenarioError, match=message) as info:
        scenario_with(tmp_path, table)
    assert key in str(info.value) and "job.toml" in str(info.value)
