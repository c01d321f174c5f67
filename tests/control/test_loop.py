"""The sensory-motor loop end to end: a letter drawn on the simulated cell within the tracking,
force and gap bounds, at the corners of the sheet with the same gains; the plan checked on an
ideal position-servo plant; unreachable placements refused before moving; divergence reported
with the log so far."""

import dataclasses

import numpy as np
import pytest

from inkarm.control.config import LoopConfig
from inkarm.control.executor import run_drawing
from inkarm.control.kinematics import ArmKinematics
from inkarm.control.laws import LawSpec
from inkarm.control.pid import PIDGains
from inkarm.control.reference import check_reachable
from inkarm.control.sequencing import minimum_jerk
from inkarm.core.frames import PagePlacement
from inkarm.core.log import PHASES, DrawLog
from inkarm.core.plant import Plant, PlantState, PositionCommand
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError, RunFault, UnreachableError
from inkarm.robots.registry import load_robot
from inkarm.sim.cell import build_model, kinematic_model, make_cell
from inkarm.sim.plant import MujocoPlant

ROBOT = load_robot("iiwa14")
JOINT_PID = LawSpec("joint_pid")  # the host's joint PID, sending torques


@pytest.fixture(scope="module")
def km():
    """The controller's kinematic model of the default (iiwa14) cell."""
    return kinematic_model(make_cell(robot=ROBOT))


def default_gains() -> PIDGains:
    return ROBOT.gains


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


def draw(km, drawing, gains=None, canvas=None, config=None, law=None):
    """Run ``drawing`` on a fresh simulated cell with the controller's model ``km``."""
    plant = MujocoPlant(build_model(make_cell(robot=ROBOT)), canvas=canvas)
    return run_drawing(drawing, plant, km, gains or default_gains(), config, law=law)


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


def assert_drawn_well(log: DrawLog, km) -> None:
    error = log.tracking_error()
    assert np.sqrt(np.mean(error**2)) <= 0.3
    assert error.max() <= 1.0
    force = log.force[log.drawing]
    assert force.std() <= 0.1
    assert abs(force.mean() - 1.0) < 0.05
    assert longest_gap_mm(log) <= 1.0
    kin = ArmKinematics.of(km)
    lower, upper = kin.lower, kin.upper
    assert np.all(log.q >= lower) and np.all(log.q <= upper)


@pytest.fixture(scope="module")
def centre_run(km):
    from inkarm.ink.canvas import Canvas

    canvas = Canvas(km.placement.size_mm, px_per_mm=5.0)
    drawing = letter(105.0, 118.5)
    return drawing, draw(km, drawing, canvas=canvas), canvas


@pytest.mark.sim
def test_a_letter_at_human_speed_is_drawn_within_the_bounds(centre_run, km):
    drawing, log, _ = centre_run
    assert drawing.strokes[0].speed().max() >= 100.0
    assert_drawn_well(log, km)
    assert log.notes == ()  # within the iiwa's speed limits: nothing was slowed


@pytest.mark.sim
def test_the_log_saves_every_array(centre_run, tmp_path):
    _, log, _ = centre_run
    log.to_npz(tmp_path / "log.npz")
    with np.load(tmp_path / "log.npz") as saved:
        np.testing.assert_array_equal(saved["tip"], log.tip)
        assert list(saved["phases"]) == list(PHASES)


@pytest.mark.sim
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


@pytest.mark.sim
def test_the_pen_presses_only_while_drawing_and_settles_before_a_stroke(centre_run):
    _, log, _ = centre_run
    off_paper = np.isin(
        log.phase, [PHASES.index("approach"), PHASES.index("travel"), PHASES.index("home")]
    )
    assert np.all(log.force[off_paper] == 0.0)
    first_draw = int(np.argmax(log.drawing))
    assert abs(log.force[first_draw] - 1.0) < 0.05


@pytest.mark.sim
def test_ink_lies_on_the_reference(centre_run):
    _, log, canvas = centre_run
    ink = canvas.ink_points_mm()
    assert len(ink) > 100
    path = log.reference[log.drawing, :2]
    nearest = np.min(np.linalg.norm(ink[:, None, :] - path[None, :, :], axis=2), axis=1)
    assert nearest.max() < 1.0  # the marker's half width plus a pixel


@pytest.mark.sim
@pytest.mark.parametrize("corner", [(25.0, 12.0), (185.0, 12.0), (25.0, 225.0), (185.0, 225.0)])
def test_the_same_gains_draw_at_the_corners_of_the_sheet(km, corner):
    drawing = Drawing([letter(*corner).strokes[0]])
    assert_drawn_well(draw(km, drawing), km)


class ServoPlant:
    """An ideal position servo: over one period q moves from the goal along the velocity
    feed-forward (kinematics only), so it is where the reference is at the next read. It senses
    nothing beyond q and qd (qd: the last velocity feed-forward)."""

    dt = 0.004
    senses = frozenset()
    commands = frozenset({"position"})

    def __init__(self, q0):
        self.q, self.t, self.goals = np.array(q0, float), 0.0, []
        self.qd = np.zeros(len(self.q))

    def read(self):
        return PlantState(time=self.t, q=self.q.copy(), qd=self.qd.copy())

    def command(self, command):
        assert isinstance(command, PositionCommand)
        self.goals.append((command.q.copy(), command.qd.copy()))

    def step(self):
        q_goal, qd_ff = self.goals[-1]
        self.q = q_goal + qd_ff * self.dt
        self.qd = qd_ff.copy()
        self.t += self.dt

    def close(self):
        pass


def test_the_servo_plant_is_a_plant():
    assert isinstance(ServoPlant(np.zeros(7)), Plant)


@pytest.mark.sim
def test_the_planned_joint_path_puts_the_pen_on_the_reference(km):
    drawing = letter(100.0, 100.0)
    plant = ServoPlant(km.home_q)
    log = run_drawing(drawing, plant, km, default_gains(), LoopConfig())
    # Without a force sensor the tip is logged from forward kinematics, the force as NaN.
    assert np.all(np.isnan(log.force))
    assert log.tracking_error().max() < 0.1  # the servo's one-period Euler step
    kin = ArmKinematics.of(km)
    goals = np.array([g for g, _ in plant.goals])[log.drawing]
    poses = [kin.fk(q) for q in goals]
    tips = km.placement.to_page(np.array([p for p, _ in poses]))
    plan_error = np.linalg.norm(tips[:, :2] - log.reference[log.drawing, :2], axis=1)
    assert plan_error.max() < 0.01  # cubic spline between IK knots
    axes = np.array([R[:, 2] for _, R in poses])
    assert np.min(axes @ km.placement.pen_axis) > 1 - 1e-8
    pressing = log.reference[log.drawing, 2]
    # below the paper: (F* - preload) / pen stiffness + F* / underlay stiffness
    np.testing.assert_allclose(pressing, -((1.0 - km.pen_preload_n) / 0.3
                                           + 1.0 / km.paper_stiffness_n_per_mm))
    np.testing.assert_allclose(plant.goals[-1][0], km.home_q, atol=1e-9)
    np.testing.assert_allclose(km.home_q, km.model.key("home").qpos[:7])


@pytest.mark.sim
def test_ik_knots_are_close_enough_to_keep_a_cusp(km):
    """A 'v' whose two strokes brake to rest at the bottom point, at 300 mm/s peak."""
    t = np.arange(0.0, 0.4 + 1e-9, 0.01)
    s = minimum_jerk(len(t))[:, None]
    down = np.array([80.0, 160.0]) + s * np.array([20.0, -60.0])
    up = np.array([100.0, 100.0]) + s * np.array([20.0, 60.0])
    stroke = Trajectory(np.concatenate([t, t[1:] + 0.4]), np.vstack([down, up[1:]]))
    plant = ServoPlant(km.home_q)
    log = run_drawing(
        Drawing([stroke]), plant, km, default_gains(), LoopConfig()
    )
    kin = ArmKinematics.of(km)
    goals = np.array([g for g, _ in plant.goals])[log.drawing]
    tips = km.placement.to_page(np.array([kin.fk(q)[0] for q in goals]))
    assert np.linalg.norm(tips[:, :2] - log.reference[log.drawing, :2], axis=1).max() < 0.02


@pytest.mark.sim
def test_nib_drag_feedforward_removes_the_lag_along_the_path(km):
    def mean_lag(log):
        mask = log.drawing
        velocity = np.gradient(log.reference[:, :2], log.time, axis=0)[mask]
        fast = np.linalg.norm(velocity, axis=1) > 50.0
        u = velocity[fast] / np.linalg.norm(velocity[fast], axis=1, keepdims=True)
        return float(np.mean(np.sum((log.tip[mask, :2] - log.reference[mask, :2])[fast] * u, 1)))

    drawing = Drawing([letter(105.0, 118.5).strokes[0]])
    runs = {}
    for mu in (None, 0.0):
        # the host's own loop: the drives' stiffness would hide the drag
        runs[mu] = mean_lag(draw(km, drawing, config=LoopConfig(nib_friction=mu),
                                      law=JOINT_PID))
    assert runs[0.0] < -0.03  # uncompensated, the nib drags behind the reference
    assert abs(runs[None]) < abs(runs[0.0]) / 1.8  # the rest is the joints' dry friction


@pytest.mark.sim
def test_an_unreachable_placement_is_refused_before_moving(km):
    page = km.placement
    far = PagePlacement(page.origin_m + [1.2, 0.0, 0.0], page.rotation, page.size_mm)
    believed_far = dataclasses.replace(km, placement=far)
    plant = MujocoPlant(build_model(make_cell(robot=ROBOT)))
    with pytest.raises(
        UnreachableError, match=r"^stroke 0, point \(105.0, 118.5\) mm: out of reach with the pen"
    ):
        run_drawing(letter(105.0, 118.5), plant, believed_far, default_gains())
    assert plant.read().time == 0.0


@pytest.mark.sim
def test_a_stroke_off_the_sheet_is_refused_naming_the_point(km):
    drawing = Drawing([Trajectory([0.0, 1.0], [[100.0, 100.0], [250.0, 100.0]])])
    with pytest.raises(
        UnreachableError, match=r"stroke 0, point \(250.0, 100.0\) mm: off the 210 x 297"
    ):
        check_reachable(drawing, km)


@pytest.mark.sim
def test_divergence_is_reported_with_the_log_so_far(km):
    g = default_gains()
    absurd = PIDGains(
        kp=g.kp,
        ki=g.ki,
        kd=-5.0 * g.kd,
        torque_limit=g.torque_limit,
        integral_limit=g.integral_limit,
    )
    # a watchdog (torque, speed) or the plant's divergence check stops it, with the log so far
    with pytest.raises(RunFault) as info:
        draw(km, letter(105.0, 118.5), gains=absurd, law=JOINT_PID)
    partial = info.value.log
    assert 0 < len(partial) < 500
    assert np.all(np.isfinite(partial.q))
    # the plan's columns are there too, up to the last row run
    # (the safe stop's lift, logged up to where the plant diverged, follows the approach)
    lift = partial.phase == PHASES.index("lift")
    assert np.all(partial.phase[~lift] == PHASES.index("approach")) and np.all(partial.stroke == -1)
    assert not lift.any() or lift[np.argmax(lift):].all()
    assert np.all(np.linalg.norm(partial.reference, axis=1) > 100.0)  # on the sheet, not zeros


@pytest.mark.sim
def test_progress_is_reported_up_to_completion(km):
    seen = []
    plant = ServoPlant(km.home_q)
    run_drawing(
        Drawing([letter(100.0, 100.0).strokes[1]]),
        plant,
        km,
        default_gains(),
        LoopConfig(),
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
        ({"force_n": 0.0}, r"^force_n: expected a number in \(0, 50\] N, got 0.0"),
        ({"descend_s": 1e9}, r"^descend_s: expected a number in \(0, 60\] s, got 1000000000.0"),
        ({"hover_mm": float("inf")}, r"^hover_mm: expected a finite number"),
        ({"settle_s": -0.1}, r"^settle_s: expected a number in \[0, 60\] s, got -0.1"),
        ({"nib_friction": -0.2}, r"^nib_friction: expected a number in \[0, 5\], got -0.2"),
        ({"speed_limits": "ignore"}, r"^speed_limits: expected 'slow' or 'refuse'"),
    ],
)
def test_bad_loop_config_is_refused(kwargs, message):
    with pytest.raises(InputError, match=message) as info:
        LoopConfig(**kwargs)
    assert info.value.key == next(iter(kwargs))
    # a caller adds where the settings came from
    located = info.value.within(file="job.toml", key="controller")
    assert str(located).startswith(f"job.toml: controller.{next(iter(kwargs))}: ")


@pytest.mark.sim
def test_a_force_beyond_the_pen_travel_is_refused(km):
    with pytest.raises(
        InputError, match=r"force_n: 5.0 N compresses the pen by 15.7 mm, more than"
    ):
        check_reachable(letter(105.0, 118.5), km, LoopConfig(force_n=5.0))


@pytest.mark.sim
def test_gains_must_match_the_arm(km):
    g = PIDGains(kp=[1.0, 1.0], ki=0.0, kd=0.0, torque_limit=1.0, integral_limit=0.0)
    with pytest.raises(InputError, match="gains: 2 joints, but the kinematic model has 7"):
        draw(km, letter(105.0, 118.5), gains=g)


@pytest.mark.sim
def test_a_plant_without_the_command_kind_is_refused(km):
    plant = ServoPlant(km.home_q)
    with pytest.raises(InputError, match="law 'joint_pid' sends torque commands; the plant "
                                         "takes position") as info:
        run_drawing(Drawing([letter(100.0, 100.0).strokes[1]]), plant, km, default_gains(),
                    law=JOINT_PID)
    assert info.value.key == "controller.law"
    assert plant.goals == []
