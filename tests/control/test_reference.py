"""Joint references for arms: the pen path by IK on the controller's model, the approach and
home moves within the joint speeds, speed limits refused or slowed."""

import dataclasses

import numpy as np
import pytest

from inkarm.control.config import LoopConfig
from inkarm.control.executor import run_drawing
from inkarm.control.kinematics import ArmKinematics
from inkarm.control.reference import (
    JointSpeedError,
    _knots,
    _Lerp,
    check_reachable,
    plan_joint_reference,
    plan_within_speed_limits,
    slowed,
)
from inkarm.control.sequencing import minimum_jerk, pen_depth_mm, sequence_pen
from inkarm.core.log import APPROACH, DRAW, HOME, PHASES
from inkarm.core.plant import PlantState, PositionCommand
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import UnreachableError
from inkarm.robots.registry import load_robot
from inkarm.sim.cell import kinematic_model, make_cell

pytestmark = pytest.mark.sim

ROBOT = load_robot("iiwa14")
DT = 0.006


@pytest.fixture(scope="module")
def km():
    return kinematic_model(make_cell(robot=ROBOT))


@pytest.fixture(scope="module")
def kin(km):
    return ArmKinematics.of(km)


def swoosh(x0=70.0, y0=120.0, duration=0.5) -> Drawing:
    """Two quick strokes, 70 mm at up to about 260 mm/s."""
    t = np.arange(0.0, duration + 1e-9, 0.01)
    s = minimum_jerk(len(t))[:, None]
    a = np.array([x0, y0]) + s * np.array([70.0, 10.0])
    b = np.array([x0, y0 + 40.0]) + s * np.array([60.0, -30.0])
    return Drawing([Trajectory(t, a), Trajectory(t, b)])


def pen_path(km, drawing, config=None):
    config = config or LoopConfig()
    depth = pen_depth_mm(config, km.pen_stiffness_n_per_mm, km.pen_travel_mm)
    return sequence_pen(drawing, config, depth, DT)


@pytest.fixture(scope="module")
def planned(km, kin):
    pen = pen_path(km, swoosh())
    return pen, plan_joint_reference(pen, km, LoopConfig(), km.home_q, DT, kin=kin)


def test_the_reference_wraps_the_pen_path_in_approach_and_home(planned, kin, km):
    pen, ref = planned
    assert len(ref) > len(pen)
    first = int(np.argmax(ref.phase != APPROACH))
    assert np.all(ref.phase[:first] == APPROACH) and np.all(ref.stroke[:first] == -1)
    np.testing.assert_array_equal(ref.phase[first : first + len(pen)], pen.phase)
    np.testing.assert_array_equal(ref.stroke[first : first + len(pen)], pen.stroke)
    np.testing.assert_array_equal(ref.page_mm[first : first + len(pen)], pen.page_mm)
    assert np.all(ref.phase[first + len(pen) :] == HOME)
    assert sorted(ref.settle) == sorted(first + r for r in pen.settle)
    np.testing.assert_allclose(ref.q[0], km.home_q)
    np.testing.assert_allclose(ref.q[-1], km.home_q, atol=1e-9)
    assert np.all(ref.q >= kin.lower) and np.all(ref.q <= kin.upper)
    for name in ("qd", "qdd", "normal_q", "contact_tau", "inertia"):
        assert getattr(ref, name).shape == ref.q.shape, name


def test_the_joint_path_puts_the_tip_on_the_pen_path(planned, kin, km):
    pen, ref = planned
    first = int(np.argmax(ref.phase != APPROACH))
    q = ref.q[first : first + len(pen)]
    tips = km.placement.to_page(np.array([kin.fk(qi)[0] for qi in q]))
    assert np.max(np.linalg.norm(tips - pen.page_mm, axis=1)) < 0.01  # spline between knots
    np.testing.assert_allclose(ref.qd, np.gradient(ref.q, DT, axis=0))


def test_joint_moves_keep_to_the_configured_joint_speed(planned):
    _, ref = planned
    moves = np.isin(ref.phase, [APPROACH, HOME])
    assert np.max(np.abs(ref.qd[moves])) <= LoopConfig().joint_speed_rad_s * (1 + 1e-9)


def test_tiny_speed_limits_are_refused_naming_a_joint(planned, km, kin):
    pen, ref = planned
    start = ref.q[int(np.argmax(ref.phase != APPROACH))]  # no approach to speak of
    config = LoopConfig(go_home=False)
    limits = np.full(kin.n, 0.01)
    with pytest.raises(JointSpeedError, match=r"the reference drives joint joint\d") as info:
        plan_joint_reference(pen, km, config, start, DT, kin=kin, speed_limits=limits)
    error = info.value
    assert isinstance(error, UnreachableError)
    assert error.joint in kin.joint_names and error.joint in str(error)
    assert error.excess > 1.0
    j = kin.joint_names.index(error.joint)
    assert error.excess == pytest.approx(np.max(np.abs(ref.qd[:, j])) / 0.01, rel=0.05)


def test_the_robots_own_limits_pass(planned, km, kin):
    pen, ref = planned
    again = plan_joint_reference(pen, km, LoopConfig(), km.home_q, DT, kin=kin,
                                 speed_limits=ROBOT.speed_limits)
    np.testing.assert_array_equal(again.q, ref.q)


def test_an_unreachable_first_point_is_refused(km, kin):
    page = km.placement
    far = dataclasses.replace(
        km, placement=type(page)(page.origin_m + [1.5, 0.0, 0.0], page.rotation, page.size_mm)
    )
    with pytest.raises(UnreachableError, match=r"^stroke 0, point \(70.0, 120.0\) mm: out of"):
        plan_joint_reference(pen_path(km, swoosh()), far, LoopConfig(), km.home_q, DT, kin=kin)
    with pytest.raises(UnreachableError, match=r"^stroke 0, point \(70.0, 120.0\) mm: out of"):
        check_reachable(swoosh(), far, kin=kin)


def planned_peaks(km, kin, drawing):
    """The drawing's reference without speed limits, and its peak joint speeds per joint on the
    draw rows and on the pen-up moves (travel, descents, lifts)."""
    ref, notes = plan_within_speed_limits(drawing, km, LoopConfig(), km.home_q, DT, kin)
    assert notes == ()
    peak = np.abs(ref.qd)
    draw = peak[ref.phase == DRAW].max(axis=0)
    moves = peak[~np.isin(ref.phase, [DRAW, APPROACH, HOME])].max(axis=0)
    return ref, draw, moves


def draw_limits(km, kin, drawing):
    """Speed limits that the drawing's strokes exceed but its descents and lifts (which slowing
    the drawing does not stretch) keep to: 60% of the draw rows' peak per joint."""
    _, draw, moves = planned_peaks(km, kin, drawing)
    limits = np.maximum(0.6 * draw, 1.1 * moves)
    assert np.any(draw > limits)
    return limits


class ServoPlant:
    """An ideal position servo (see test_loop): q follows the goals, qd the feed-forward."""

    dt = DT
    senses = frozenset()
    commands = frozenset({"position"})

    def __init__(self, q0):
        self.q, self.qd, self.t, self.goal = np.array(q0, float), np.zeros(len(q0)), 0.0, None

    def read(self):
        return PlantState(time=self.t, q=self.q.copy(), qd=self.qd.copy())

    def command(self, command):
        assert isinstance(command, PositionCommand)
        self.goal = command

    def step(self):
        self.q = self.goal.q + self.goal.qd * self.dt
        self.qd = self.goal.qd.copy()
        self.t += self.dt

    def close(self):
        pass


def test_a_drawing_too_fast_for_the_limits_is_slowed_and_says_so(km, kin):
    drawing = swoosh()
    limits = draw_limits(km, kin, drawing)
    log = run_drawing(drawing, ServoPlant(km.home_q), km, ROBOT.gains,
                      LoopConfig(speed_limits="slow"), speed_limits=limits)
    assert len(log.notes) >= 1
    assert all(note.startswith("slowed ") for note in log.notes)
    assert "x: the reference drives joint" in log.notes[0]
    assert np.all(np.abs(log.qd) <= limits * (1 + 1e-9))
    # each stroke took longer than drawn (0.5 s), by the stretch the note gives
    stretch = float(log.notes[-1].split()[1])
    assert stretch > 1.05
    for k in (0, 1):
        drawn = log.time[log.drawing & (log.stroke == k)]
        assert drawn[-1] - drawn[0] == pytest.approx(0.5 * stretch, abs=2 * DT)
    assert set(log.phase.tolist()) == {PHASES.index(p) for p in PHASES}


def test_moves_too_fast_between_strokes_keep_within_themselves_not_the_strokes(km, kin):
    """Limits that only the travel, descents and lifts exceed: those slow down, the strokes
    keep the drawing's own timing."""
    drawing = Drawing([swoosh().strokes[0], swoosh(x0=20.0, y0=40.0).strokes[1]])
    ref, draw, moves = planned_peaks(km, kin, drawing)
    # (a joint the plan hardly moves, the wrist's spin, gets a limit of 0.01 rad/s, not one at
    # the last bits of its planned speed)
    limits = np.maximum(np.maximum(1.1 * draw, 0.7 * moves), 0.01)
    assert np.any(moves > limits)
    slow, notes = plan_within_speed_limits(drawing, km, LoopConfig(), km.home_q, DT, kin,
                                           speed_limits=limits)
    assert notes and all(n.startswith("slowed the pen-up moves ") for n in notes), notes
    assert np.all(np.abs(slow.qd) <= limits * (1 + 1e-9))
    assert len(slow) > len(ref)
    for k in (0, 1):  # each stroke as long as drawn (0.5 s)
        assert np.sum((slow.phase == DRAW) & (slow.stroke == k)) == \
            np.sum((ref.phase == DRAW) & (ref.stroke == k))


def test_refuse_raises_instead_of_slowing(km, kin):
    drawing = swoosh()
    limits = draw_limits(km, kin, drawing)
    with pytest.raises(JointSpeedError) as info:
        run_drawing(drawing, ServoPlant(km.home_q), km, ROBOT.gains,
                    LoopConfig(speed_limits="refuse"), speed_limits=limits)
    assert info.value.joint in kin.joint_names


def test_slowed_stretches_every_time():
    drawing = swoosh()
    slow = slowed(drawing, 2.0)
    for a, b in zip(drawing.strokes, slow.strokes):
        np.testing.assert_allclose(b.t, 2.0 * a.t)
        np.testing.assert_array_equal(b.pos, a.pos)


def test_knots_take_every_stride_th_row_and_always_the_last():
    for n in range(1, 40):
        for stride in range(1, 9):
            knots = _knots(n, stride)
            np.testing.assert_array_equal(knots, np.unique(np.append(np.arange(0, n, stride),
                                                                     n - 1)))
            values = np.random.default_rng(n).normal(size=(len(knots), 2, 3))
            lerped = _Lerp(knots, n)(values)
            np.testing.assert_array_equal(lerped[knots], values)  # the knots' own rows
