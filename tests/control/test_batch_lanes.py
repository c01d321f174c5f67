"""A batch's members' periods in one C call (inkarm/control/batch_lanes.py, ``_member_batch.c``'s
``periods``) against the members' generators: the same bits in every member's log and on its
page, the same faults at the same rows (a watchdog, the search, a Ctrl-C inside a member's
period or between two), with readings older than a period and each member's own read-out age,
and the errors of the call that name what was expected."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.control import batch_lanes, compiled, members
from inkarm.core.log import LIFT
from inkarm.jobs.ensemble import run_ensemble
from inkarm.jobs.scenario import load_scenario
from tests.compiled import assert_same_log
from tests.control.test_member_lane import hook_solve

pytestmark = pytest.mark.sim

# The executor's three ways for a batch: every step in Python (the extensions off), each
# member's steps in one C call a period from its generator (the batch's call withheld), and
# every member's period in one C call.
WAYS = ("python", "lanes", "batch")
# Readings older than the 6 ms period, each member's own read-out age, commands that reach the
# drives late, and paper heights from 20 mm below to 16 mm above the model's with a 3 mm search:
# seed 3's sheet is never found, seed 9's is hit too hard, seed 0's is drawn on (as
# tests/jobs/test_ensemble.py's RISKY).
DELAYED = {"plant.sensing_delay_ms": 8.0, "plant.readout_jitter_ms": 3.0,
           "plant.actuation_delay_ms": 4.0, "plant.random": {"paper_height_mm": [-20.0, 16.0]},
           "controller.correction_limit_mm": 3.0}
SEEDS = [0, 3, 9, 4]


@pytest.fixture(scope="module")
def quick():
    return load_scenario("scenarios/quick_stroke.toml")


def _ensembles(scenario, monkeypatch, seeds=SEEDS, progress=None, before=None) -> dict:
    """``scenario``'s ensemble of ``seeds`` each way, in this process (``before(way)`` called
    first): (the Runs, or the logs of a Ctrl-C; the members the C call handed back, with their
    exceptions' types; the members back in their generators, whatever sent them)."""
    out = {}
    period, drop = batch_lanes.BatchLanes.period, batch_lanes.BatchLanes.drop
    for way in WAYS:
        handed, dropped = [], []
        if before is not None:
            before(way)

        def counted(lanes, handed=handed):
            for m, fault in period(lanes):
                handed.append((m, type(fault).__name__))
                yield m, fault

        with monkeypatch.context() as m:
            m.setenv(compiled.SWITCH, "0" if way == "python" else "1")
            m.setattr(batch_lanes.BatchLanes, "period", counted)
            m.setattr(batch_lanes.BatchLanes, "drop",
                      lambda lanes, member, dropped=dropped: (dropped.append(member),
                                                               drop(lanes, member))[1])
            if way == "lanes":
                m.setattr(members, "batch_lanes", lambda *args: None)
            try:
                result = run_ensemble(scenario, seeds, processes=1, progress=progress)
            except KeyboardInterrupt as stop:
                result = stop.logs
        out[way] = (result, handed, dropped)
    return out


def _assert_same(ways: dict) -> None:
    (first, *_), *others = ways.values()
    for other, *_ in others:
        assert len(first) == len(other)
        for a, b in zip(first, other):
            if hasattr(a, "log"):  # (a Run)
                assert (a.status, a.reason) == (b.status, b.reason)
                assert a.canvas.image.tobytes() == b.canvas.image.tobytes()
                a, b = a.log, b.log
            assert_same_log(a, b)


def test_faulting_members_and_old_readings_give_the_same_bits_every_way(built, monkeypatch,
                                                                         quick):
    reports = []  # (each way's progress)
    ways = _ensembles(quick.with_overrides(DELAYED), monkeypatch,
                      progress=lambda fraction, phase: reports[-1].append((fraction, phase)),
                      before=lambda way: reports.append([]))
    _assert_same(ways)
    assert reports[0] == reports[1] == reports[2] and len(reports[2]) > 10
    runs, handed, _ = ways["batch"]
    assert [r.status == "failed" for r in runs] == [False, True, True, False]
    assert runs[1].reason.startswith("paper_not_found: no contact within 3 mm")
    assert runs[2].reason.startswith("force_limit: pen force")
    # the faults came out of the batch's C call; the finishers went back at their plan's end
    assert sorted(handed) == [(0, "NoneType"), (1, "RunFault"), (2, "RunFault"),
                              (3, "NoneType")]
    assert ways["lanes"][1:] == ([], []) == ways["python"][1:]


def test_a_tracking_fault_with_the_watchdogs_counting_in_python_is_the_same_every_way(
        built, monkeypatch, quick):
    scenario = quick.with_overrides({"controller.tracking_limit_mm": 0.05,
                                     "controller.watchdog_s": 0.012,
                                     "plant.sensing_delay_ms": 2.0})
    ways = _ensembles(scenario, monkeypatch, seeds=[1, 2])
    _assert_same(ways)
    runs, handed, _ = ways["batch"]
    assert all(r.status == "failed" and r.reason.startswith("tracking_limit") for r in runs)
    assert {m for m, _ in handed} == {0, 1}


def _interrupt():
    raise KeyboardInterrupt


def _at_solve(monkeypatch, scenario, solve_no: int, seeds=SEEDS, act=_interrupt) -> dict:
    """``scenario`` each way with ``act()`` called at the plane's ``solve_no``-th solve (from a
    member's period in C: inside the batch's call)."""
    calls = hook_solve(monkeypatch, solve_no, act)
    return _ensembles(scenario, monkeypatch, seeds, before=lambda way: calls.__setitem__(0, 0))


def test_ctrl_c_inside_a_members_period_lifts_every_pen_as_the_generators_do(
        built, monkeypatch, quick):
    ways = _at_solve(monkeypatch, quick.with_overrides(DELAYED), 9, seeds=[0, 4, 5])
    _assert_same(ways)
    logs, handed, _ = ways["batch"]
    assert isinstance(logs, list) and all(len(log.time) for log in logs)  # (a Ctrl-C's logs)
    assert "KeyboardInterrupt" in {kind for _, kind in handed}  # (inside the C call)
    assert all(log.phase[-1] == LIFT for log in logs)  # (every pen lifted)


def test_a_member_whose_simulation_diverges_fails_alone_as_in_its_generator(built, monkeypatch,
                                                                            quick):
    from inkarm.sim.batch import BatchPlant

    plants, init = [], BatchPlant.__init__
    monkeypatch.setattr(BatchPlant, "__init__", lambda plant, *a, **k: (
        plants.append(plant), init(plant, *a, **k))[1])

    def kick():  # (member 1's joint 4 flung: the batch's step faults it)
        plants[-1]._qvel[1, 3] = 500.0

    ways = _at_solve(monkeypatch, quick.with_overrides(DELAYED), 9, seeds=[0, 4, 5], act=kick)
    _assert_same(ways)
    runs, handed, dropped = ways["batch"]
    assert [r.status == "failed" for r in runs] == [False, True, True]
    assert runs[1].reason.startswith("simulation diverged") and "joint4 moves at" in runs[1].reason
    assert runs[2].reason.startswith("paper_not_found")  # (seed 5's sheet: too low)
    # (member 1 went back to its generator by the batch's step, not by the C call)
    assert 1 in dropped and all(m != 1 for m, _ in handed)


def test_ctrl_c_between_periods_lifts_every_pen_as_the_generators_do(built, monkeypatch,
                                                                      quick):
    reports = [0]

    def stop(fraction, phase):
        reports[0] += 1
        if reports[0] == 8:
            raise KeyboardInterrupt

    ways = _ensembles(quick.with_overrides(DELAYED), monkeypatch, seeds=[0, 4], progress=stop,
                      before=lambda way: reports.__setitem__(0, 0))
    _assert_same(ways)
    logs, handed, dropped = ways["batch"]
    # (both went back to their generators by the Ctrl-C, none by the C call)
    assert len(logs) == 2 and handed == [] and dropped == [0, 1]


def test_ctrl_c_before_the_first_call_lifts_every_pen_as_after_the_first_step(
        built, monkeypatch, quick):
    """A Ctrl-C as the C call fetches the batch's rows the first time (the members taken, none
    of their periods run by it) stops them where a Ctrl-C in the first step stops the
    generators: each at its yield after its own first period, that period stepped."""
    from inkarm.sim.batch import BatchPlant
    from inkarm.sim.batch_members import BatchMembers

    step, rows = BatchPlant.step, BatchMembers.lane_rows
    hook = {}

    def step_then_stop(plant, ids):
        faults = step(plant, ids)
        if hook.pop("step", False):
            raise KeyboardInterrupt
        return faults

    def stop_at_first(members):
        if hook.pop("rows", False):
            raise KeyboardInterrupt
        return rows(members)

    monkeypatch.setattr(BatchPlant, "step", step_then_stop)
    monkeypatch.setattr(BatchMembers, "lane_rows", stop_at_first)
    ways = _ensembles(quick.with_overrides(DELAYED), monkeypatch, seeds=[0, 4],
                      before=lambda way: hook.update({"rows" if way == "batch" else "step": 1}))
    _assert_same(ways)
    logs, handed, dropped = ways["batch"]
    assert not hook and handed == [] and dropped == [0, 1]  # (both taken, then sent back)
    assert all((log.phase[1:] == LIFT).all() for log in logs)


def test_the_call_refuses_what_is_not_a_batchs_rows(built):
    periods = compiled.member_module().periods
    with pytest.raises(TypeError, match=r"periods\(kernels: tuple, ids: list"):
        periods([], [], 0, lambda: None, [])
    with pytest.raises(ValueError, match=r"member 0 has no MemberPeriod among the 1 kernels"):
        periods((None,), [0], 0, lambda: None, [0])
    with pytest.raises(ValueError, match=r"rows has 2 items for 1 members"):
        periods((None,), [0], 0, lambda: None, [0, 0])
    with pytest.raises(ValueError, match=r"start must be >= 0, not -1"):
        periods((None,), [0], -1, lambda: None, [0])
    assert periods((), [], 0, lambda: None, []) == (0, None)
    from tests.control.test_member_lane import _kernel

    kernel, n = _kernel(), 2
    kernel.period(type("S", (), {"time": 0.0, "q": np.zeros(n), "qd": np.zeros(n),
                                 "torque": None, "force": 0.0, "tip_mm": np.zeros(3)})())
    assert not kernel.fresh  # (a reading of Python's: its generator knows it is fresh)
    rows = [np.zeros((1, n)), np.zeros((1, n)), np.zeros((1, n)), np.zeros(1), np.zeros((1, 3))]
    out = [np.zeros((1, n)), np.zeros((1, n)), np.zeros((1, n)), np.zeros(1, dtype=bool)]
    bad = (0.006, None, *rows[:4], np.zeros((1, 2)), *out)
    with pytest.raises(ValueError, match=r"the batch's tip must be of format d, 2-d, 1 rows "
                                         r"\(x 3\)"):
        periods((kernel,), [0], 0, lambda: bad, [0])
    assert kernel.i == 0 and kernel.row == 1  # (nothing changed)
    assert periods((kernel,), [0], 0, lambda: None, [0]) == (0, None)  # (not the lane's rows)
    odd = (0.006, np.array([np.nan]), *rows, *out)  # (a time period() would refuse)
    assert periods((kernel,), [0], 0, lambda: odd, [0]) == (0, None)
    assert kernel.i == 0 and kernel.row == 1 and not out[3][0]
    assert periods((kernel,), [0], 0, lambda: (0.006, None, *rows, *out), [7]) == (1, None)
    # its period, its command given (the reading commanded: not fresh)
    assert kernel.i == 1 and kernel.row == 2 and out[3][0] and not kernel.fresh
