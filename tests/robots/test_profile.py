"""Robot profiles as data: every built-in loads, a user's own file works the same way, and a
mistake in a profile names the file and the key."""

from __future__ import annotations

import re

import numpy as np
import pytest

from inkarm.errors import InputError, ScenarioError
from inkarm.jobs.scenario import parse_scenario
from inkarm.robots.profile import RobotProfile, load_profile
from inkarm.robots.registry import DATA, load_robot, robot_names

IIWA_TEXT = (DATA / "iiwa14.toml").read_text()


def test_the_built_in_robots():
    assert robot_names() == ("iiwa14", "menagerie-iiwa14", "menagerie-panda", "wx250s")


@pytest.mark.parametrize("name", robot_names())
def test_every_built_in_profile_loads_and_is_consistent(name):
    robot = load_robot(name)
    assert isinstance(robot, RobotProfile) and robot.name == name
    n = robot.n
    assert len(robot.joint_names) == n == len(set(robot.joint_names))
    for vector in (robot.home_q, robot.speed_limits, robot.torque_limits):
        assert vector.shape == (n,) and np.all(np.isfinite(vector))
    assert np.all(robot.speed_limits > 0) and np.all(robot.torque_limits > 0)
    assert robot.gains.n == n
    np.testing.assert_allclose(robot.gains.torque_limit, robot.torque_limits)
    assert np.all(robot.gains.integral_limit <= robot.gains.torque_limit)
    for joint in robot.joints:
        if joint.range is not None:
            assert joint.range[0] <= joint.home <= joint.range[1]
    assert (robot.model.builder is None) != (robot.model.menagerie is None)
    assert robot.control_period_s > 0 and min(robot.paper_size_mm) > 0
    assert load_robot(name) == robot


@pytest.mark.sim
@pytest.mark.parametrize("name", ["iiwa14", "wx250s"])
def test_built_in_arms_build_with_their_home_and_limits(name):
    from inkarm.sim.cell import build_model, joint_ranges, make_cell

    robot = load_robot(name)
    model = build_model(make_cell(robot=robot))
    np.testing.assert_allclose(model.key("home").qpos, [*robot.home_q, 0.0, 0.0])  # pen, pad
    np.testing.assert_allclose(model.actuator_ctrlrange[:, 1], robot.torque_limits)
    ranges = joint_ranges(model, robot.joint_names)
    np.testing.assert_allclose(ranges, [j.range for j in robot.joints])


def test_with_gains_replaces_and_checks():
    robot = load_robot("iiwa14")
    softer = robot.with_gains(kp=robot.gains.kp / 2)
    np.testing.assert_allclose(softer.gains.kp, robot.gains.kp / 2)
    np.testing.assert_allclose(softer.gains.kd, robot.gains.kd)
    assert softer != robot
    with pytest.raises(InputError) as e:
        robot.with_gains(kp=np.ones(3))
    assert e.value.key.startswith("gains")


def _user_profile(tmp_path, text=IIWA_TEXT, name="my_arm.toml"):
    path = tmp_path / name
    path.write_text(text.replace('name = "iiwa14"', 'name = "my_arm"', 1))
    return path


def test_a_user_profile_file_loads_by_path(tmp_path):
    path = _user_profile(tmp_path)
    robot = load_robot(str(path))
    assert robot.name == "my_arm" and robot.source == str(path)
    assert robot.joint_names == load_robot("iiwa14").joint_names
    assert load_profile(path) == robot


def test_a_scenario_names_a_user_profile_by_file(tmp_path):
    _user_profile(tmp_path)
    scenario = parse_scenario(
        {"source": {"kind": "tag"}, "robot": {"file": "my_arm.toml", "gains": {"kd": 1.0}}},
        "job.toml",
        tmp_path,
    )
    assert scenario.robot.name == "my_arm"
    np.testing.assert_allclose(scenario.robot.gains.kd, 1.0)
    assert scenario.to_dict()["robot"]["file"] == str(tmp_path / "my_arm.toml")
    with pytest.raises(ScenarioError, match=r"job.toml: robot: give one of name"):
        parse_scenario(
            {"source": {"kind": "tag"}, "robot": {"file": "my_arm.toml", "name": "iiwa14"}},
            "job.toml",
            tmp_path,
        )


JOINT2 = 'name = "joint2"\nrange_deg = [-120.0, 120.0]'
BAD_PROFILES = [
    (
        "missing joints",
        lambda t: re.sub(r"\[\[joints\]\].*?(?=\[gains\])", "", t, flags=re.DOTALL),
        "joints",
        r"required",
    ),
    (
        "empty joints",
        lambda t: (
            "joints = []\n" + re.sub(r"\[\[joints\]\].*?(?=\[gains\])", "", t, flags=re.DOTALL)
        ),
        "joints",
        r"expected an array of \[\[joints\]\] tables",
    ),
    (
        "range upside down",
        lambda t: t.replace(JOINT2, 'name = "joint2"\nrange_deg = [120.0, -120.0]'),
        "joints[1].range_deg",
        r"lower < upper",
    ),
    (
        "range of three",
        lambda t: t.replace(JOINT2, 'name = "joint2"\nrange_deg = [1.0, 2.0, 3.0]'),
        "joints[1].range_deg",
        r"expected 2 numbers, got 3",
    ),
    (
        "home outside range",
        lambda t: t.replace("home_rad = 0.45", "home_rad = 3.0"),
        "joints[1].home_rad",
        r"3.0 rad is outside range_deg",
    ),
    (
        "joint without torque",
        lambda t: t.replace("torque_nm = 176.0\nhome_rad = 0.0", "home_rad = 0.0", 1),
        "joints[2].torque_nm",
        r"required",
    ),
    (
        "unknown builder",
        lambda t: t.replace('builder = "iiwa14"', 'builder = "iiwa15"'),
        "model.builder",
        r"unknown value 'iiwa15' \(did you mean 'iiwa14'\?\)",
    ),
    (
        "gains wrong length",
        lambda t: t.replace(
            "kp = [4000.0, 4000.0, 1500.0, 1500.0, 250.0, 150.0, 100.0]", "kp = [4000.0, 4000.0]"
        ),
        "gains.kp",
        r"expected one number or a list of 7 \(one per joint\), got 2",
    ),
    (
        "negative gain",
        lambda t: t.replace("kd = [120.0,", "kd = [-120.0,"),
        "gains.kd",
        r"expected numbers in \[0, 1e\+07\]",
    ),
    (
        "an empty joint name",
        lambda t: t.replace('name = "joint4"', 'name = ""'),
        "joints[3].name",
        r"expected a name of letters, digits",
    ),
    (
        "a joint too slow to draw",
        lambda t: re.sub(r"speed_deg_s = [0-9.]+", "speed_deg_s = 1e-300", t, count=1),
        "joints[0].speed_deg_s",
        r"expected a number >= 0.1, got 1e-300",
    ),
    (
        "a pen holder MuJoCo cannot build",
        lambda t: re.sub(r"holder_mm = [0-9.]+", "holder_mm = 1e-300", t),
        "pen.holder_mm",
        r"expected a number >= 1, got 1e-300",
    ),
    (
        "fewer joints than the builder makes",
        lambda t: re.sub(r"(\[\[joints\]\]\nname = \"joint7\".*?)(?=\[gains\])", "", t,
                         flags=re.DOTALL),
        "joints",
        r"the iiwa14 builder makes 7 joints; got 6 \[\[joints\]\] tables",
    ),
    (
        "unknown key",
        lambda t: t.replace("[pen]\n", "[pen]\nholder = 3.0\n"),
        "pen.holder",
        r"unknown key \(did you mean 'holder_mm'\?\)",
    ),
]


@pytest.mark.parametrize(
    ("why", "edit", "key", "match"), BAD_PROFILES, ids=[b[0] for b in BAD_PROFILES]
)
def test_profile_errors_name_the_file_and_the_key(tmp_path, why, edit, key, match):
    text = edit(IIWA_TEXT)
    assert text != IIWA_TEXT, why
    path = _user_profile(tmp_path, text)
    with pytest.raises(ScenarioError, match=match) as e:
        load_robot(str(path))
    assert e.value.file == str(path) and e.value.key == key
    assert str(e.value).startswith(f"{path}: {key}: ")


def test_unknown_robot_name_suggests_the_closest():
    with pytest.raises(InputError, match=r"unknown robot 'wx250z' \(did you mean 'wx250s'\?\)"):
        load_robot("wx250z")


def test_missing_profile_file_is_named(tmp_path):
    with pytest.raises(ScenarioError, match=r"nope.toml: no such robot profile"):
        load_robot(str(tmp_path / "nope.toml"))
