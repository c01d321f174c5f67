"""Scenarios: the schema's error paths, the shipped jobs, and whole drawing runs in MuJoCo."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from inkarm.cli import main
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError, ScenarioError, UnreachableError
from inkarm.jobs.outputs import write_run
from inkarm.jobs.run import run
from inkarm.jobs.scenario import (
    DEFAULT_SCENARIO,
    Placement,
    load_scenario,
    parse_scenario,
    place,
    source_drawing,
)

SCENARIOS = sorted((Path(__file__).parents[2] / "scenarios").glob("*.toml"))
LINE = {"kind": "plan", "plan": {"strokes": [{"targets": [{"mean": [0.0, 0.0], "cov": 1.0},
                                                          {"mean": [30.0, 10.0], "cov": 1.0}]}]}}


def _scenario(tmp_path: Path, text: str, name: str = "job.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def default_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("default")
    result = run(load_scenario())
    write_run(result, out)
    return result, out


# -- the default job meets the drawing cell's targets -----------------------------------------


@pytest.mark.sim
@pytest.mark.slow
def test_default_scenario_meets_the_drawing_targets(default_run):
    result, out = default_run
    assert result.ok and result.reason == ""
    m = result.metrics
    assert m["tracking_rms_mm"] <= 0.3
    assert m["tracking_max_mm"] <= 1.0
    assert m["ink_chamfer_mm"] <= 0.3
    assert m["gap_mm"] <= 1.0
    assert m["contact_force_std_n"] <= 0.1
    assert m["joint_limit_margin_rad"] > 0.0
    lo, hi = result.drawing.bounds()
    assert 55.0 <= hi[1] - lo[1] <= 65.0  # a letter about 60 mm tall
    peak = max(s.speed().max() for s in result.drawing.strokes)
    assert peak >= 100.0  # human speed
    written = json.loads((out / "metrics.json").read_text())
    assert written["status"] == "ok" and written["reasons"] == []
    assert {k: written[k] for k in m} == pytest.approx(m)
    for name in ("canvas.png", "report.png", "trace.npz", "reference.csv"):
        assert (out / name).stat().st_size > 0


@pytest.mark.sim
@pytest.mark.slow
def test_trace_holds_the_whole_run(default_run):
    _, out = default_run
    with np.load(out / "trace.npz") as z:
        n = len(z["time"])
        assert z["q"].shape == (n, 7) and z["tip"].shape == (n, 3)
        assert z["force"].shape == (n,) and z["reference"].shape == (n, 3)
        assert np.all(np.diff(z["time"]) > 0)
        assert set(z["phases"][np.unique(z["phase"])]) >= {"approach", "draw", "home"}


@pytest.mark.sim
@pytest.mark.parametrize("corner", [(30.0, 35.0), (180.0, 35.0), (30.0, 262.0), (180.0, 262.0)])
def test_same_gains_draw_at_the_corners_of_a4(tmp_path, corner):
    text = DEFAULT_SCENARIO.read_text().replace("centre_mm = [105.0, 148.5]",
                                                f"centre_mm = [{corner[0]}, {corner[1]}]")
    result = run(load_scenario(_scenario(tmp_path, text)))
    assert result.ok, result.reason
    m = result.metrics
    assert m["tracking_rms_mm"] <= 0.3 and m["tracking_max_mm"] <= 1.0
    assert m["ink_chamfer_mm"] <= 0.3 and m["gap_mm"] <= 1.0
    assert m["contact_force_std_n"] <= 0.1 and m["joint_limit_margin_rad"] > 0.0


# -- refusals before and during simulation ---------------------------------------------------


@pytest.mark.sim
def test_placement_off_the_sheet_is_refused_before_simulating_naming_the_point(tmp_path):
    text = DEFAULT_SCENARIO.read_text().replace("centre_mm = [105.0, 148.5]", "centre_mm = [200.0, 148.5]")
    with pytest.raises(UnreachableError, match=r"stroke 0, point \(2\d\d\.\d, \d+\.\d\) mm: off the 210 x 297 mm sheet"):
        run(load_scenario(_scenario(tmp_path, text)))


@pytest.mark.sim
def test_paper_out_of_reach_is_refused_naming_the_point(tmp_path):
    text = DEFAULT_SCENARIO.read_text() + "\n[sim]\npaper_centre_mm = [1500.0, 0.0]\n"
    with pytest.raises(UnreachableError, match=r"stroke 0, point \(\d+\.\d, \d+\.\d\) mm: out of reach"):
        run(load_scenario(_scenario(tmp_path, text)))


@pytest.mark.sim
def test_diverging_gains_fail_the_run_and_keep_the_partial_trace_and_canvas(tmp_path):
    text = DEFAULT_SCENARIO.read_text() + "\n[robot.gains]\nkp = 1e7\nkd = 0.0\n"
    result = run(load_scenario(_scenario(tmp_path, text)))
    assert result.status == "failed" and not result.ok
    assert result.reason.split(":")[0] in ("torque_saturated", "diverged", "joint_speed")
    assert result.metrics == {}
    write_run(result, tmp_path / "out")
    with np.load(tmp_path / "out" / "trace.npz") as z:
        assert 0 < len(z["time"])
    assert (tmp_path / "out" / "canvas.png").exists()
    assert not (tmp_path / "out" / "metrics.json").exists()


# -- the schema ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("titel = 'x'\n[source]\nkind='plan'\nfile='p.toml'\n", r"titel: unknown key \(did you mean 'title'\?\)"),
        ("title = 'x'\n", r"source: required"),
        ("[source]\nkind = 'plans'\n", r"source.kind: unknown value 'plans' \(did you mean 'plan'\?\)"),
        ("[source]\nfile = 'p.toml'\n", r"source.kind: required"),
        ("[source]\nkind = 'plan'\nfile = 'missing.toml'\n", r"source.file: no such file: .*missing.toml"),
        ("[source]\nkind = 'trajectory'\n", r"source.file: required"),
        ("[source]\nkind = 'text'\ntext = '  '\n", r"source.text: empty text"),
        ("[source]\nkind = 'trace'\nfile = 'job.toml'\ncompression = 1.5\n", r"source.compression: expected a number in \(0, 1\), got 1.5"),
        ("seed = -1\n[source]\nkind = 'tag'\n", r"seed: expected an integer in 0..9223372036854775807, got -1"),
        ("[source]\nkind = 'tag'\n[placement]\nscale = 'big'\n", r"placement.scale: expected a number, got 'big' \(str\)"),
        ("[source]\nkind = 'tag'\n[placement]\nscale = 2\nheight_mm = 3\n", r"placement: give one of height_mm and scale"),
        ("[source]\nkind = 'tag'\n[placement]\ncentre_mm = [1, 2, 3]\n", r"placement.centre_mm: expected \[x, y\]"),
        ("[source]\nkind = 'tag'\n[sim]\ntimestep = -1.0\n", r"sim.timestep: expected a number in \[1e-05, 0.01\] s, got -1.0"),
        ("[source]\nkind = 'tag'\n[sim]\npaper_size = [1, 2]\n", r"sim.paper_size: unknown key \(did you mean 'paper_size_mm'\?\)"),
        ("[source]\nkind = 'tag'\n[sim]\npaper_size_mm = [1, 2, 3]\n", r"sim.paper_size_mm: expected 2 numbers, got 3"),
        ("[source]\nkind = 'tag'\n[sim.plnt]\nseed = 1\n", r"sim.plnt: unknown key \(did you mean 'plant'\?\)"),
        ("[source]\nkind = 'tag'\n[sim.plant]\nseed = 1\n[plant]\nseed = 2\n", r"plant: give \[sim.plant\] only \(\[plant\] is its old name\)"),
        ("[source]\nkind = 'tag'\n[dynamixel]\nlatency_ms = 3\n", r"dynamixel: robot 'iiwa14' has no \[backends.dynamixel\] table"),
        ("[source]\nkind = 'tag'\n[robot]\nname = 'wx250s'\n[dynamixel]\nlatency_ms = -3\n", r"dynamixel.latency_ms: expected a number >= 0, got -3"),
        ("[source]\nkind = 'tag'\n[robot]\nname = 'wx250s'\n[dynamixel]\ncalibration = 'nope.toml'\n", r"dynamixel.calibration: no such file: .*nope.toml"),
        ("[source]\nkind = 'tag'\n[plotter]\nprofile = 'serv'\n", r"plotter.profile: unknown pen profile 'serv' \(did you mean 'servo'\?\)"),
        ("[source]\nkind = 'tag'\n[plotter]\nport = 'x'\n", r"plotter.port: unknown key"),
        ("[source]\nkind = 'tag'\n[controller]\nforce_n = 'hard'\n", r"controller.force_n: expected a number"),
        ("[source]\nkind = 'tag'\n[robot.gains]\nkpp = 1\n", r"robot.gains.kpp: unknown key \(did you mean 'kp'\?\)"),
        ("[source]\nkind = 'tag'\n[robot]\nname = 'wx250z'\n", r"robot.name: unknown value 'wx250z' \(did you mean 'wx250s'\?\)"),
        ("[source]\nkind = 'tag'\n[robot]\nfile = 'arm.toml'\n", r"robot.file: no such file: .*arm.toml"),
        ("[source]\nkind = 'tag'\n[robot]\narm = 'x'\n", r"robot.arm: unknown key"),
        ("[source]\nkind = 'tag'\n[ink]\nmodel = 'crayon'\n", r"ink.model: unknown value 'crayon'"),
        ("[source]\nkind = 'tag'\n[ink]\nwidth = 3\n", r"ink.width: unknown key; valid keys here: w0_mm, k_mm"),
        ("[source]\nkind = 'plan'\nfile = 'job.toml'\nsample = [0]\nspacing_mm = 5\n", r"source.spacing_mm: only with a list of several samples"),
        ("[source\n", r"not valid TOML"),
    ],
)
def test_bad_scenarios_name_the_file_and_the_key(tmp_path, text, match):
    path = _scenario(tmp_path, text)
    with pytest.raises(ScenarioError, match=match) as e:
        load_scenario(path)
    assert str(path) in str(e.value)


def test_missing_scenario_file_is_named(tmp_path):
    with pytest.raises(ScenarioError, match=r"nope.toml: no such scenario file"):
        load_scenario(tmp_path / "nope.toml")


def test_source_plan_that_does_not_parse_is_named(tmp_path):
    (tmp_path / "plan.toml").write_text("[[strokes]]\ntargets = [{ mean = [0, 0], cov = -1.0 }]\n")
    path = _scenario(tmp_path, "[source]\nkind = 'plan'\nfile = 'plan.toml'\n")
    with pytest.raises(ScenarioError, match=r"plan.toml: strokes\[0\].targets\[0\].cov"):
        source_drawing(load_scenario(path))


def test_source_trajectory_with_nan_is_refused_naming_the_line(tmp_path):
    (tmp_path / "path.csv").write_text("t,x,y\n0,0,0\n0.1,nan,1\n0.2,2,2\n")
    path = _scenario(tmp_path, "[source]\nkind = 'trajectory'\nfile = 'path.csv'\n")
    with pytest.raises(InputError, match=r"path.csv:3: NaN or inf value"):
        source_drawing(load_scenario(path))


def test_inline_plan_errors_name_the_scenario(tmp_path):
    path = _scenario(tmp_path, "[source]\nkind = 'plan'\n[[source.plan.strokes]]\ntargets = [{ mean = [0, 0], cov = [[1, 2], [0, 1]] }]\n")
    with pytest.raises(ScenarioError, match=r"job.toml: source.plan.*strokes\[0\].targets\[0\].cov.*not symmetric"):
        source_drawing(load_scenario(path))


# -- placement ----------------------------------------------------------------------------------


def test_place_scales_to_height_and_centres_the_bounding_box():
    d = Drawing([Trajectory(t=[0, 1, 2], pos=[[0, 0], [10, 20], [20, 0]])])
    placed = place(d, Placement(centre_mm=(100.0, 50.0), height_mm=60.0), (210, 297))
    lo, hi = placed.bounds()
    assert np.allclose(hi - lo, [60.0, 60.0]) and np.allclose((lo + hi) / 2, [100.0, 50.0])


def test_place_rotates_about_the_centre_and_stretches_time():
    d = Drawing([Trajectory(t=[0, 1], pos=[[0, 0], [10, 0]])])
    placed = place(d, Placement(centre_mm=(0.0, 0.0), rotation_deg=90.0, time_scale=2.0), (210, 297))
    assert np.allclose(placed.strokes[0].pos, [[0, -5], [0, 5]])
    assert np.allclose(placed.strokes[0].t, [0, 2])


def test_several_samples_are_drawn_side_by_side(tmp_path):
    data = {"seed": 1, "source": dict(LINE, sample=[0, 1, 2], spacing_mm=50.0)}
    d = source_drawing(parse_scenario(data, "inline", tmp_path))
    assert len(d.strokes) == 3
    starts = np.array([s.pos[0] for s in d.strokes])
    assert np.allclose(np.diff(starts[:, 0]), 50.0, atol=5.0)
    assert not np.allclose(d.strokes[0].pos[5:-5] - starts[0], d.strokes[1].pos[5:-5] - starts[1])


# -- every shipped scenario ---------------------------------------------------------------------


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_every_shipped_scenario_builds_a_drawing_that_fits_the_sheet(path):
    scenario = load_scenario(path)
    d = place(source_drawing(scenario), scenario.placement, (210.0, 297.0))
    lo, hi = d.bounds()
    assert np.all(lo[:2] >= 0.0) and hi[0] <= 210.0 and hi[1] <= 297.0


@pytest.mark.sim
def test_cli_draw_writes_the_pictures_and_says_where(tmp_path, capsys):
    scenario = _scenario(tmp_path, "[source]\nkind = 'plan'\n[[source.plan.strokes]]\n"
                         "targets = [{ mean = [0.0, 0.0], cov = 1.0 }, { mean = [20.0, 5.0], cov = 1.0 }]\n"
                         "[ink]\npx_per_mm = 4.0\n")
    assert main(["draw", str(scenario), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "tracking RMS" in out and str(tmp_path / "o" / "canvas.png") in out
    assert (tmp_path / "o" / "report.png").exists()


def test_cli_draw_bad_scenario_exits_2_with_one_line(tmp_path, capsys):
    scenario = _scenario(tmp_path, "[source]\nkind = 'plan'\nfiel = 'x.toml'\n")
    assert main(["draw", str(scenario), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "source.fiel: unknown key (did you mean 'file'?)" in err[0]


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        ("[controller]\nforce_n = 5.0\n", r"job.toml: controller.force_n: 5.0 N compresses the pen"),
        ("[robot.gains]\nkp = [1.0, 2.0]\n", r"job.toml: robot.gains.kp: expected one number or a list of 7"),
        ("[robot.gains]\nkd = -3.0\n", r"job.toml: robot.gains.kd: expected a number >= 0, got -3.0"),
        ("[ink]\npx_per_mm = 1000\n", r"job.toml: ink.px_per_mm: expected at most 40"),
    ],
)
def test_bad_cell_and_controller_settings_name_the_file_and_key(tmp_path, extra, match):
    path = _scenario(tmp_path, "[source]\nkind = 'plan'\n[[source.plan.strokes]]\n"
                     "targets = [{ mean = [0.0, 0.0], cov = 1.0 }, { mean = [20.0, 5.0], cov = 1.0 }]\n" + extra)
    with pytest.raises(InputError, match=match):
        run(load_scenario(path))


def test_unknown_style_of_each_source_kind_is_named(tmp_path):
    with pytest.raises(ScenarioError, match=r"source.style: unknown value 'nope'; expected one of 'faithful'"):
        load_scenario(_scenario(tmp_path, "[source]\nkind = 'tag'\nstyle = 'nope'\n"))
    with pytest.raises(ScenarioError, match=r"source.style: unknown value 'cursive'; expected one of 'geometric', 'semi-tied'"):
        load_scenario(_scenario(tmp_path, "[source]\nkind = 'trace'\nfile = 'job.toml'\nstyle = 'cursive'\n"))


@pytest.mark.sim
def test_three_dimensional_sources_are_refused(tmp_path):
    (tmp_path / "p.csv").write_text("t,x,y,z\n0,0,0,0\n1,10,0,1\n")
    path = _scenario(tmp_path, "[source]\nkind = 'trajectory'\nfile = 'p.csv'\n")
    with pytest.raises(InputError, match=r"job.toml: source: the drawing has 3-D positions"):
        run(load_scenario(path))


@pytest.mark.sim
@pytest.mark.slow
@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_every_shipped_scenario_draws_and_writes_strict_json(path, tmp_path):
    import json

    from inkarm.jobs.outputs import write_run
    from inkarm.jobs.run import run

    result = run(load_scenario(path))
    assert result.ok, result.reason
    write_run(result, tmp_path, report=False)

    def refuse(constant):
        raise AssertionError(f"bare {constant} in JSON")

    metrics = json.loads((tmp_path / "metrics.json").read_text(), parse_constant=refuse)
    status = json.loads((tmp_path / "status.json").read_text(), parse_constant=refuse)
    assert status["status"] == "ok" and metrics["ink_chamfer_mm"] is not None
    assert metrics["tracking_rms_mm"] < 0.5 and metrics["ink_chamfer_mm"] < 0.5


def test_the_0_2_tables_cell_and_plant_still_read_with_a_warning(tmp_path):
    import warnings

    path = tmp_path / "old.toml"
    path.write_text("[source]\nkind = 'tag'\n[cell]\ntimestep = 0.001\n"
                    "[plant]\npaper_height_mm = 2.0\n[plant.random]\nmass_scale = [0.9, 1.1]\n")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        old = load_scenario(path)
    assert sorted(str(w.message).split(": ", 1)[1] for w in caught) == [
        "the table [cell] is deprecated and goes in the next release; write [sim]",
        "the table [plant] is deprecated and goes in the next release; write [sim.plant]"]
    new = tmp_path / "new.toml"
    new.write_text("[source]\nkind = 'tag'\n[sim]\ntimestep = 0.001\n"
                   "[sim.plant]\npaper_height_mm = 2.0\n[sim.plant.random]\n"
                   "mass_scale = [0.9, 1.1]\n")
    assert load_scenario(new).cell == old.cell and load_scenario(new).plant == old.plant
    # the overrides' old spelling names the same keys, without a warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert old.with_overrides({"plant.seed": 3}).plant.seed == 3
        assert old.with_overrides({"cell.timestep": 0.002}).cell.timestep == 0.002
