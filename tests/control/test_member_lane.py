"""The member's compiled period (inkarm/control/_member.c via inkarm.control.member_lane) and the
plant's port (inkarm/sim/_period.c via inkarm.sim.compiled.Port) against the executor's Python
steps: the same bits in the log and on the canvas, the same faults at the same rows (a watchdog,
the search, the plant's divergence, Ctrl-C) inside a run of whole periods in C, the hand-over to
Python for a reading it cannot take, and the errors that name what was expected."""

from __future__ import annotations

import re
import sys

import numpy as np
import pytest

from inkarm.control import compiled, executor, member_lane
from inkarm.control.surface import SurfaceEstimate
from inkarm.core.log import LIFT
from inkarm.jobs.outcome import RunInterrupted
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario, parse_scenario
from inkarm.sim.plant import MujocoPlant
from tests.compiled import LOGGED, assert_same_log

pytestmark = pytest.mark.sim

LINE = {"source": {"kind": "plan", "plan": {"strokes": [{"targets": [
    {"mean": [0.0, 0.0], "cov": 1.0}, {"mean": [20.0, 5.0], "cov": 1.0}]}]}},
    "ink": {"px_per_mm": 4.0}}
# The executor's three ways: every step in Python (the extensions off), the member's steps in
# one C call a period (the plant's port withheld), and whole periods in C through the port.
WAYS = ("python", "period", "whole")


def _runs(scenario, monkeypatch, ways=WAYS) -> dict:
    """``scenario`` run each way: the Run (or the partial Run of a Ctrl-C) and how many
    periods ran whole in C (-1 where its fault came out of whole periods in C)."""
    out = {}
    lane_run = member_lane.Lane.run
    for way in ways:
        ran = [0]

        def counted(lane, periods, ran=ran):
            try:
                done = lane_run(lane, periods)
            except BaseException:
                ran[0] = -1
                raise
            ran[0] += done
            return done

        with monkeypatch.context() as m:
            m.setenv(compiled.SWITCH, "0" if way == "python" else "1")
            m.setattr(member_lane.Lane, "run", counted)
            if way == "period":
                m.setattr(MujocoPlant, "compiled_port", lambda plant: None)
            try:
                result = run(scenario)
            except RunInterrupted as stop:
                result = stop.run
        out[way] = (result, ran[0])
    return out


def _assert_same(runs: dict) -> None:
    (a, _), *others = runs.values()
    for b, _ in others:
        assert (a.status, a.reason) == (b.status, b.reason)
        assert_same_log(a.log, b.log)
        assert a.canvas.image.tobytes() == b.canvas.image.tobytes()
        assert a.canvas.n_strokes == b.canvas.n_strokes


def _line(tmp_path, **overrides):
    return parse_scenario(LINE, "job.toml", tmp_path).with_overrides(overrides)


def _kernel(n: int = 2, plan_q=None, hold=None, log=None, loop=None, qd=None):
    """A MemberPeriod of 4 plan rows for ``n`` joints, zeros throughout (its errors' and
    hand-overs' tests), with any of its parts replaced."""
    module = compiled.member_module()
    law = compiled.position_law()(*(np.zeros((4, n)),) * 5, np.zeros(n), np.ones(n), 0.0)
    plan = (np.zeros((4, n)) if plan_q is None else plan_q, np.zeros((4, n)), None, np.zeros(4),
            np.zeros(4), np.zeros(4, dtype=np.int64),
            np.zeros(4, dtype=bool) if hold is None else hold,
            np.zeros((4, n)) if qd is None else qd, np.zeros((4, n)))
    log = log if log is not None else (
        np.zeros(9), np.zeros((9, n)), np.zeros((9, n)), np.zeros((9, n)), np.zeros((9, 3)),
        np.zeros(9), np.zeros(9, dtype=np.int64), np.zeros(9, dtype=np.int64), np.zeros(9))
    loop = loop if loop is not None else (
        0.5, 0.05, 1e-4, 1.0, 3e-3, 1e-5, 0.1, 1e-3, 0.1, 500.0, 0.03, True, 1, 4e-3, 1e-3, 10,
        lambda t: None, SurfaceEstimate.plane)
    return module.MemberPeriod(plan, log, law, loop, print, None, 1.0, 1.0, 0, True, 5, 10,
                               (0, 1, 2, 5), 0.002, False, 0.0, (np.hypot, np.empty, tuple))


def _state(time: float, q, qd) -> object:
    return type("S", (), {"time": time, "q": q, "qd": qd, "torque": None, "force": 0.0,
                          "tip_mm": np.zeros(3)})()


def test_the_default_drawing_is_the_same_every_way(built, monkeypatch):
    runs = _runs(load_scenario(), monkeypatch)
    _assert_same(runs)
    assert runs["whole"][0].status == "ok"
    # most periods ran whole in C; none did with the port withheld
    assert runs["whole"][1] > 0.9 * len(runs["whole"][0].log.time)
    assert runs["period"][1] == 0 == runs["python"][1]


@pytest.mark.parametrize("overrides, reason", [
    ({"controller.tracking_limit_mm": 0.02, "controller.watchdog_s": 0.004},
     r"tracking_limit: pen 0\.0 mm from its reference for 4 ms \(limit 0\.02 mm\)"),
    ({"controller.force_limit_n": 1.01}, r"force_limit: pen force 1\.0[1-9] N above the 1\.01 N"),
    ({"sim.plant.paper_height_mm": -40.0}, r"paper_not_found: no contact within 10 mm"),
    # (the watchdogs in Python every period, counting)
    ({"robot.gains.kp": 1e7, "robot.gains.kd": 0.0},
     r"torque_saturated: joint6 torque at its 40 N m limit for 100 ms"),
])
def test_a_fault_inside_whole_periods_in_c_stops_the_run_as_in_python(
        built, monkeypatch, tmp_path, overrides, reason):
    runs = _runs(_line(tmp_path, **overrides), monkeypatch)
    _assert_same(runs)
    failed = runs["whole"][0]
    assert failed.status == "failed"
    assert len(failed.log.time) > 0 and re.search(reason, failed.reason), failed.reason
    assert runs["whole"][1] == -1  # (the fault came out of whole periods in C)


def hook_solve(monkeypatch, solve_no: int, act) -> list[int]:
    """``act()`` called at the plane's ``solve_no``-th solve (the solve is Python's, called from
    C); returns the count of solves, ``[n]``: set it to ``[0]`` before each run."""
    plane, calls = SurfaceEstimate.plane, [0]

    def solve(sums, prior):
        calls[0] += 1
        if calls[0] == solve_no:
            act()
        return plane(sums, prior)

    monkeypatch.setattr(SurfaceEstimate, "plane", staticmethod(solve))
    return calls


def _at_sixth_solve(monkeypatch, scenario, act) -> dict:
    """``scenario`` run each way (:func:`_runs`) with ``act()`` called at the plane's 6th solve,
    well inside the drawing (in whole periods in C)."""
    calls = hook_solve(monkeypatch, 6, act)
    runs = {}
    for way in WAYS:
        calls[0] = 0
        runs |= _runs(scenario, monkeypatch, ways=(way,))
    return runs


def test_ctrl_c_inside_whole_periods_in_c_lifts_the_pen_as_in_python(built, monkeypatch,
                                                                      tmp_path):
    def interrupt():
        raise KeyboardInterrupt

    runs = _at_sixth_solve(monkeypatch, _line(tmp_path), interrupt)
    _assert_same(runs)
    assert runs["whole"][0].status == "interrupted" and runs["whole"][1] == -1


def test_the_plant_diverging_inside_whole_periods_in_c_fails_the_run_as_in_python(
        built, monkeypatch, tmp_path):
    plants, init = [], MujocoPlant.__init__
    monkeypatch.setattr(MujocoPlant, "__init__", lambda plant, *a, **k: (
        plants.append(plant), init(plant, *a, **k))[1])

    def kick():
        plants[-1].data.qvel[3] = 500.0

    runs = _at_sixth_solve(monkeypatch, _line(tmp_path), kick)
    _assert_same(runs)
    failed = runs["whole"][0]
    assert failed.status == "failed" and re.search(r"moves at [0-9.]+ rad/s", failed.reason)
    assert runs["whole"][1] == -1


def test_progress_is_reported_as_often_with_whole_periods_in_c(built, monkeypatch):
    reports = {}
    for way in ("period", "whole"):
        seen = []
        with monkeypatch.context() as m:
            if way == "period":
                m.setattr(MujocoPlant, "compiled_port", lambda plant: None)
            run(load_scenario(), progress=lambda fraction, phase, seen=seen: seen.append(fraction))
        reports[way] = seen
    assert abs(len(reports["whole"]) - len(reports["period"])) <= 1
    assert reports["whole"] == sorted(reports["whole"]) and reports["whole"][-1] == 1.0


@pytest.mark.parametrize("after", [1, 300])
def test_a_reading_the_c_period_cannot_take_hands_the_member_to_python(built, monkeypatch,
                                                                        after):
    read, handed = MujocoPlant.read, []
    reads = [0]

    def float32_later(plant):  # (a driver that changes its arrays' kind mid-run)
        state = read(plant)
        reads[0] += 1
        if reads[0] > after:
            state.q = state.q.astype(np.float32)
        return state

    over = member_lane.Lane.hand_over
    monkeypatch.setattr(member_lane.Lane, "hand_over",
                        lambda lane, loop: handed.append(1) or over(lane, loop))
    monkeypatch.setattr(MujocoPlant, "read", float32_later)
    runs = {}
    # (after 300 readings the whole periods in C read the plant through its port, not read())
    ways = ("python steps", "period", "whole") if after == 1 else ("python steps", "period")
    for way in ways:
        reads[0] = 0
        with monkeypatch.context() as m:
            if way == "python steps":
                m.setattr(executor, "lane_for", lambda **kwargs: None)
            if way == "period":  # (a float32 reading after 300 periods in C: the port withheld)
                m.setattr(MujocoPlant, "compiled_port", lambda plant: None)
            runs[way] = (run(load_scenario()), 0)
    assert handed == [1] * (len(ways) - 1) and runs["period"][0].status == "ok"
    _assert_same(runs)


def test_the_c_period_refuses_what_is_not_its_plan(built):
    module = compiled.member_module()
    with pytest.raises(ValueError, match=r"q_ref must be of format d, 2-d, 4 rows \(x 2\)"):
        _kernel(plan_q=np.zeros((4, 3)))
    loop = (0.5, 0.05, 1e-4, 1.0, 3e-3, 1e-5, 0.1, 1e-3, 0.1, 500.0, 0.03, True, 1, 1e-3, 1e-3,
            10, lambda t: None, SurfaceEstimate.plane)  # (another dead band)
    with pytest.raises(ValueError, match=r"dead band, lag or refit interval"):
        _kernel(loop=loop)
    kernel = _kernel()
    with pytest.raises(module.NotForLane, match=r"the reading's q is not 2 float64"):
        kernel.period(_state(0.0, np.zeros(3), np.zeros(2)))
    assert kernel.row == 0 and kernel.i == 0  # (nothing changed)
    with pytest.raises(TypeError, match=r"port must be a plant.s port \(a PyCapsule named "
                                        r"inkarm.plant\)"):
        kernel.run(object(), 1)


def test_the_plants_port_is_only_offered_where_it_can_take_over(built):
    from inkarm.core.plant import PositionCommand
    from inkarm.sim.cell import build_model

    plant = MujocoPlant(build_model())
    port = plant.compiled_port()
    assert port is not None and port.enter() is None  # (no position goal held yet)
    plant.command(PositionCommand(plant.read().q))
    assert port.enter() is None  # (a command queued)
    plant.step()
    capsule = port.enter()
    assert capsule is not None
    with pytest.raises(RuntimeError, match="step\\(\\) between enter\\(\\) and leave\\(\\)"):
        plant.step()
    with pytest.raises(RuntimeError, match="entered already"):
        port.enter()
    port.leave()
    plant.step()  # (the plant's own period again)
    with pytest.raises(RuntimeError, match="not entered"):
        plant._period.leave()


def test_without_the_extension_or_off_its_path_the_executor_takes_its_python_steps(
        monkeypatch, tmp_path):
    made = []
    lane_for = executor.lane_for
    monkeypatch.setattr(executor, "lane_for", lambda **kw: made.append(lane_for(**kw)) or made[-1])
    monkeypatch.setenv(compiled.SWITCH, "0")
    run(_line(tmp_path))
    monkeypatch.setenv(compiled.SWITCH, "1")
    run(_line(tmp_path, **{"controller.law": "joint_pid"}))  # (not the position law)
    run(_line(tmp_path, **{"controller.probe_paper": True}))  # (probing: Python)
    assert made == [None, None, None]


def test_a_plant_that_wraps_the_simulated_arm_is_not_bypassed_by_its_port(built):
    from inkarm.sim.cell import build_model

    class Shaping:  # (forwards every attribute, but shapes the commands: cf. ServoGoals)
        def __init__(self, plant):
            self._plant = plant

        def __getattr__(self, name):
            return getattr(self._plant, name)

    class Subclass(MujocoPlant):
        pass

    plant = MujocoPlant(build_model())
    assert member_lane.port_of(plant) is not None
    assert member_lane.port_of(Shaping(plant)) is None
    assert member_lane.port_of(Subclass(build_model())) is None


def test_a_port_used_after_leave_refuses_instead_of_writing_freed_buffers(built):
    from inkarm.core.plant import PositionCommand
    from inkarm.sim.cell import build_model

    plant = MujocoPlant(build_model())
    plant.command(PositionCommand(plant.read().q))
    plant.step()
    port = plant.compiled_port()
    capsule = port.enter()
    port.leave()
    kernel = _kernel(7)
    with pytest.raises(RuntimeError, match=r"the plant's port is closed \(leave\(\) was called\)"):
        kernel.run(capsule, 3)
    assert kernel.row == 0


def test_a_plant_drawn_on_again_lifts_its_pen_on_ctrl_c_as_in_python(built, monkeypatch,
                                                                      tmp_path):
    from inkarm.jobs.backends import BackendOptions, get_backend

    logs = {}
    for way in ("python", "whole"):  # (the second drawing's periods all in C from its first)
        monkeypatch.setenv(compiled.SWITCH, "0" if way == "python" else "1")
        session = get_backend("sim").open(_line(tmp_path), BackendOptions())
        session.execute(None)

        def stop(fraction, phase):
            raise KeyboardInterrupt

        with pytest.raises(KeyboardInterrupt) as info:
            session.execute(stop)
        logs[way] = info.value.log
    assert (logs["whole"].phase == LIFT).sum() > 0  # (lifted, not only braked)
    for key in LOGGED:
        assert getattr(logs["python"], key).tobytes() == getattr(logs["whole"], key).tobytes()


def test_a_refused_construction_leaks_and_frees_nothing(built):
    qd_free = np.zeros((4, 2))  # (the planned qd: the constructor keeps a reference to it)
    hold = np.zeros(5, dtype=bool)  # (hold_at: one row too many)
    before = sys.getrefcount(qd_free), sys.getrefcount(hold)
    for _ in range(3):
        with pytest.raises(TypeError):  # (a log of 8 columns, not 9)
            _kernel(log=(np.zeros(9),) * 8, qd=qd_free)
        with pytest.raises(ValueError, match="hold_at must be of format"):
            _kernel(hold=hold)
    assert (sys.getrefcount(qd_free), sys.getrefcount(hold)) == before


def test_handing_over_without_a_period_stepped_leaves_the_drives_as_they_were(built):
    from inkarm.core.plant import PositionCommand
    from inkarm.sim.cell import build_model

    plant = MujocoPlant(build_model())
    plant.command(PositionCommand(plant.read().q, np.zeros(7), None, np.full(7, 0.25)))
    plant.step()
    drive = plant.drive
    before = (drive.q_goal, drive.qd_goal, drive.tau_ff, drive.since, plant._steps)
    port = plant.compiled_port()
    port.enter()
    port.leave()
    assert (drive.q_goal, drive.qd_goal, drive.tau_ff, drive.since, plant._steps) == before


def test_a_reading_at_a_time_that_is_not_finite_goes_to_python(built):
    with pytest.raises(compiled.member_module().NotForLane, match="time is not a finite number"):
        _kernel().period(_state(float("nan"), np.zeros(2), np.zeros(2)))
