"""The real sheet's relief (inkarm.sim.relief; its contact patch in inkarm.sim.perturb): the
field against its closed forms, a file against the same analytic wave, the patch against the
tangent plane, a pen resting on it and sliding over it against the flat sheet, and every refusal
with its message."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from inkarm.errors import InputError
from inkarm.sim.cell import (
    HOME_KEY,
    PAPER,
    PAPER_ORIGIN,
    PEN_TIP,
    build_model,
    make_cell,
    page_placement,
)
from inkarm.sim.imperfections import PlantTruth
from inkarm.sim.perturb import RELIEF, RELIEF_GROUP, plant_model, relief_follower
from inkarm.sim.relief import (
    grid_spacing,
    read_relief_file,
    relief_field,
    relief_grid,
    relief_height,
)

pytestmark = pytest.mark.sim

CELL = make_cell()
SIZE = CELL.paper_size_mm
N = len(CELL.robot.joint_names)
WAVE = PlantTruth(relief_wave_mm=1.0, relief_wavelength_mm=30.0, relief_wave_direction_deg=30.0,
                  relief_wave_phase_deg=20.0)


def test_the_wave_and_the_bump_are_their_closed_forms():
    x, y = np.array([0.0, 12.5, 100.0]), np.array([0.0, 40.0, 7.0])
    u = 2 * math.pi / 30.0 * (x * math.cos(math.radians(30)) + y * math.sin(math.radians(30)))
    assert relief_height(WAVE, x, y, SIZE) == pytest.approx(np.sin(u + math.radians(20)),
                                                            abs=1e-12)
    bump = PlantTruth(relief_bump_mm=-0.8, relief_bump_width_mm=8.0)
    cx, cy = SIZE[0] / 2, SIZE[1] / 2  # no centre given: the sheet's
    assert relief_height(bump, cx, cy, SIZE) == pytest.approx(-0.8)
    assert relief_height(bump, cx + 4.0, cy, SIZE) == pytest.approx(-0.4)  # full width at half
    assert relief_height(bump, cx, cy - 4.0, SIZE) == pytest.approx(-0.4)
    assert abs(relief_height(bump, cx + 30.0, cy, SIZE)) < 1e-16  # exp(-39)
    both = PlantTruth(relief_wave_mm=1.0, relief_bump_mm=0.5, relief_bump_x_mm=20.0,
                      relief_bump_y_mm=30.0)
    assert relief_height(both, 20.0, 30.0, SIZE) == pytest.approx(
        0.5 + math.sin(2 * math.pi * 20.0 / 30.0))


def test_the_grid_resolves_the_finest_feature_and_spans_the_sheet():
    assert grid_spacing(PlantTruth(relief_wave_mm=1.0)) == 1.0
    assert grid_spacing(PlantTruth(relief_wave_mm=1.0, relief_wavelength_mm=10.0)) == 0.5
    assert grid_spacing(PlantTruth(relief_bump_mm=1.0, relief_bump_width_mm=3.0)) == 0.5
    x, y, z = relief_grid(WAVE, SIZE)
    assert (x[0], x[-1], y[0], y[-1]) == (0.0, SIZE[0], 0.0, SIZE[1])
    assert np.diff(x).max() <= 1.0 + 1e-12 and np.diff(y).max() <= 1.0 + 1e-12
    assert z.shape == (y.size, x.size)
    assert z[3, 5] == pytest.approx(relief_height(WAVE, x[5], y[3], SIZE))
    with pytest.raises(InputError, match=r"relief_wavelength_mm: the relief needs a 4001 x "
                                         r"4001 grid .* more than 4000000 points"):
        relief_grid(PlantTruth(relief_wave_mm=1.0, relief_wavelength_mm=5.0), (1000.0, 1000.0))


def _write_csv(path, z: np.ndarray) -> str:
    path.write_text("\n".join(",".join(f"{v:.12g}" for v in row) for row in z) + "\n")
    return str(path)


def test_a_file_of_the_analytic_wave_gives_the_same_heights(tmp_path):
    cell = 1.0
    x = np.arange(0.0, SIZE[0] + cell, cell)
    y = np.arange(0.0, SIZE[1] + cell, cell)
    file = _write_csv(tmp_path / "wave.csv", relief_height(WAVE, x[None, :], y[:, None], SIZE))
    from_file = PlantTruth(relief_file=file, relief_cell_mm=cell)
    rng = np.random.default_rng(0)
    px, py = rng.uniform(0, SIZE[0], 200), rng.uniform(0, SIZE[1], 200)
    # bilinear between points 1 mm apart: within a k^2 h^2 / 4 of the wave
    bound = 1.0 * (2 * math.pi / 30.0) ** 2 * cell**2 / 4
    assert np.abs(relief_height(from_file, px, py, SIZE)
                  - relief_height(WAVE, px, py, SIZE)).max() < bound
    fields = [relief_field(t, SIZE) for t in (WAVE, from_file)]
    for x_mm, y_mm in zip(px[:20], py[:20], strict=True):
        a, b = (f.at(x_mm, y_mm) for f in fields)
        assert a[0] == pytest.approx(b[0], abs=bound)
        assert a[1:] == pytest.approx(b[1:], abs=0.01)  # slopes, of at most 0.21


def test_the_field_and_its_slopes_are_the_relief_between_grid_points():
    field = relief_field(WAVE, SIZE)
    k, u = 2 * math.pi / 30.0, np.array([math.cos(math.radians(30)), math.sin(math.radians(30))])
    for x, y in np.random.default_rng(1).uniform(5.0, 200.0, (50, 2)):
        z, zx, zy = field.at(x, y)
        phase = k * (x * u[0] + y * u[1]) + math.radians(20)
        assert z == pytest.approx(math.sin(phase), abs=k**2 / 8 + 1e-3)
        # central differences over 1 mm, bilinear between: within 1 % of the slope's amplitude
        assert (zx, zy) == pytest.approx(k * math.cos(phase) * u, abs=0.01 * k)
    assert field.at(-50.0, -50.0) == field.at(0.0, 0.0)  # held at the edges


def _surface_mm(model: mujoco.MjModel, px, py) -> np.ndarray:
    """The contact surface above the page plane [mm] at page points, by casting rays down onto
    the relief's patch alone."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, PAPER_ORIGIN)
    rot, origin = data.site_xmat[site].reshape(3, 3), data.site_xpos[site]
    group = np.zeros(6, np.uint8)
    group[RELIEF_GROUP] = 1
    hit = np.zeros(1, np.int32)
    out = []
    for x, y in zip(px, py, strict=True):
        start = origin + rot @ np.array([x / 1000.0, y / 1000.0, 0.05])
        out.append(1000.0 * (0.05 - mujoco.mj_ray(model, data, start, -rot[:, 2], group, 1, -1,
                                                 hit)))
    return np.array(out)


def test_the_patch_is_the_tangent_plane_under_the_tip():
    truth = PlantTruth(relief_bump_mm=1.5, relief_bump_width_mm=12.0, relief_bump_x_mm=40.0,
                       relief_bump_y_mm=220.0, relief_wave_mm=0.3)
    model = plant_model(CELL, truth)
    follower = relief_follower(model, CELL, truth)
    for x, y in [(40.0, 220.0), (43.0, 217.0), (170.0, 77.0), (10.3, 290.1)]:
        z, zx, zy = follower.place(x, y)
        assert z == pytest.approx(relief_height(truth, x, y, SIZE), abs=0.01)
        # on the plane: the height at the tip, and the slopes beside it
        px, py = np.array([x, x + 2.0, x]), np.array([y, y, y - 2.0])
        assert _surface_mm(model, px, py) == pytest.approx([z, z + 2 * zx, z - 2 * zy],
                                                          abs=1e-9)
    # the sheet is where it was: the page, its size and the box that carries the ink
    flat = build_model(CELL)
    a, b = page_placement(model), page_placement(flat)
    assert np.array_equal(a.origin_m, b.origin_m) and a.size_mm == b.size_mm
    box, patch = (mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in (PAPER, RELIEF))
    assert model.geom_contype[box] == 0 and model.geom_conaffinity[box] == 0
    for name in ("geom_contype", "geom_conaffinity", "geom_solref", "geom_solimp",
                 "geom_friction", "geom_margin", "geom_gap"):
        assert np.array_equal(getattr(model, name)[patch], getattr(flat, name)[box]), name
    assert relief_follower(flat, CELL, PlantTruth()) is None
    with pytest.raises(InputError, match=r"ReliefFollower: the model has no relief patch "
                                         r"'paper_relief'"):
        relief_follower(flat, CELL, truth)


def test_hard_paper_reaches_the_patch_too():
    model = plant_model(CELL, PlantTruth(relief_wave_mm=1.0, paper_timeconst_s=0.002))
    patch = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, RELIEF)
    assert model.geom_solref[patch, 0] == pytest.approx(0.004)  # twice the time step


def _hold(model: mujoco.MjModel, page_mm, press_mm: float, lower_mm: float = 0.0,
          follower=None, turn_rad_s: float = 0.0, steps: int = 400):
    """Hold the arm at home (turning its first joint at ``turn_rad_s`` after 300 steps: the tip
    slides on an arc) with the sheet slid so that page point ``page_mm`` lies under the tip,
    ``press_mm`` into it (less ``lower_mm``). Returns the tip in page [mm] at the end and the
    contact's normal force [N] at every step."""
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY,
                                                               HOME_KEY))
    mujoco.mj_forward(model, data)
    tip, origin = (mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, s)
                   for s in (PEN_TIP, PAPER_ORIGIN))
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, PAPER)
    rot = data.site_xmat[origin].reshape(3, 3)
    shift = data.site_xpos[tip] - data.site_xpos[origin] - rot @ np.array([*page_mm, 0.0]) / 1e3
    shift += rot[:, 2] * (press_mm - lower_mm) / 1000.0
    model.body_pos[body] += shift
    mujoco.mj_kinematics(model, data)
    q = data.qpos[:N].copy()
    force, contact = [], np.zeros(6)
    for k in range(steps):
        speed = turn_rad_s if k >= 300 else 0.0
        q[0] += speed * model.opt.timestep
        data.qpos[:N], data.qvel[:N] = q, 0.0
        data.qvel[0] = speed
        if follower is not None:
            follower.follow(data)
        mujoco.mj_step(model, data)
        total = 0.0
        for i in range(data.ncon):
            mujoco.mj_contactForce(model, data, i, contact)
            total += contact[0]
        force.append(total)
    model.body_pos[body] -= shift
    rot = data.site_xmat[origin].reshape(3, 3)
    return 1000.0 * rot.T @ (data.site_xpos[tip] - data.site_xpos[origin]), np.array(force)


@pytest.mark.parametrize("page_mm", [(100.0, 100.0), (37.5, 61.2), (120.0, 150.0),
                                     (123.4, 147.2), (180.0, 260.0)])
def test_a_pen_resting_on_the_relief_sits_at_the_fields_height(page_mm):
    truth = PlantTruth(relief_wave_mm=1.0, relief_wave_direction_deg=30.0, relief_bump_mm=0.8,
                       relief_bump_x_mm=120.0, relief_bump_y_mm=150.0)
    h = float(relief_height(truth, *page_mm, SIZE))
    model = plant_model(CELL, truth)
    # the holder h above where it is over the flat sheet: the same force, the tip h higher
    tip, force = _hold(model, page_mm, 2.5, h, relief_follower(model, CELL, truth))
    flat_tip, flat_force = _hold(build_model(CELL), page_mm, 2.5)
    assert 0.9 < flat_force[-1] < 1.1  # about 1 N
    # a slope of up to 0.2 tilts the contact normal: +-3.3 % at these points
    assert force[-1] == pytest.approx(flat_force[-1], rel=0.05)
    assert tip[2] - flat_tip[2] == pytest.approx(h, abs=0.02)  # the underlay sinks 0.5 mm
    assert tip[:2] == pytest.approx(flat_tip[:2], abs=0.02)  # the ink lands where it did


def test_a_pen_sliding_on_a_faint_relief_feels_the_flat_sheet():
    """The contact itself adds nothing: on relief of 0.01 mm the force while sliding at 25 mm/s
    is the flat sheet's (a MuJoCo height field gave 0.98..1.22 N here, the flat sheet 1.02)."""
    faint = PlantTruth(relief_wave_mm=0.01)
    model = plant_model(CELL, faint)
    _, force = _hold(model, (105.0, 148.5), 2.5, 0.0, relief_follower(model, CELL, faint),
                     turn_rad_s=0.05, steps=1200)
    _, flat = _hold(build_model(CELL), (105.0, 148.5), 2.5, turn_rad_s=0.05, steps=1200)
    assert np.abs(force[400:] - flat[400:]).max() < 0.01
    assert flat[400:].std() < 1e-3 and abs(flat[-1] - 1.0) < 0.1


@pytest.mark.parametrize(("content", "message"), [
    ("", r"no heights \(expected CSV rows of heights in mm\)"),
    ("0,0,0\n0,0\n", r"line 2 has 2 heights, expected 3 as in the first row"),
    ("0,0,0\n0,x,0\n", r"line 2, column 2: expected a height in mm, got 'x'"),
    ("0,0\n0,25\n", r"row 2, column 2: expected a height in \[-20, 20\] mm, got 25.0"),
    ("0,0,0\n0,0,0\n", (r"2 rows x 3 columns 1 mm apart cover 2 x 1 mm; expected the whole "
                       r"sheet, 210 x 297 mm: at least 298 rows x 211 columns")),
])
def test_bad_relief_files_are_refused_saying_what_is_expected(tmp_path, content, message):
    path = tmp_path / "relief.csv"
    path.write_text(content)
    with pytest.raises(InputError, match=r"relief_file: .*" + message):
        read_relief_file(path, 1.0, SIZE)
    with pytest.raises(InputError, match=message):
        plant_model(CELL, PlantTruth(relief_file=str(path)))


def test_a_missing_relief_file_is_named(tmp_path):
    missing = tmp_path / "nowhere.csv"
    with pytest.raises(InputError, match=r"relief_file: no such file: .*nowhere.csv \(a CSV of "
                                         r"heights in mm\)"):
        plant_model(CELL, PlantTruth(relief_file=str(missing)))


def test_comments_and_blank_lines_are_skipped(tmp_path):
    path = tmp_path / "relief.csv"
    path.write_text("# heights in mm\n\n0,1\n2,3\n")
    file_map = read_relief_file(path, 10.0, (10.0, 10.0))
    assert file_map.height(5.0, 5.0) == pytest.approx(1.5)
    assert file_map.height(10.0, 0.0) == pytest.approx(1.0)


def test_the_patch_still_turns_after_mj_set_const():
    """A plant with a transmission calls mj_setConst, which would fix the patch's rotation to
    its body's: the follower made afterwards frees it again."""
    truth = PlantTruth(relief_wave_mm=1.0)
    model = plant_model(CELL, truth)
    mujoco.mj_setConst(model, mujoco.MjData(model))
    follower = relief_follower(model, CELL, truth)
    z, zx, _ = follower.place(15.0, 100.0)  # where the wave is steepest: slope -0.21
    assert _surface_mm(model, [15.0, 17.0], [100.0, 100.0]) == pytest.approx([z, z + 2 * zx],
                                                                           abs=1e-9)
    assert abs(zx) > 0.2


def test_a_drawn_relief_is_the_one_the_follower_follows():
    truth = PlantTruth(relief_bump_mm=1.0, random={"relief_bump_x_mm": (40.0, 60.0)}, seed=3)
    drawn = truth.realised()
    assert 40.0 <= drawn.relief_bump_x_mm <= 60.0
    follower = relief_follower(plant_model(CELL, truth), CELL, truth)
    for x in (drawn.relief_bump_x_mm, drawn.relief_bump_x_mm + 3.0, 105.0):
        # (bilinear on a 1 mm grid flattens the bump's top by up to 2 %)
        assert follower.place(x, SIZE[1] / 2)[0] == pytest.approx(
            relief_height(drawn, x, SIZE[1] / 2, SIZE), abs=0.03)


def test_a_relief_file_that_is_not_text_is_refused_naming_it(tmp_path):
    from inkarm.errors import InputError
    from inkarm.sim.relief import read_relief_file

    path = tmp_path / "scan.csv"
    path.write_bytes(b"0,0\n\xff\xfe,1\n")
    with pytest.raises(InputError, match=r"scan.csv: not a text file \(byte 4 is not UTF-8\)"):
        read_relief_file(path, 1.0, (10.0, 10.0))
