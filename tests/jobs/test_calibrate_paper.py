"""``calibrate paper`` as a library call, and a scenario's ``calibration``: the probe finds a
planted sheet (raised and tilted: a plane the fit must give back), the file merges, a run says
which calibration it believed and the controller's model carries the map found."""

from __future__ import annotations

import math

import numpy as np
import pytest

from inkarm.errors import InputError, ScenarioError
from inkarm.jobs.calibration import (
    believed_model,
    believing,
    drawing_scenario,
    probe_paper,
    scenario_calibration,
    update_calibration,
    with_calibration,
)
from inkarm.jobs.scenario import load_scenario, parse_scenario
from inkarm.robots.calibration import (
    CellCalibration,
    HeightMap,
    calibration_path,
    read_calibration,
    write_calibration,
)
from inkarm.robots.geometry import GeometryErrors
from inkarm.sim.cell_config import Cell

HEIGHT_MM, TILT_DEG = 1.5, 0.5


@pytest.fixture(autouse=True)
def config_dir(monkeypatch, tmp_path):
    """Every test's own configuration folder (nothing is written under ~/.config)."""
    monkeypatch.setenv("INKARM_CONFIG_DIR", str(tmp_path / "config"))
    return tmp_path / "config"


@pytest.fixture(scope="module")
def probe():
    """The default letter's sheet, 1.5 mm higher than believed and tilted 0.5 deg, probed every
    10 mm of its path on the simulated arm."""
    scenario = load_scenario().with_overrides({"sim.plant.paper_height_mm": HEIGHT_MM,
                                               "sim.plant.paper_tilt_deg": TILT_DEG,
                                               "sim.plant.paper_tilt_axis_deg": 30.0})
    return scenario, probe_paper(scenario, spacing_mm=10.0)


def test_the_probe_finds_the_planted_plane(probe):
    _, found = probe
    assert found.run.finished and found.missed == () and found.dots == len(found.points_mm) > 15
    p = found.points_mm
    design = np.column_stack([np.ones(len(p)), p[:, 0], p[:, 1]])
    coef, *_ = np.linalg.lstsq(design, p[:, 2], rcond=None)
    flatness = p[:, 2] - design @ coef
    assert np.abs(flatness).max() < 0.02  # a plane, to 20 um
    slope = math.hypot(coef[1], coef[2])
    assert slope == pytest.approx(math.tan(math.radians(TILT_DEG)), rel=0.03)
    # the tilt's axis at 30 deg from page x: the slope points across it
    assert math.degrees(math.atan2(coef[2], coef[1])) % 180 == pytest.approx(120.0, abs=2.0)
    # the map gives back the touches, and the plane between them
    assert found.residual_rms_mm < 0.005
    centre = p[:, :2].mean(axis=0)
    assert found.map.height(*centre) == pytest.approx(coef @ [1.0, *centre], abs=0.01)
    assert f"{len(p)} of {found.dots} touches" in found.summary()


def test_calibrate_then_draw_believes_the_map(probe, config_dir):
    from inkarm.jobs.run import run

    scenario, found = probe
    cal, path = update_calibration(scenario.robot.name, paper=found.map, note="paper: test")
    assert path == calibration_path(scenario.robot.name) and path.parent.parent == config_dir
    assert read_calibration(path).notes == ("paper: test",)
    auto = with_calibration(scenario, "auto")
    believed, notes = believed_model(auto, Cell(auto.cell, auto.robot))
    assert believed.paper_map is not None
    np.testing.assert_array_equal(believed.paper_map.z_mm, found.map.z_mm)
    assert notes == (f"calibration: {path}: {cal.describe()}",)
    result = run(auto)
    assert result.finished and result.notes[0] == notes[0]


def test_a_scenario_names_its_calibration_beside_itself(tmp_path, config_dir):
    robot = load_scenario().robot.name
    write_calibration(CellCalibration(robot, geometry=GeometryErrors(
        tip_offset_mm=(0.0, 0.0, 1.0))), tmp_path / "cal.toml")
    data = {"source": {"kind": "text", "text": "a"}, "calibration": "cal.toml"}
    scenario = parse_scenario(data, source="s.toml", base_dir=tmp_path)
    assert scenario.calibration == str((tmp_path / "cal.toml").resolve())
    assert scenario.to_dict()["calibration"] == scenario.calibration
    again = scenario.with_overrides({"seed": 3})
    assert again.calibration == scenario.calibration
    cal, note = scenario_calibration(scenario)
    assert cal.geometry.tip_offset_mm == (0.0, 0.0, 1.0)
    assert note == f"calibration: {scenario.calibration}: pen tip (+0.00, +0.00, +1.00) mm"
    # none by default: nothing said, nothing in its tables (runs stay as they were)
    plain = parse_scenario({"source": {"kind": "text", "text": "a"}}, base_dir=tmp_path)
    assert plain.calibration is None and "calibration" not in plain.to_dict()
    assert scenario_calibration(plain) == (None, None)
    # "auto" without a file: the nominal cell, and the run says where it looked
    auto = parse_scenario({**data, "calibration": "auto"}, base_dir=tmp_path)
    where = config_dir / "calibration" / f"{robot}.toml"
    assert scenario_calibration(auto) == (
        None, f"calibration: none (auto: no file {where}); the nominal cell")


@pytest.mark.parametrize("value, match", [
    ("missing.toml", (r"s.toml: calibration: no such calibration file: .*missing.toml "
                      r"\(expected a file written by `inkarm calibrate`, or \"auto\"\)")),
    (3, r"s.toml: calibration: expected a string, got 3"),
    ("bad.toml", (r"s.toml: calibration: .*bad.toml: robot: missing.* \(the calibration file "
                  r"it names\)")),
])
def test_a_bad_calibration_key_names_the_scenario_and_key(tmp_path, value, match):
    (tmp_path / "bad.toml").write_text("notes = []\n")
    with pytest.raises(ScenarioError, match=match):
        parse_scenario({"source": {"kind": "text", "text": "a"}, "calibration": value},
                       source="s.toml", base_dir=tmp_path)


def test_a_calibration_of_another_robot_is_refused(tmp_path):
    write_calibration(CellCalibration("wx250s"), tmp_path / "other.toml")
    scenario = with_calibration(load_scenario(), tmp_path / "other.toml")
    with pytest.raises(InputError, match=r"calibration: the calibration \(.*other.toml\) was "
                                         r"measured on robot 'wx250s', the scenario's robot is "
                                         r"'iiwa14'"):
        scenario_calibration(scenario)
    with pytest.raises(InputError, match=r"--out: .*other.toml is the calibration of robot "
                                         r"'wx250s', not 'iiwa14'"):
        believing(load_scenario(), tmp_path / "other.toml", "paper")
    with pytest.raises(InputError, match=r"--out: .* not 'iiwa14' \(give another --out\)"):
        update_calibration("iiwa14", tmp_path / "other.toml", paper=None)
    with pytest.raises(InputError, match=r"calibration: expected a CellCalibration, a file, "
                                         r"'auto' or None, got int"):
        with_calibration(load_scenario(), 3)


def test_an_in_memory_calibration_survives_overrides():
    cal = CellCalibration("iiwa14", paper=HeightMap([0.0, 1.0], [0.0, 1.0], np.ones((2, 2))))
    scenario = with_calibration(load_scenario(), cal).with_overrides({"seed": 2})
    assert scenario.calibration is cal and "calibration" not in scenario.to_dict()
    assert scenario_calibration(scenario)[1] == f"calibration: in memory: {cal.describe()}"
    assert scenario.with_overrides({"calibration": "auto"}).calibration == "auto"


def test_update_replaces_one_part_and_keeps_the_rest(tmp_path):
    path = tmp_path / "c.toml"
    geometry = GeometryErrors(tip_offset_mm=(0.1, 0.2, 0.3))
    update_calibration("iiwa14", path, geometry=geometry, note="pen: first")
    flat = HeightMap([0.0, 1.0], [0.0, 1.0], np.zeros((2, 2)))
    cal, _ = update_calibration("iiwa14", path, paper=flat, note="paper: second")
    back = read_calibration(path)
    assert back.geometry == geometry and back.paper is not None
    assert back.notes == ("pen: first", "paper: second") == cal.notes


def test_a_probe_believes_the_target_file_without_the_part_it_measures(tmp_path):
    path = tmp_path / "c.toml"
    full = CellCalibration(
        "iiwa14", paper=HeightMap([0.0, 1.0], [0.0, 1.0], np.ones((2, 2))),
        geometry=GeometryErrors(link_length_mm=(0.0, 0.5), joint_offset_deg=(0.1, 0.2),
                                tip_offset_mm=(0.0, 0.0, 2.0)))
    write_calibration(full, path)
    scenario = load_scenario()
    paper = believing(scenario, path, "paper").calibration
    assert paper.paper is None and paper.geometry == full.geometry
    pen = believing(scenario, path, "pen").calibration
    assert pen.geometry.tip_offset_mm == (0.0, 0.0, 0.0) and pen.paper is not None
    assert pen.geometry.link_length_mm == (0.0, 0.5)
    arm = believing(scenario, path, "kinematics").calibration
    assert arm.geometry.link_length_mm == () == arm.geometry.joint_offset_deg
    assert arm.geometry.tip_offset_mm == (0.0, 0.0, 2.0)
    assert believing(scenario, tmp_path / "none.toml", "paper").calibration is None
    with pytest.raises(InputError, match=r"part: unknown part 'arm'; expected one of paper, "
                                         r"pen, kinematics"):
        believing(scenario, path, "arm")


def test_a_backend_without_a_force_sensor_is_refused_before_it_moves():
    with pytest.raises(InputError, match=r"--backend: the dynamixel backend senses no pen force"):
        probe_paper(load_scenario(), backend="dynamixel")


def test_a_grid_probe_covers_the_drawings_box_and_finds_a_raised_sheet():
    quick = load_scenario("scenarios/quick_stroke.toml").with_overrides(
        {"sim.plant.paper_height_mm": 0.8})
    found = probe_paper(quick, spacing_mm=10.0, pattern="grid")
    assert found.dots == len(found.points_mm) >= 4 and found.missed == ()
    np.testing.assert_allclose(found.points_mm[:, 2], 0.8, atol=0.01)
    assert np.ptp(found.points_mm[:, 1]) > 5.0  # rows across the stroke, not along it only
    with pytest.raises(InputError, match=r"pattern: expected one of path, grid, got 'grd' "
                                         r"\(did you mean 'grid'\?\)"):
        probe_paper(quick, pattern="grd")
    with pytest.raises(InputError, match=r"dwell_s: expected a dwell > 0 s, got 0"):
        probe_paper(quick, dwell_s=0.0)


def test_a_probe_that_cannot_find_the_paper_says_so():
    low = load_scenario("scenarios/quick_stroke.toml").with_overrides(
        {"sim.plant.paper_height_mm": -40.0})
    with pytest.raises(InputError, match=r"calibrate paper: the probe run failed: "
                                         r"paper_not_found"):
        probe_paper(low)


def test_a_drawing_scenario_draws_exactly_its_page_drawing():
    from inkarm.core.trajectory import Drawing, Trajectory
    from inkarm.jobs.preflight import placed_within_budget

    scenario = load_scenario()
    points = np.array([[80.0, 120.0], [130.5, 171.25], [101.0, 150.0]])
    dots = Drawing([Trajectory(t=np.array([0.0, 0.1]), pos=np.array([p, p])) for p in points],
                   page_size=(210.0, 297.0), meta={"mine": [1, 2, 3]})
    probe = drawing_scenario(scenario, dots, title="dots")
    placed = placed_within_budget(probe, Cell(probe.cell, probe.robot))
    np.testing.assert_allclose(np.array([s.pos[0] for s in placed.strokes]), points, atol=1e-12)
    assert placed.meta == {"mine": [1, 2, 3]} and probe.title == "dots"


def test_every_member_of_an_ensemble_says_which_calibration_it_believed():
    from inkarm.jobs.ensemble import run_ensemble

    cal = CellCalibration("iiwa14", paper=HeightMap([0.0, 210.0], [0.0, 297.0],
                                                    np.full((2, 2), 0.1)))
    scenario = with_calibration(load_scenario("scenarios/quick_stroke.toml"), cal)
    runs = run_ensemble(scenario, [1, 2], processes=1)
    assert [r.notes[0] for r in runs] == [f"calibration: in memory: {cal.describe()}"] * 2
    assert all(r.finished for r in runs)


def test_the_emulators_twin_is_the_nominal_arm_or_the_real_one():
    import mujoco

    from inkarm.jobs.backends.dynamixel import twin_emulator

    scenario = load_scenario("scenarios/wx250s_letter_N.toml").with_overrides(
        {"sim.plant.paper_height_mm": 2.0})
    heights = []
    for truth in (False, True):
        model = twin_emulator(scenario, truth=truth).twin.model
        paper = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "paper")
        heights.append(model.body_pos[paper][2])
    assert heights[1] - heights[0] == pytest.approx(0.002)


# --- the probe for an arm without a force sensor: ramped dashes read from their ink ----------

def test_ramped_dashes_cover_the_box_and_the_believed_map_aims_each_dash_down():
    from inkarm.control.calibration.paper import RampDashes

    dashes = RampDashes.over((130.0, 80.0), (165.0, 125.0), spacing_mm=10.0, length_mm=12.0,
                             range_mm=(-0.5, 5.0), speed_mm_s=6.0)
    starts = dashes.starts_mm
    assert len(starts) == 3 * 5  # columns of 12 mm + 4 mm gaps over 35 mm, rows every 10 mm
    rows = starts.reshape(5, 3, 2)
    np.testing.assert_allclose(np.diff(rows[:, :, 0], axis=1), 16.0)
    np.testing.assert_allclose(np.diff(rows[:, 0, 1]), 10.0)
    # each row a third of the pitch on from the last, in turn -1, 0, +1 thirds
    np.testing.assert_allclose(rows[:, 0, 0] - rows[1, 0, 0], np.array([-1, 0, 1, -1, 0]) * 16 / 3)
    # centred on the box (the unshifted rows)
    np.testing.assert_allclose((rows[1, 0, 0] + rows[1, -1, 0] + 12.0) / 2, 147.5)
    np.testing.assert_allclose((starts[:, 1].min() + starts[:, 1].max()) / 2, 102.5)
    depth = 2.83
    aim = dashes.aim_map(depth)
    for s in (0.0, 0.25, 0.5, 1.0):  # linear along every dash, under bilinear interpolation,
        for dy in (-2.9, 0.0, 2.9):  # and the same across it, the pen's offsets included
            h = aim.height(starts[:, 0] + 12.0 * s, starts[:, 1] + dy)
            np.testing.assert_allclose(h, 5.0 + depth - 5.5 * s, atol=1e-12)
    drawing = dashes.drawing((297.0, 210.0))
    assert len(drawing.strokes) == len(starts)
    np.testing.assert_allclose(drawing.strokes[4].pos, [starts[4], starts[4] + (12.0, 0.0)])
    assert drawing.strokes[4].t[-1] == pytest.approx(2.0)  # 12 mm at 6 mm/s


@pytest.mark.parametrize("kwargs, match", [
    ({"range_mm": (2.0, 1.0)},
     r"range_mm: expected \(low, high\) with high > low \[mm\], got \(2.0, 1.0\)"),
    ({"length_mm": 0.0}, r"length_mm: expected > 0, got 0.0"),
    ({"speed_mm_s": float("nan")}, r"speed_mm_s: expected > 0, got nan"),
])
def test_ramped_dashes_refuse_a_bad_setting(kwargs, match):
    from inkarm.control.calibration.paper import RampDashes

    with pytest.raises(InputError, match=match):
        RampDashes.over((0.0, 0.0), (10.0, 10.0), **kwargs)


def test_the_inks_threshold_is_found_from_its_marks():
    from inkarm.ink.inks import make_ink
    from inkarm.jobs.calibration import ink_threshold_n

    assert ink_threshold_n(make_ink("marker")) == pytest.approx(0.08, abs=1e-3)
    assert ink_threshold_n(make_ink("marker", threshold_n=0.5)) == pytest.approx(0.5, abs=1e-3)
    assert ink_threshold_n(make_ink("marker", threshold_n=0.0)) == 0.0
    with pytest.raises(InputError, match=r"ink: the ink lays nothing at 10 N"):
        ink_threshold_n(make_ink("marker", threshold_n=20.0))


def test_the_models_own_touch_says_where_the_ink_starts():
    from inkarm.control.calibration.paper import onset_depth_mm

    scenario = load_scenario("scenarios/wx250s_letter_N.toml")
    believed, _ = believed_model(scenario, Cell(scenario.cell, scenario.robot))
    light = onset_depth_mm(believed, believed.home_q, 0.08)
    firm = onset_depth_mm(believed, believed.home_q, 0.25)
    # the soft contact reaches above the sheet's top; pressing harder takes the tip lower
    assert 0.3 < light < 0.9 and firm < light
    with pytest.raises(InputError, match=r"believed: the model's own tip does not reach 5.0 N"):
        onset_depth_mm(believed, believed.home_q, 5.0)


def test_ramped_dashes_find_a_raised_sheet_and_a_longer_pen_without_the_force():
    """The servo arm's sheet 1.5 mm higher and its pen 2 mm longer than believed: the sheet is
    3.5 mm higher for the believed tip. The dashes read it from their ink and the joint readings
    (the simulated arm's force sensor is not used: the force loop is off), within the servos'
    resolution (their goals move in encoder ticks: 0.3 mm steps of the pen's height here)."""
    from inkarm.jobs.calibration import draw_dashes, read_dashes

    scenario = load_scenario("scenarios/wx250s_letter_N.toml").with_overrides(
        {"sim.plant.paper_height_mm": 1.5, "sim.plant.pen_length_error_mm": 2.0})
    drawn = draw_dashes(scenario)
    found = read_dashes(drawn)
    assert found.run.finished and found.missed == () and found.dots == len(found.points_mm) == 18
    assert np.isfinite(found.run.log.force).any()  # (sensed, and not used)
    h = found.points_mm[:, 2]
    assert abs(h.mean() - 3.5) < 0.25 and np.abs(h - 3.5).max() < 0.4
    assert found.map.range_mm[0] > 2.8 and found.map.range_mm[1] < 3.8
    # the same sheet scanned: its image, the corners at the raster's own (u right, v down)
    image = drawn.canvas.image
    rows, cols = image.shape
    corners = [[0.0, rows], [cols, rows], [cols, 0.0], [0.0, 0.0]]
    scanned = read_dashes(drawn, image=image, corners_px=corners)
    # (a scan's ink is what stands out of its paper by a quarter: where a dash begins, a pixel
    # or two more of faint ink, 0.05 mm of height each on the ramp)
    np.testing.assert_allclose(scanned.points_mm[:, 2], h, atol=0.12)
    np.testing.assert_allclose(scanned.points_mm[:, :2], found.points_mm[:, :2], atol=0.25)
    with pytest.raises(InputError, match=r"corners_px: an image of the sheet needs its four"):
        read_dashes(drawn, image=image)


def test_ramped_dashes_below_their_range_say_so():
    from inkarm.jobs.calibration import probe_paper_marks

    low = load_scenario("scenarios/wx250s_letter_N.toml").with_overrides(
        {"sim.plant.paper_height_mm": -3.0})
    with pytest.raises(InputError, match=r"calibrate paper: 0 of 18 dashes met the sheet within "
                                         r"\(-0.5, 5.0\) mm \(widen range_mm\)"):
        probe_paper_marks(low)


def test_a_scanned_sheets_ink_lands_on_the_page_through_its_corners():
    from inkarm.control.calibration.paper import image_ink_mm

    image = np.zeros((50, 80))
    image[10, 20] = image[40, 70] = 0.9  # (row 10 is near the top: page y high)
    corners = [[0.0, 50.0], [80.0, 50.0], [80.0, 0.0], [0.0, 0.0]]
    ink = image_ink_mm(image, corners, (160.0, 100.0))  # 2 mm a pixel
    np.testing.assert_allclose(ink[np.argsort(ink[:, 0])], [[41.0, 79.0], [141.0, 19.0]])
    assert image_ink_mm(np.zeros((5, 5)), corners, (160.0, 100.0)).shape == (0, 2)
    with pytest.raises(InputError, match=r"image: expected a finite 2-D darkness raster, got "
                                         r"shape \(5,\)"):
        image_ink_mm(np.zeros(5), corners, (160.0, 100.0))
