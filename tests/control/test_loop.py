"""The sensory-motor loop end to end: a letter drawn on the simulated cell within the tracking,
force and gap bounds, at the corners of the sheet with the same gains; the plan checked on an
ideal position-servo plant; unreachable placements refused before moving; divergence reported
with the log so far."""

import numpy as np
import pytest

from inkarm.control.ik import ArmKinematics
from inkarm.control.loop import (
    PHASES,
    DrawLog,
    LoopConfig,
    check_reachable,
    minimum_jerk,
    run_drawing,
)
from inkarm.control.pid import PIDGains
from inkarm.core.frames import PagePlacement
from inkarm.core.plant import PlantState
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError, SimulationError, UnreachableError
from inkarm.sim.cell import build_model, default_gains
from inkarm.sim.plant import MujocoPlant

KIN_MODEL = build_model()
PAGE = PagePlacement.from_model(KIN_MODEL)


def letter(x0: float, y0: float, duration: float = 1.6, dt: float = 0.01) -> Drawing:
    """A figure-of-eight 60 mm tall and 30 mm wide with its lowest point at (x0, y0) [mm] and
    a short cross-bar: minimum-jerk timing, so each stroke starts and ends at rest."""
    t = np.arange(0.0, duration + 1e-9, dt)
    s = minimum_jerk(len(t))
    eight = np.column_stack(
        [x0 + 15 * np.sin(4 * np.pi * s), y0 + 30 * (1 - np.cos(2 * np.pi * s))]
    )
    tb = np.arange(0.0, 0.4 + 1e-9, dt)
    sb = minimum_jerk(len(tb))
    bar = np.column_stack([x0 - 15 + 30 * sb, np.full(len(tb), y0 + 30.0)])
    return Drawing([Trajectory(t, eight), Trajectory(tb, bar)])


def draw(drawing, gains=None, canvas=None):
    plant = MujocoPlant(build_model(), canvas=canvas)
    return run_drawing(drawing, plant, KIN_MODEL, gains or default_gains(), PAGE)


def longest_gap_mm(log: DrawLog, threshold: float = 0.05) -> float:
    """Longest reference arc [mm] drawn without contact inside one stroke."""
    longest, run = 0.0, 0.0
    for k in range(1, len(log)):
        if log.phase[k] == log.phase[k - 1] == 2 and log.stroke[k] == log.stroke[k - 1]:
            step = float(np.linalg.norm(log.reference[k, :2] - log.reference[k - 1, :2]))
            run = run + step if log.force[k] <= threshold else 0.0
            longest = max(longest, run)
        else:
            run = 0.0
    return longest


def assert_drawn_well(log: DrawLog) -> None:
    error = log.tracking_error()
    assert np.sqrt(np.mean(error**2)) <= 0.3
    assert error.max() <= 1.0
    force = log.force[log.drawing]
    assert force.std() <= 0.1
    assert abs(force.mean() - 1.0) < 0.05
    assert longest_gap_mm(log) <= 1.0
    lower, upper = KIN_MODEL.jnt_range[:7].T
    assert np.all(log.q >= lower) and np.all(log.q <= upper)


@pytest.fixture(scope="module")
def centre_run():
    from inkarm.ink.canvas import Canvas

    canvas = Canvas(PAGE.size_mm, px_per_mm=5.0)
    drawing = letter(105.0, 118.5)
    return drawing, draw(drawing, canvas=canvas), canvas


def test_a_letter_at_human_speed_is_drawn_within_the_bounds(centre_run):
    drawing, log, _ = centre_run
    assert drawing.strokes[0].speed().max() >= 100.0
    assert_drawn_well(log)


def test_the_log_saves_every_array(centre_run, tmp_path):
    _, log, _ = centre_run
    log.to_npz(tmp_path / "log.npz")
    with np.load(tmp_path / "log.npz") as saved:
        np.testing.assert_array_equal(saved["tip"], log.tip)
        assert list(saved["phases"]) == list(PHASES)


def test_the_run_goes_through_the_phases_in_order(centre_run):
    _, log, _ = centre_run
    changes = [int(log.phase[0])] + [
        int(p) for k, p in enumerate(log.phase[1:], 1) if p != log.phase[k - 1]
    ]
    names = [PHASES[p] for p in changes]
    assert names == [
        "approach",
        "descend",
        "draw",
        "lift",
        "travel",
        "descend",
        "draw",
        "lift",
        "home",
    ]
    assert set(log.stroke[log.drawing]) == {0, 1}
    assert np.all(np.diff(log.time) > 0)
    assert log.wall_s > 0 and log.realtime_factor > 0


def test_the_pen_presses_only_while_drawing_and_settles_before_a_stroke(centre_run):
    _, log, _ = centre_run
    off_paper = np.isin(
        log.phase, [PHASES.index("approach"), PHASES.index("travel"), PHASES.index("home")]
    )
    assert np.all(log.force[off_paper] == 0.0)
    first_draw = int(np.argmax(log.drawing))
    assert abs(log.force[first_draw] - 1.0) < 0.05


def test_ink_lies_on_the_reference(centre_run):
    _, log, canvas = centre_run
    ink = canvas.ink_points_mm()
    assert len(ink) > 100
    path = log.reference[log.drawing, :2]
    nearest = np.min(np.linalg.norm(ink[:, None, :] - path[None, :, :], axis=2), axis=1)
    assert nearest.max() < 1.0  # the marker's half width plus a pixel


@pytest.mark.parametrize("corner", [(25.0, 12.0), (185.0, 12.0), (25.0, 225.0), (185.0, 225.0)])
def test_the_same_gains_draw_at_the_corners_of_the_sheet(corner):
    drawing = Drawing([letter(*corner).strokes[0]])
    assert_drawn_well(draw(drawing))


class ServoPlant:
    """An ideal position servo: over one period q moves from the goal along the velocity
    feed-forward (kinematics only), so it is where the reference is at the next read."""

    dt = 0.004

    def __init__(self, q0):
        self.q, self.t, self.goals = np.array(q0, float), 0.0, []

    def read(self):
        return PlantState(time=self.t, q=self.q.copy(), qd=np.zeros(7))

    def command(self, torque=None, q_goal=None, qd_ff=None, pen_down=None):
        self.goals.append((q_goal.copy(), qd_ff.copy()))

    def step(self):
        q_goal, qd_ff = self.goals[-1]
        self.q = q_goal + qd_ff * self.dt
        self.t += self.dt

    def close(self):
        pass


def test_the_planned_joint_path_puts_the_pen_on_the_reference():
    drawing = letter(100.0, 100.0)
    plant = ServoPlant(KIN_MODEL.key("home").qpos[:7])
    log = run_drawing(
        drawing, plant, KIN_MODEL, default_gains(), PAGE, LoopConfig(command="position")
    )
    # Without a force sensor the tip is logged from forward kinematics, the force as NaN.
    assert np.all(np.isnan(log.force))
    assert log.tracking_error().max() < 0.1  # the servo's one-period Euler step
    kin = ArmKinematics(KIN_MODEL)
    goals = np.array([g for g, _ in plant.goals])[log.drawing]
    poses = [kin.fk(q) for q in goals]
    tips = PAGE.to_page(np.array([p for p, _ in poses]))
    plan_error = np.linalg.norm(tips[:, :2] - log.reference[log.drawing, :2], axis=1)
    assert plan_error.max() < 0.01  # cubic spline between IK knots
    axes = np.array([R[:, 2] for _, R in poses])
    assert np.min(axes @ PAGE.pen_axis) > 1 - 1e-8
    pressing = log.reference[log.drawing, 2]
    np.testing.assert_allclose(pressing, -1.0 / 0.3)  # F* / pen stiffness below the paper
    np.testing.assert_allclose(plant.goals[-1][0], KIN_MODEL.key("home").qpos[:7], atol=1e-9)


def test_ik_knots_are_close_enough_to_keep_a_cusp():
    """A 'v' whose two strokes brake to rest at the bottom point, at 300 mm/s peak."""
    t = np.arange(0.0, 0.4 + 1e-9, 0.01)
    s = minimum_jerk(len(t))[:, None]
    down = np.array([80.0, 160.0]) + s * np.array([20.0, -60.0])
    up = np.array([100.0, 100.0]) + s * np.array([20.0, 60.0])
    stroke = Trajectory(np.concatenate([t, t[1:] + 0.4]), np.vstack([down, up[1:]]))
    plant = ServoPlant(KIN_MODEL.key("home").qpos[:7])
    log = run_drawing(
        Drawing([stroke]), plant, KIN_MODEL, default_gains(), PAGE, LoopConfig(command="position")
    )
    kin = ArmKinematics(KIN_MODEL)
    goals = np.array([g for g, _ in plant.goals])[log.drawing]
    tips = PAGE.to_page(np.array([kin.fk(q)[0] for q in goals]))
    assert np.linalg.norm(tips[:, :2] - log.reference[log.drawing, :2], axis=1).max() < 0.02


def test_nib_drag_feedforward_removes_the_lag_along_the_path():
    def mean_lag(log):
        mask = log.drawing
        velocity = np.gradient(log.reference[:, :2], log.time, axis=0)[mask]
        fast = np.linalg.norm(velocity, axis=1) > 50.0
        u = velocity[fast] / np.linalg.norm(velocity[fast], axis=1, keepdims=True)
        return float(np.mean(np.sum((log.tip[mask, :2] - log.reference[mask, :2])[fast] * u, 1)))

    drawing = Drawing([letter(105.0, 118.5).strokes[0]])
    runs = {}
    for mu in (None, 0.0):
        plant = MujocoPlant(build_model())
        config = LoopConfig(nib_friction=mu)
        runs[mu] = mean_lag(run_drawing(drawing, plant, KIN_MODEL, default_gains(), PAGE, config))
    assert runs[0.0] < -0.03  # uncompensated, the nib drags behind the reference
    assert abs(runs[None]) < abs(runs[0.0]) / 3


def test_an_unreachable_placement_is_refused_before_moving():
    far = PagePlacement(PAGE.origin_m + [1.2, 0.0, 0.0], PAGE.rotation, PAGE.size_mm)
    plant = MujocoPlant(build_model())
    with pytest.raises(
        UnreachableError, match=r"^stroke 0, point \(105.0, 118.5\) mm: out of reach with the pen"
    ):
        run_drawing(letter(105.0, 118.5), plant, KIN_MODEL, default_gains(), far)
    assert plant.read().time == 0.0


def test_a_stroke_off_the_sheet_is_refused_naming_the_point():
    drawing = Drawing([Trajectory([0.0, 1.0], [[100.0, 100.0], [250.0, 100.0]])])
    with pytest.raises(
        UnreachableError, match=r"stroke 0, point \(250.0, 100.0\) mm: off the 210 x 297"
    ):
        check_reachable(drawing, PAGE, KIN_MODEL)


def test_divergence_is_reported_with_the_log_so_far():
    g = default_gains()
    absurd = PIDGains(
        kp=g.kp,
        ki=g.ki,
        kd=-5.0 * g.kd,
        torque_limit=g.torque_limit,
        integral_limit=g.integral_limit,
    )
    with pytest.raises(SimulationError, match="simulation diverged at t = ") as info:
        draw(letter(105.0, 118.5), gains=absurd)
    partial = info.value.log
    assert 0 < len(partial) < 500
    assert np.all(np.isfinite(partial.q))
    # the plan's columns are there too, up to the last row run
    assert np.all(partial.phase == PHASES.index("approach")) and np.all(partial.stroke == -1)
    assert np.all(np.linalg.norm(partial.reference, axis=1) > 100.0)  # on the sheet, not zeros


def test_progress_is_reported_up_to_completion():
    seen = []
    plant = ServoPlant(KIN_MODEL.key("home").qpos[:7])
    run_drawing(
        Drawing([letter(100.0, 100.0).strokes[1]]),
        plant,
        KIN_MODEL,
        default_gains(),
        PAGE,
        LoopConfig(command="position"),
        progress=lambda f, phase: seen.append((f, phase)),
    )
    fractions = [f for f, _ in seen]
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    assert {phase for _, phase in seen} <= set(PHASES)


def test_minimum_jerk_profile():
    s = minimum_jerk(101)
    assert s[0] == 0.0 and s[-1] == pytest.approx(1.0) and s[50] == pytest.approx(0.5)
    v = np.gradient(s, 0.01)
    assert v.max() == pytest.approx(1.875, rel=1e-3)  # Flash-Hogan peak speed 1.875 A / T


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"force_n": 0.0}, r"LoopConfig.force_n: expected > 0, got 0.0"),
        ({"command": "velocity"}, r"LoopConfig.command: expected 'torque' or 'position'"),
        ({"hover_mm": float("inf")}, r"LoopConfig.hover_mm: expected a finite number"),
        ({"settle_s": -0.1}, r"LoopConfig.settle_s: expected >= 0, got -0.1"),
        ({"nib_friction": -0.2}, r"LoopConfig.nib_friction: expected >= 0, got -0.2"),
    ],
)
def test_bad_loop_config_is_refused(kwargs, message):
    with pytest.raises(InputError, match=message):
        LoopConfig(**kwargs)


def test_a_force_beyond_the_pen_travel_is_refused():
    with pytest.raises(
        InputError, match=r"force_n: 5.0 N compresses the pen by 16.7 mm, more than"
    ):
        check_reachable(letter(105.0, 118.5), PAGE, KIN_MODEL, LoopConfig(force_n=5.0))


def test_gains_must_match_the_arm():
    g = PIDGains(kp=[1.0, 1.0], ki=0.0, kd=0.0, torque_limit=1.0, integral_limit=0.0)
    with pytest.raises(InputError, match="gains: 2 joints, but the kinematic model has 7"):
        draw(letter(105.0, 118.5), gains=g)
