"""The plotter's scenario keys ([plotter] page_origin, homing), the G-code a plotter job
sends, and the refusals of the plotter backend and ``inkarm gcode`` (issues 20 and 21)."""

from __future__ import annotations

import textwrap

import pytest

from inkarm.errors import InkarmError
from inkarm.hardware.plotter.workspace import Placement
from inkarm.jobs.backends.plotter import scenario_pen
from inkarm.jobs.scenario import load_scenario
from tests.hardware.scenario_files import scenario_file as one_stroke_file

PLACED = "[placement]\ncentre_mm = [105.0, 148.5]\n"


def scenario_file(tmp_path, plotter: str, name: str = "s.toml"):
    return one_stroke_file(tmp_path, "plotter keys",
                           PLACED + "[plotter]\n" + textwrap.dedent(plotter), name)


@pytest.mark.parametrize("plotter, key, hint", [
    ('page_origin = "lower-lef"\n', "plotter.page_origin", "did you mean 'lower-left'"),
    ('homing = "skp"\n', "plotter.homing", "did you mean 'skip'"),
    ("page_origin = [1.0, 2.0, 3.0]\n", "plotter.page_origin", "lower-left corner [x, y]"),
    ('page_origin = ["a", 2.0]\n', "plotter.page_origin[0]", "number"),
    ('home = "skip"\n', "plotter", "homing"),
])
def test_plotter_placement_keys_are_checked_when_the_scenario_is_read(tmp_path, plotter, key,
                                                                      hint):
    path = scenario_file(tmp_path, plotter)
    with pytest.raises(InkarmError) as caught:
        load_scenario(path)
    text = str(caught.value)
    assert key in text and hint in text and str(path) in text


def test_the_scenarios_placement_replaces_the_profiles_key_by_key(tmp_path):
    profile = tmp_path / "pen.toml"
    profile.write_text('page_origin = "upper-right"\nhoming = "skip"\n')
    path = scenario_file(tmp_path, f'profile = "{profile}"\npage_origin = [-200.0, -250.5]\n')
    scenario = load_scenario(path)
    pen = scenario_pen(scenario, None)
    assert pen.placement == Placement((-200.0, -250.5), "skip")  # homing: the profile's
    assert scenario_pen(load_scenario(scenario_file(tmp_path, 'homing = "skip"\n', "b.toml")),
                        None).placement == Placement("auto", "skip")
    # without the keys, the profile's own placement
    assert scenario_pen(load_scenario(scenario_file(tmp_path, "", "c.toml")),
                        str(profile)).placement == Placement("upper-right", "skip")
    # kept through overrides (the scenario's tables parse back)
    again = scenario.with_overrides({"plotter.homing": "auto"})
    assert scenario_pen(again, None).placement == Placement((-200.0, -250.5), "auto")
    with pytest.raises(InkarmError, match="plotter.homing.*did you mean 'auto'"):
        scenario.with_overrides({"plotter.homing": "aut"})


# -- pen profiles: only printable G-code reaches the device ---------------------------------

@pytest.mark.parametrize("text, key, what", [
    ('pen_down = ["M3 S1000\\u0018"]\n', "pen_down[0]", "U+0018"),
    ('header = ["G90", "G94\\u0085"]\n', "header[1]", "U+0085"),
    ('pen_up = ["M5\\t"]\n', "pen_up[0]", "U+0009"),
    ('footer = ["M5 (up!)"]\n', "footer[0]", "real-time"),
    ("pen_down = []\n", "pen_down", "at least one G-code line"),
    ("pen_up = []\n", "pen_up", "at least one G-code line"),
])
def test_pen_profiles_refuse_bytes_grbl_acts_on_and_empty_pen_groups(tmp_path, text, key,
                                                                      what):
    from inkarm.hardware.plotter.profiles import load_profile

    path = tmp_path / "pen.toml"
    path.write_text(text)
    with pytest.raises(InkarmError) as caught:
        load_profile(str(path))
    message = str(caught.value)
    assert key in message and what in message and str(path) in message


# -- inkarm gcode ---------------------------------------------------------------------------

@pytest.mark.parametrize("rows, where", [
    ("0,-5,10,0\n0.5,20,10,0\n", "stroke 1 point 1 at (-5.00, 10.00) mm"),
    ("0,5,10,0\n1,450,10,0\n", "stroke 1 point 2 at (450.00, 10.00) mm"),
    ("0,5,10,0\n1,6,10,0\n0,5,20,1\n1,5,301.9,1\n", "stroke 2 point 2 at (5.00, 301.90) mm"),
])
def test_gcode_refuses_points_beyond_the_travel_in_one_line(tmp_path, capsys, rows, where):
    from inkarm.cli import main

    drawing = tmp_path / "d.csv"
    drawing.write_text("t,x,y,stroke\n" + rows)
    out = tmp_path / "d.gcode"
    assert main(["gcode", str(drawing), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err and where in err
    assert ("$130" in err or "$131" in err) and "--travel X,Y" in err and "0 to 300 mm" in err
    assert not out.exists()
    # the machine's own travel lets it through
    assert main(["gcode", str(drawing), "--out", str(out), "--travel", "500,500"]) == 0 \
        or where.startswith("stroke 1 point 1")  # a negative x is beyond any travel
    for bad in ("0,5", "a,b", "5", "1e9,5"):
        assert main(["gcode", str(drawing), "--out", str(out), "--travel", bad]) == 2
        assert "--travel" in capsys.readouterr().err


def test_gcode_files_have_the_usual_mode_and_name_what_a_run_streams(tmp_path, capsys):
    import os

    from inkarm.cli import main
    from inkarm.jobs.backends.plotter import prepared, run_lines

    out = tmp_path / "q.gcode"
    old = os.umask(0o022)
    try:
        assert main(["gcode", "scenarios/quick_stroke.toml", "--out", str(out)]) == 0
    finally:
        os.umask(old)
    assert out.stat().st_mode & 0o777 == 0o644  # 0666 & ~umask, as open() makes files
    text = capsys.readouterr().out
    scenario = load_scenario("scenarios/quick_stroke.toml")
    pen, _, drawing = prepared(scenario, None)
    written = len(out.read_text().splitlines())
    assert f"{out}: {written} lines" in text
    assert f"streams {len(run_lines(scenario, pen, drawing))} lines" in text
