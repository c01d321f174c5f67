"""Sweeps: one scenario run over a design of overrides, on a process pool or a Ray cluster.

:func:`run_sweep` runs the points of a design (:mod:`inkarm.jobs.sweep.design`) that the
output folder has not finished yet, writes each run's row as it finishes
(:mod:`inkarm.jobs.sweep.table`) and its ink crop (``ink/<point id>.npz``), and compacts the
table at the end or on an interruption; running it again resumes. A run that fails, or whose
overrides the run refuses, is a row with its status and reason, never a crash of the sweep.

Executors: "process", a local :class:`concurrent.futures.ProcessPoolExecutor` in the
"forkserver" context (MuJoCo's state and threads do not survive a fork of a process that has
used them; Ctrl-C is the parent's alone, workers ignore it), or "ray", tasks on a Ray cluster
(``ray.init(address)``: a running cluster, or a local one when no address is given and none
is running; one already initialised by the caller is used as it is). Each run is the pure
:func:`inkarm.jobs.run.run`, so both give the same rows, bit for bit, except the wall-clock
columns (``wall_s``, ``realtime_factor``).
"""

from __future__ import annotations

import hashlib
import itertools
import json
import multiprocessing
import signal
import time
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from inkarm.errors import InkarmError, InputError, SimulationError
from inkarm.io.outputs import atomic_file
from inkarm.jobs.ensemble.workers import available_cpus
from inkarm.jobs.outputs import strict_json
from inkarm.jobs.scenario import Scenario
from inkarm.jobs.sweep.design import Point, with_point
from inkarm.jobs.sweep.table import DIGEST_COLUMN, PARTS_DIR, compact, finished_ids, write_part

MANIFEST = "sweep.json"
INK_DIR = "ink"
FIGURES_DIR = "figures"
EXECUTORS = ("process", "ray")
TIMING_COLUMNS = ("wall_s", "realtime_factor")  # the machine's, not the run's
IN_FLIGHT_PER_WORKER = 4  # tasks handed to the process pool ahead of its workers
RAY_IN_FLIGHT = 1000  # tasks submitted to Ray ahead of the results


@dataclass(frozen=True)
class PointResult:
    """A finished point: its table row and its ink (pixel box (r0, r1, c0, c1) and 8-bit grey
    crop of the page, None without ink), with the page's rows and resolution [px/mm]."""

    row: dict
    box: tuple[int, int, int, int] | None
    grey: np.ndarray | None
    page_rows: int
    px_per_mm: float


@dataclass
class SweepSummary:
    """What :func:`run_sweep` did: points in the design, skipped (finished before), the ids
    it ran now, how many of them failed, and whether it was interrupted."""

    total: int
    skipped: int
    ran: list[str] = field(default_factory=list)
    failed: int = 0
    interrupted: bool = False


def failed_row(point: Point, reason: str = "") -> dict:
    """``point``'s table row before (or without) a run: failed, with ``reason``."""
    return {"point_id": point.point_id, "index": point.index, "seed": point.seed,
            **point.params, "status": "failed", "reason": reason}


def run_point(scenario: Scenario, point: Point) -> PointResult:
    """Run ``scenario`` with ``point``'s overrides and seed; every failure becomes the row's
    status and reason."""
    from inkarm.analysis.metrics import ink_box
    from inkarm.jobs.regress.baseline import library_versions, page_grey
    from inkarm.jobs.regress.ink import ink_mask
    from inkarm.jobs.run import run

    start = time.perf_counter()
    row = failed_row(point)
    box = grey = None
    rows, px_per_mm = 0, 0.0
    try:
        result = run(with_point(scenario, point.overrides()))
        row["status"], row["reason"] = result.status, result.reason
        row.update({k: float(v) for k, v in result.metrics.items()})
        if result.log is not None and len(result.log.time):
            row["sim_s"] = float(result.log.time[-1] - result.log.time[0])
        page = page_grey(result)
        rows, px_per_mm = page.shape[0], result.canvas.px_per_mm
        box = ink_box(ink_mask(page), True)
        if box is not None:
            grey = page[box[0]:box[1], box[2]:box[3]].copy()
    except InkarmError as e:
        row["reason"] = str(e)
    except Exception as e:  # noqa: BLE001 -- a bug in one run is its row, not the sweep
        row["reason"] = f"{type(e).__name__}: {e}"
    row["wall_s"] = time.perf_counter() - start
    row.update({f"version_{k}": v for k, v in library_versions().items()})
    return PointResult(row, box, grey, rows, px_per_mm)


def scenario_digest(scenario: Scenario) -> str:
    """A digest of what the scenario draws (its tables), to tell a resumed sweep's scenario
    from another."""
    text = json.dumps(scenario.to_dict(), sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def check_manifest(out: Path, scenario: Scenario, digest: str) -> None:
    """Write ``sweep.json`` in a new sweep folder; in an existing one, refuse a different
    scenario (its rows would be mixed with this one's); ``digest``: the scenario's
    (:func:`scenario_digest`)."""
    manifest = out / MANIFEST
    if manifest.is_file():
        try:
            old = json.loads(manifest.read_text()).get("scenario_digest")
        except ValueError:
            old = None
        if old != digest:
            raise InputError(f"{out} holds a sweep of another scenario (or of this one before "
                             f"it changed: digest {old}, now {digest}); choose another folder",
                             key="--out", value=str(out))
        return
    out.mkdir(parents=True, exist_ok=True)
    with atomic_file(manifest) as partial:
        partial.write_text(strict_json({"scenario": scenario.path, "title": scenario.title,
                                        "scenario_digest": digest}))


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def process_results(scenario: Scenario, points: list[Point],
                    workers: int) -> Iterator[PointResult]:
    """Run ``points`` on a local process pool; yield results as they finish."""
    if "forkserver" in multiprocessing.get_all_start_methods():
        context = multiprocessing.get_context("forkserver")
        # the server imports inkarm once (no MuJoCo model, no thread yet), the workers fork it
        context.set_forkserver_preload(["inkarm.jobs.sweep", "inkarm.jobs.run"])
    else:
        context = multiprocessing.get_context("spawn")
    pool = ProcessPoolExecutor(max_workers=workers, initializer=_ignore_sigint,
                               mp_context=context)
    queue = iter(points)
    pending: set = set()
    try:
        while True:
            # a few tasks per worker in flight: a long sweep never holds every task at once
            for p in itertools.islice(queue, max(0, IN_FLIGHT_PER_WORKER * workers - len(pending))):
                pending.add(pool.submit(run_point, scenario, p))
            if not pending:
                break
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                try:
                    yield future.result()
                except BrokenProcessPool as e:
                    raise SimulationError(f"a worker process died ({e}); the finished runs "
                                          "are kept: run the sweep again to resume") from None
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def ray_results(scenario: Scenario, points: list[Point],
                address: str | None) -> Iterator[PointResult]:
    """Run ``points`` as Ray tasks; yield results as they finish."""
    try:
        import ray
    except ImportError:
        raise InputError("Ray is not installed: pip install 'inkarm[ray]'",
                         key="--ray") from None
    started = not ray.is_initialized()
    if started:
        options = {"address": address} if address else {"include_dashboard": False}
        ray.init(log_to_driver=False, **options)
    pending: dict = {}
    try:
        task = ray.remote(num_cpus=1, max_retries=0)(run_point)
        shared = ray.put(scenario)
        queue = iter(points)
        while True:
            room = max(0, RAY_IN_FLIGHT - len(pending))
            pending.update({task.remote(shared, p): p for p in itertools.islice(queue, room)})
            if not pending:
                break
            ready, _ = ray.wait(list(pending), num_returns=1)
            for ref in ready:
                point = pending.pop(ref)
                try:
                    yield ray.get(ref)
                except ray.exceptions.RayError as e:  # the worker died, not the run
                    yield PointResult(failed_row(point, f"ray: {type(e).__name__}: {e}"),
                                      None, None, 0, 0.0)
    finally:
        for ref in pending:
            ray.cancel(ref)
        if started:
            ray.shutdown()


def run_sweep(scenario: Scenario, points: list[Point], out_dir: str | Path, *,
              executor: str = "process", workers: int | None = None,
              ray_address: str | None = None,
              progress: Callable[[int, int, int], None] | None = None) -> SweepSummary:
    """Run the ``points`` of ``scenario`` not yet finished in ``out_dir`` (see the module
    docstring); ``progress(done, total, failed)`` after each finished run. A KeyboardInterrupt
    (Ctrl-C, or raised by ``progress``) stops the sweep with the finished rows compacted into
    the table, and propagates."""
    if executor not in EXECUTORS:
        raise InputError(f"unknown executor {executor!r}; expected one of {EXECUTORS}",
                         key="executor", value=executor, choices=EXECUTORS)
    out = Path(out_dir)
    digest = scenario_digest(scenario)
    done = finished_ids(out, digest)  # before the manifest: a refused folder stays as it was
    new_folder = not (out / MANIFEST).exists()
    check_manifest(out, scenario, digest)
    todo = [p for p in points if p.point_id not in done]
    summary = SweepSummary(total=len(points), skipped=len(points) - len(todo))
    if workers is None:
        workers = available_cpus()
    results = (ray_results(scenario, todo, ray_address) if executor == "ray"
               else process_results(scenario, todo, max(1, min(workers, len(todo)))))
    if progress is not None:
        progress(summary.skipped, summary.total, 0)
    try:
        if todo:
            for result in results:
                save_result(out, result, digest)
                summary.ran.append(result.row["point_id"])
                summary.failed += result.row["status"] != "ok"
                if progress is not None:
                    progress(summary.skipped + len(summary.ran), summary.total, summary.failed)
    except KeyboardInterrupt:
        summary.interrupted = True
        raise
    finally:
        if todo:
            results.close()
        try:
            compact(out)
        finally:
            if new_folder and not summary.ran:  # nothing of this sweep was kept (a full disk,
                _remove_sweep_folder(out)       # an error, Ctrl-C before a run): no trace left
    return summary


def _remove_sweep_folder(out: Path) -> None:
    """Remove what a sweep that kept no row made in its new folder ``out``: the manifest, ink
    crops of runs whose row was never written, and the folders once empty (anything else a
    user put there is left)."""
    (out / MANIFEST).unlink(missing_ok=True)
    for crop in (out / INK_DIR).glob("*.npz"):
        crop.unlink(missing_ok=True)
    for folder in (out / PARTS_DIR, out / INK_DIR, out):
        try:
            folder.rmdir()
        except OSError:
            pass


def save_result(out: Path, result: PointResult, digest: str) -> None:
    """The run's ink crop, then its row with the scenario's ``digest`` (the row marks the
    point finished)."""
    if result.grey is not None:
        ink = out / INK_DIR
        ink.mkdir(exist_ok=True)
        np.savez_compressed(ink / f"{result.row['point_id']}.npz", box=np.array(result.box),
                            grey=result.grey, page_rows=result.page_rows,
                            px_per_mm=result.px_per_mm)
    write_part(out, {**result.row, DIGEST_COLUMN: digest})


def write_figures(out_dir: str | Path, keys: list[str], metrics: list[str]) -> list[Path]:
    """Figures of the compacted table in ``out_dir/figures``: each metric against each swept
    key (lines; grouped by the other key when there are two) and, for two keys, a heat map;
    and ``ink_overlay.png``, the ink of every finished run. Returns the files written."""
    from inkarm.jobs.sweep.table import read_results
    from inkarm.plots.figure import save_figure
    from inkarm.plots.sweep import plot_ink_overlay, plot_metric_heatmap, plot_metric_lines

    out = Path(out_dir)
    table = read_results(out)
    folder = out / FIGURES_DIR
    folder.mkdir(exist_ok=True)
    written = []
    data = {name: table.column(name).to_pylist() for name in table.column_names}
    for metric in [m for m in metrics if m in data]:
        for key in keys:
            others = [k for k in keys if k != key]
            group = data[others[0]] if len(keys) == 2 else None
            fig = plot_metric_lines(data[key], data[metric], group=group, xlabel=key,
                                    ylabel=metric, group_label=others[0] if group else "")
            written.append(save_figure(fig, folder / f"{metric}_vs_{key}.png", dpi=110))
        if len(keys) == 2:
            fig = plot_metric_heatmap(data[keys[0]], data[keys[1]], data[metric],
                                      xlabel=keys[0], ylabel=keys[1], zlabel=metric)
            written.append(save_figure(fig, folder / f"{metric}_map.png", dpi=110))
    crops, page_rows, px_per_mm = [], 0, 0.0
    for point_id in data.get("point_id", []):
        file = out / INK_DIR / f"{point_id}.npz"
        if file.is_file():
            with np.load(file) as ink:
                crops.append((tuple(int(v) for v in ink["box"]), ink["grey"]))
                page_rows, px_per_mm = int(ink["page_rows"]), float(ink["px_per_mm"])
    if crops:
        fig = plot_ink_overlay(crops, page_rows, px_per_mm)
        written.append(save_figure(fig, folder / "ink_overlay.png", dpi=110))
    return written
