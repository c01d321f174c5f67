"""Plug-ins: a small package (``inkarm_demo_plugin``, next to this file) installed the way pip
makes one visible (a copy on ``sys.path`` with its ``.dist-info`` and entry points in the group
``inkarm.plugins``) adds a law, a watchdog, an ink, a robot, a stroke kind and a backend, and a
scenario uses each by name; a broken entry point and an unknown name are refused, naming what
is wrong."""

from __future__ import annotations

import shutil
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from inkarm.control.laws import LAWS, make_law
from inkarm.control.watchdogs import WATCHDOGS, make_watchdog
from inkarm.errors import InputError, ScenarioError
from inkarm.ink.inks import INKS, make_ink
from inkarm.io.planfile import KINDS, parse_plan, stroke_kinds
from inkarm.jobs.backends import backend_names, get_backend, run_backend
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario, source_drawing
from inkarm.plans.realise import realise_plan, stroke_size
from inkarm.plugins import registry, reload_entry_points
from inkarm.robots.registry import load_robot, robot_names

PACKAGE = Path(__file__).parent / "inkarm_demo_plugin"
SCENARIOS = Path(__file__).parents[2] / "scenarios"
ENTRY_POINTS = {
    "law.demo": "inkarm_demo_plugin.law:ScaledFeedForward",
    "watchdog.stop_after": "inkarm_demo_plugin.watchdog:StopAfter",
    "ink.demo": "inkarm_demo_plugin.ink:StampInk",
    "robot.demo": "inkarm_demo_plugin:ROBOT",
    "stroke_kind.circle": "inkarm_demo_plugin.circle:Circle",
    "backend.demo": "inkarm_demo_plugin.backend:BACKEND",
}
CIRCLE = {"name": "ring", "kind": "circle", "centre": [0.0, 0.0], "radius": 6.0}


def _install(site: Path, distribution: str, entry_points: dict[str, str]) -> None:
    """What ``pip install`` leaves in site-packages: the package and its ``.dist-info``."""
    if not (site / PACKAGE.name).exists():
        shutil.copytree(PACKAGE, site / PACKAGE.name)
    info = site / f"{distribution}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {distribution}\nVersion: 0.1\n")
    lines = "".join(f"{name} = {target}\n" for name, target in entry_points.items())
    (info / "entry_points.txt").write_text(f"[inkarm.plugins]\n{lines}")
    reload_entry_points()


@pytest.fixture
def site(tmp_path):
    """A folder on ``sys.path`` like site-packages; what it added is forgotten afterwards."""
    sys.path.insert(0, str(tmp_path))
    reload_entry_points()
    yield tmp_path
    sys.path.remove(str(tmp_path))
    for module in [m for m in sys.modules if m.split(".")[0] in (PACKAGE.name, "bad_robots", "bad_kinds")]:
        del sys.modules[module]
    reload_entry_points()


@pytest.fixture
def demo(site):
    _install(site, "inkarm_demo_plugin", ENTRY_POINTS)
    return site


def _plan(text: str):
    return parse_plan(tomllib.loads(text), source="plan.toml")


def test_each_registry_lists_the_plugin_after_its_builtins_and_forgets_it_when_removed(demo):
    assert registry("law").names()[-1] == "demo" and "position" in LAWS.names()
    assert WATCHDOGS.names()[-1] == "stop_after"
    assert INKS.names() == ("marker", "brush", "pencil", "demo")
    assert robot_names() == ("iiwa14", "menagerie-iiwa14", "menagerie-panda", "wx250s", "demo")
    assert stroke_kinds() == (*KINDS, "circle")
    assert backend_names()[-1] == "demo" and "sim" in backend_names()
    shutil.rmtree(demo / "inkarm_demo_plugin-0.1.dist-info")  # pip uninstall
    reload_entry_points()
    assert "demo" not in INKS.names() and stroke_kinds() == KINDS and "demo" not in robot_names()


@pytest.mark.sim
def test_a_scenario_draws_with_the_plugins_law_watchdog_ink_robot_and_stroke_kind(demo):
    scenario = load_scenario(SCENARIOS / "quick_stroke.toml").with_overrides({
        "robot.name": "demo",
        "controller.law": "demo",
        "controller.demo": {"scale": 1.0},
        "controller.watchdogs": ["stop_after"],
        "ink.model": "demo",
        "ink.opacity": 0.4,
        "source.plan.strokes": [CIRCLE],
        "source.plan.circle": {"duration": 1.5},
    })
    law = sys.modules["inkarm_demo_plugin.law"].ScaledFeedForward
    starts = law.starts
    result = run(scenario)
    assert result.status == "ok", result.reason
    assert law.starts == starts + 1  # the plug-in's law drove the arm
    assert result.scenario.robot.name == "demo"  # the plug-in's profile
    assert type(scenario.ink.make()).__module__ == "inkarm_demo_plugin.ink"
    assert result.canvas.image.max() == pytest.approx(0.4, abs=1e-3)  # its ink: opacity 0.4
    source = source_drawing(scenario).strokes[0].pos  # the plug-in's stroke kind: a circle
    np.testing.assert_allclose(np.linalg.norm(source, axis=1), 6.0, atol=1e-9)
    placed = result.drawing.strokes[0].pos
    np.testing.assert_allclose(np.linalg.norm(placed - placed[:-1].mean(axis=0), axis=1), 6.0,
                               atol=1e-6)
    weak = run(scenario.with_overrides({"controller.demo": {"scale": 0.0}}))  # its setting
    assert weak.metrics["tracking_rms_mm"] > 1.3 * result.metrics["tracking_rms_mm"]
    stopped = run(scenario.with_overrides({"controller.stop_after": {"after_s": 0.5}}))
    assert stopped.status == "failed"
    assert stopped.reason.startswith("stop_after: the demo plug-in stops runs after 0.5 s at t = ")
    on_demo = run_backend("demo", scenario)  # the plug-in's backend (`inkarm draw --backend demo`)
    assert on_demo.status == "ok", on_demo.reason
    assert "drawn by the demo plug-in's backend" in on_demo.notes
    np.testing.assert_array_equal(on_demo.canvas.image, result.canvas.image)


def test_the_plugins_stroke_kind_reads_its_keys_and_settings_and_is_budgeted(demo):
    plan = _plan("samples = 2\n[model]\ndt = 0.01\n[circle]\nturns = 2.0\n"
                 "[[strokes]]\nkind = 'circle'\nradius = 3.0\ncircle = { duration = 0.5 }\n")
    stroke = plan.strokes[0]
    assert stroke.options == {"duration": 0.5, "turns": 2.0, "radius": 3.0}
    assert stroke_size(stroke, 2) == (51, 8.0 * 51 * 5 * 3)
    result = realise_plan(plan)
    assert result.strokes[0].samples.shape == (2, 51, 2)
    np.testing.assert_allclose(result.strokes[0].mean.pos[[0, 25, 50]],
                               [[3.0, 0.0], [3.0, 0.0], [3.0, 0.0]], atol=1e-12)
    with pytest.raises(ScenarioError, match=r"plan.toml: circle.speed: unknown key; valid keys "
                                            r"here: duration, turns"):
        _plan("[circle]\nspeed = 1\n[[strokes]]\nkind = 'circle'\nradius = 3.0\n")
    with pytest.raises(ScenarioError, match=r"strokes\[0\].circle: only applies to circle "
                                            r"strokes, this one is gaussian"):
        _plan("[[strokes]]\ntargets = [{ mean = [0.0, 0.0], cov = 1.0 }]\ncircle = {}\n")
    with pytest.raises(ScenarioError, match=r"strokes\[0\].radius: required for a circle stroke"):
        _plan("[[strokes]]\nkind = 'circle'\n")


def test_plugins_are_also_named_by_import_path_without_an_entry_point(site):
    shutil.copytree(PACKAGE, site / PACKAGE.name)  # on the path, no .dist-info
    plan = _plan("[[strokes]]\nkind = 'inkarm_demo_plugin.circle:Circle'\nradius = 2.0\n")
    assert realise_plan(plan).drawing.strokes[0].pos[0].tolist() == [2.0, 0.0]
    scenario = load_scenario(SCENARIOS / "quick_stroke.toml").with_overrides(
        {"ink.model": "inkarm_demo_plugin.ink:StampInk", "ink.width_mm": 1.5})
    assert scenario.ink.make().width_mm == 1.5
    assert load_robot("inkarm_demo_plugin:ROBOT").name == "demo"
    with pytest.raises(InputError, match=r"strokes\[0\].kind: 'inkarm_demo_plugin.ink:StampInk' "
                                            r"is not a stroke kind: .*\(missing: parse, realise\)"):
        _plan("[[strokes]]\nkind = 'inkarm_demo_plugin.ink:StampInk'\n")
    with pytest.raises(InputError, match=r"ink.model: 'inkarm_demo_plugin.watchdog:StopAfter' "
                                            r"is not an ink model: an ink model is a dataclass"):
        load_scenario(SCENARIOS / "quick_stroke.toml").with_overrides(
            {"ink.model": "inkarm_demo_plugin.watchdog:StopAfter"})
    with pytest.raises(ScenarioError, match=r"ink.opacity: expected an opacity in \(0, 1\], "
                                            r"got 2.0"):
        load_scenario(SCENARIOS / "quick_stroke.toml").with_overrides(
            {"ink.model": "inkarm_demo_plugin.ink:StampInk", "ink.opacity": 2.0})


def test_a_robot_plugin_is_a_profile_file_a_profile_or_a_callable_returning_one(site):
    (site / "bad_robots.py").write_text(
        "from inkarm.robots.registry import load_robot\n"
        "def made():\n    return load_robot('wx250s')\n"
        "PROFILE = load_robot('wx250s')\n"
        "NUMBER = 42\n"
        "def broken():\n    raise RuntimeError('no arm today')\n")
    assert load_robot("bad_robots:made") is load_robot("bad_robots:PROFILE") is load_robot("wx250s")
    with pytest.raises(InputError, match=r"robot: robot 'bad_robots:NUMBER' is 42; expected a "
                                         r"RobotProfile, a profile file \(a path\) or a callable"):
        load_robot("bad_robots:NUMBER")
    with pytest.raises(InputError, match=r"robot 'bad_robots:broken': its plug-in "
                                         r"bad_robots:broken failed: RuntimeError: no arm today"):
        load_robot("bad_robots:broken")


def test_a_stroke_kind_that_realises_the_wrong_shape_is_named(site):
    (site / "bad_kinds.py").write_text(
        "import numpy as np\n"
        "from inkarm.core.trajectory import Trajectory\n"
        "from inkarm.io.planfile import read_points_stroke\n"
        "class Flat:\n"
        "    keys = ('points',)\n"
        "    def parse(self, rd, stroke, key, context):\n"
        "        return read_points_stroke(rd, stroke, key, context)\n"
        "    def realise(self, stroke, samples, stream):\n"
        "        mean = Trajectory(t=np.arange(2.0), pos=stroke.points)\n"
        "        return mean, np.zeros((samples, 5, 2))\n")
    plan = _plan("samples = 3\n[[strokes]]\nkind = 'bad_kinds:Flat'\npoints = [[0, 0], [1, 0]]\n")
    with pytest.raises(InputError, match=r"plan.toml: strokes\[0\].kind: stroke kind "
                                         r"'bad_kinds:Flat' realised samples \(3, 5, 2\); expected "
                                         r"a Trajectory and samples of shape \(K, N, D\) = \(3, N, D\)"):
        realise_plan(plan)


def test_an_entry_point_that_fails_to_load_names_the_plugin_its_package_and_target(site):
    _install(site, "inkarm_broken_plugin", {
        "law.broken": "inkarm_broken_plugin.laws:Nope",
        "ink.broken": "inkarm_demo_plugin.ink:Missing",
        "stroke_kind.broken": "inkarm_broken_plugin.kinds:Spiral",
        "robot.broken": "inkarm_broken_plugin:ARM",
        "backend.broken": "inkarm_demo_plugin.backend:Nothing",
    })
    with pytest.raises(InputError, match=r"law: the law plug-in 'law.broken' of the package "
                                         r"'inkarm_broken_plugin' \(inkarm_broken_plugin.laws:Nope\) "
                                         r"failed to load: ModuleNotFoundError: No module named "
                                         r"'inkarm_broken_plugin'"):
        make_law("broken")
    with pytest.raises(InputError, match=r"the ink plug-in 'ink.broken' .*\(inkarm_demo_plugin."
                                         r"ink:Missing\) failed to load: AttributeError"):
        make_ink("broken")
    with pytest.raises(InputError, match=r"plan.toml: stroke_kind: the stroke_kind plug-in "
                                         r"'stroke_kind.broken' .*inkarm_broken_plugin.kinds:Spiral"):
        _plan("[[strokes]]\ntargets = [{ mean = [0.0, 0.0], cov = 1.0 }]\n")
    with pytest.raises(InputError, match=r"the robot plug-in 'robot.broken' "):
        load_robot("broken")
    with pytest.raises(InputError, match=r"the backend plug-in 'backend.broken' .*\(inkarm_demo_"
                                         r"plugin.backend:Nothing\) failed to load: AttributeError"):
        get_backend("broken")
    # a broken plug-in is refused when it is asked for, never when another name is
    assert load_scenario(SCENARIOS / "quick_stroke.toml").ink.model == "marker"
    with pytest.raises(InputError, match=r"the law plug-in 'law.broken'"):  # every time asked
        make_law("broken")


def test_an_unknown_name_lists_the_valid_ones_with_the_plugins(demo):
    with pytest.raises(InputError, match=r"unknown law 'dmeo' \(did you mean 'demo'\?\); "
                                         r"expected one of 'position', .*, 'demo'$"):
        make_law("dmeo")
    with pytest.raises(InputError, match=r"unknown watchdog 'stop_afterr' \(did you mean "
                                         r"'stop_after'\?\); expected one of .*'stop_after'"):
        make_watchdog("stop_afterr")
    with pytest.raises(InputError, match=r"ink model 'dem': expected one of \['brush', 'demo', "
                                         r"'marker', 'pencil'\]"):
        make_ink("dem")
    quick = load_scenario(SCENARIOS / "quick_stroke.toml")
    with pytest.raises(ScenarioError, match=r"ink.model: unknown value 'dem' \(did you mean "
                                            r"'demo'\?\); expected one of 'marker', 'brush', "
                                            r"'pencil', 'demo'"):
        quick.with_overrides({"ink.model": "dem"})
    with pytest.raises(ScenarioError, match=r"robot.name: unknown value 'dmo' \(did you mean "
                                            r"'demo'\?\); expected one of 'iiwa14', .*'wx250s', "
                                            r"'demo'"):
        quick.with_overrides({"robot.name": "dmo"})
    with pytest.raises(InputError, match=r"--backend: unknown backend 'dmeo' \(did you mean "
                                         r"'demo'\?\); expected one of 'sim', .*, 'demo'$"):
        get_backend("dmeo")
    with pytest.raises(ScenarioError, match=r"strokes\[0\].kind: unknown value 'circel' \(did you "
                                            r"mean 'circle'\?\); expected one of 'gaussian', "
                                            r"'keypoints', 'human_line', 'minjerk', 'circle'"):
        _plan("[[strokes]]\nkind = 'circel'\nradius = 1.0\n")
