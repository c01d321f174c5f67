"""Ensembles in worker processes: the packing of pages (bit for bit, against the arrays
themselves), the shares' streams in order, the members equal to one batch in this process
(the oracle), progress, errors, dead workers, and Ctrl-C or a caller that stops ending the
workers."""

from __future__ import annotations

import gc
import multiprocessing
import os
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.core.log import PHASES
from inkarm.errors import InkarmError, InputError
from inkarm.jobs.ensemble import iter_ensemble, run_ensemble
from inkarm.jobs.ensemble import workers as ensemble_workers
from inkarm.jobs.ensemble.workers import nonzero_box, pack, stream_shares
from inkarm.jobs.scenario import load_scenario

RISKY = {"plant.random": {"paper_height_mm": [-20.0, 16.0]},
         "controller.correction_limit_mm": 3.0}  # seed 0 draws, 3 and 9 fail (test_ensemble)


def workers_alive() -> list[int]:
    return [p.pid for p in multiprocessing.active_children()
            if p.name == "inkarm-ensemble-worker"]


# -- packing ------------------------------------------------------------------------------------

@settings(max_examples=40, deadline=None)
@given(st.integers(1, 40), st.integers(1, 40), st.sampled_from(["<f4", "<f8", "<i2", "|u1"]),
       st.lists(st.tuples(st.integers(0, 39), st.integers(0, 39),
                          st.sampled_from([1.0, -0.0, 0.25, 7.0])), max_size=6))
def test_nonzero_box_is_the_box_of_the_nonzero_bits(rows, cols, dtype, marks):
    array = np.zeros((rows, cols), np.dtype(dtype))
    for r, c, v in marks:
        array[r % rows, c % cols] = v if array.dtype.kind == "f" else abs(v)
    bits = array.view(np.dtype(f"u{array.itemsize}"))
    hit_rows, hit_cols = np.nonzero(bits)
    expected = None if not hit_rows.size else (hit_rows.min(), hit_rows.max() + 1,
                                                hit_cols.min(), hit_cols.max() + 1)
    assert nonzero_box(array) == expected


@settings(max_examples=25, deadline=None)
@given(st.integers(600, 900), st.integers(500, 700), st.sampled_from(["<f4", "<f8"]),
       st.integers(0, 2**31))
def test_pages_travel_as_their_box_and_come_back_bit_for_bit(rows, cols, dtype, seed):
    rng = np.random.default_rng(seed)
    page = np.zeros((rows, cols), np.dtype(dtype))  # >= 1 MiB: sent as its box
    r0, c0 = rng.integers(0, rows - 50), rng.integers(0, cols - 40)
    page[r0:r0 + 50, c0:c0 + 40] = rng.random((50, 40))
    page[r0 + 3, c0 + 5] = -0.0  # a sign bit alone is kept too
    small = rng.random((3, 4))  # below PAGE_BYTES: pickled as it is
    item = {"page": page, "blank": np.zeros_like(page), "small": small, "same": page}
    packed = pack(item)
    assert len(packed) < 50 * 40 * page.itemsize + small.nbytes + 2000
    back = pickle.loads(packed)
    assert back["page"].dtype == page.dtype and back["page"].shape == page.shape
    assert back["page"].tobytes() == page.tobytes()
    assert not back["blank"].any() and back["blank"].shape == page.shape
    assert np.array_equal(back["small"], small)
    assert back["same"] is back["page"]  # one array, not two copies
    back["page"][0, 0] = 1.0  # writable, as the canvas needs


# -- streams of shares --------------------------------------------------------------------------

def numbered(first: int, count: int, progress=None):
    for k in range(count):
        if progress is not None:
            progress((k + 1) / count, f"share {first}")
        yield first + k, os.getpid()


def broken(message: str | None, progress=None):
    yield 1
    if message:
        raise InputError(message, key="share")


def dying(code: int, progress=None):
    if code:
        os._exit(code)
    yield from ()


class Unpicklable(Exception):
    def __init__(self, a, b):  # pickling rebuilds it with one argument: it cannot come back
        super().__init__(a)


def unpicklable(fail: bool, progress=None):
    if fail:
        raise Unpicklable("odd", 2)
    yield from ()


@pytest.mark.parametrize("here", [True, False])
def test_shares_stream_in_order_from_kept_workers(here):
    reports = []
    items = list(stream_shares(numbered, [(0, 3), (100, 5), (200, 1)],
                               lambda f, phase: reports.append(f), here=here))
    assert [k for k, _ in items] == [0, 1, 2, 100, 101, 102, 103, 104, 200]
    pid_of = dict(items)
    pids = [pid_of[0], pid_of[100], pid_of[200]]
    assert len(set(pids)) == 3 and os.getpid() not in pids[1:]
    assert (pids[0] == os.getpid()) == here  # share 0 in this process
    assert reports == sorted(reports) and reports[-1] == 1.0  # the slowest share's, never back
    again = dict(stream_shares(numbered, [(0, 1), (100, 1), (200, 1)], here=here))
    assert [again[100], again[200]] == pids[1:]  # kept: a sweep starts its workers once


def test_an_error_in_a_worker_is_raised_here_and_the_workers_end():
    with pytest.raises(InputError, match="share broke") as err:
        list(stream_shares(broken, [(None,), ("share broke",)]))
    assert err.value.key == "share"
    assert workers_alive() == []
    with pytest.raises(InkarmError, match="(?s)an ensemble worker failed:.*Unpicklable"):
        list(stream_shares(unpicklable, [(False,), (True,)]))


def test_a_worker_that_dies_is_named():
    with pytest.raises(InkarmError, match=r"ensemble worker \d \(pid \d+\) ended with exit "
                                          r"code 7; the ensemble is lost"):
        list(stream_shares(dying, [(0,), (7,)]))
    assert workers_alive() == []


def collecting(progress=None):
    gc.collect()  # whatever the worker inherited and could collect, it collects now
    yield os.getpid()


@pytest.mark.sim
def test_a_threaded_batch_left_to_the_collector_here_does_not_kill_a_worker(risky):
    from inkarm.sim.batch import BatchPlant, member_model
    from inkarm.sim.cell import Cell
    from inkarm.sim.imperfections import PlantTruth

    cell = Cell(risky.cell, risky.robot)
    gc.disable()  # the batch stays uncollected garbage until the worker collects it
    try:
        plant = BatchPlant([member_model(cell, PlantTruth())] * 2, cell, PlantTruth(), [0, 1],
                           nthread=2)
        cycle = {"plant": plant}
        cycle["cycle"] = cycle
        del plant, cycle
        ensemble_workers.shutdown_workers()  # forked now, with the garbage
        (_, worker) = list(stream_shares(collecting, [(), ()]))
    finally:
        gc.enable()
    assert worker != os.getpid()


def test_a_caller_that_stops_ends_the_workers():
    items = stream_shares(numbered, [(0, 2), (10, 2), (20, 2)])
    assert next(items)[0] == 0
    assert len(workers_alive()) >= 2
    items.close()
    assert workers_alive() == []


# -- ensembles in shares ------------------------------------------------------------------------

@pytest.fixture(scope="module")
def risky():
    return load_scenario("scenarios/quick_stroke.toml").with_overrides(RISKY)


@pytest.mark.sim
def test_shares_in_workers_equal_one_batch_here(risky):
    seeds = [9, 0, 3]
    here = run_ensemble(risky, seeds, processes=1)
    reports = []
    shared = list(iter_ensemble(risky, seeds, processes=2,
                                progress=lambda f, phase: reports.append((f, phase))))
    assert [r.scenario.plant.seed for r in shared] == seeds
    assert [r.status for r in shared] == ["failed", "ok", "failed"]
    for a, b in zip(shared, here):
        assert (a.status, a.reason, a.notes) == (b.status, b.reason, b.notes)
        for column in ("time", "q", "qd", "torque", "tip", "force", "phase", "reference"):
            assert np.array_equal(getattr(a.log, column), getattr(b.log, column)), column
        assert a.canvas.image.tobytes() == b.canvas.image.tobytes()
        assert a.canvas.n_strokes == b.canvas.n_strokes
        assert {k: v for k, v in a.metrics.items() if k != "realtime_factor"} == \
            {k: v for k, v in b.metrics.items() if k != "realtime_factor"}
    # the pages are live canvases: drawing on one goes on as on the original
    for canvas in (shared[1].canvas, here[1].canvas):
        canvas.touch((20.0, 20.0), 1.0, 0.0)
        canvas.touch((30.0, 20.0), 1.0, 0.01)
        canvas.lift()
    assert shared[1].canvas.image.tobytes() == here[1].canvas.image.tobytes()
    fractions = [f for f, _ in reports]
    assert len(reports) > 10 and fractions == sorted(fractions) and fractions[-1] == 1.0
    # (the phase is the slowest share's at each report: which share that is depends on timing)
    assert "descend" in {phase for _, phase in reports} and \
        {phase for _, phase in reports} <= set(PHASES)


def seed_status_ink(run):
    return run.scenario.plant.seed, run.status, run.metrics.get("ink_chamfer_mm"), os.getpid()


@pytest.mark.sim
def test_keep_is_computed_in_the_workers_and_only_it_comes_back(risky):
    seeds = [9, 0, 3, 4]
    here = [seed_status_ink(r)[:3] for r in run_ensemble(risky, seeds, processes=1)]
    kept = run_ensemble(risky, seeds, processes=2, keep=seed_status_ink)
    assert [k[:3] for k in kept] == here
    assert os.getpid() not in {k[3] for k in kept}  # every share in a worker


def test_keep_that_cannot_reach_the_workers_is_refused(risky):
    with pytest.raises(InputError, match="keep must be a module-level function") as err:
        run_ensemble(risky, [0, 1], keep=lambda run: run.status)
    assert err.value.key == "keep"


@pytest.mark.sim
def test_ctrl_c_stops_every_share_and_ends_the_workers(risky):
    def interrupt(fraction, phase):
        if fraction > 0.2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_ensemble(risky, [0, 1, 2, 4], processes=2, progress=interrupt)
    assert workers_alive() == []
    after = run_ensemble(risky, [0, 9], processes=2)  # new workers
    assert [r.status for r in after] == ["ok", "failed"]


def ensemble_in(scenario, answer):
    answer.send([r.status for r in run_ensemble(scenario, [0, 9], processes=2)])


@pytest.mark.sim
def test_a_daemonic_process_draws_its_ensemble_itself(risky):
    context = multiprocessing.get_context("fork")
    receive, send = context.Pipe(duplex=False)
    daemon = context.Process(target=ensemble_in, args=(risky, send), daemon=True)
    gc.freeze()  # (see ensemble_workers: a fork must not collect this process's batches)
    try:
        daemon.start()
    finally:
        gc.unfreeze()
    assert receive.recv() == ["ok", "failed"]  # not "daemonic processes may not have children"
    daemon.join()
    assert daemon.exitcode == 0


@pytest.mark.parametrize("kwargs, key", [({"processes": -1}, "processes"),
                                         ({"nthread": -2}, "nthread")])
def test_negative_counts_are_refused(risky, kwargs, key):
    with pytest.raises(InputError, match="count CPUs") as err:
        run_ensemble(risky, [0, 1], **kwargs)
    assert err.value.key == key


def teardown_module():
    ensemble_workers.shutdown_workers()
