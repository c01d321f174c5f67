"""Persistent worker processes that run the shares of a batched ensemble at once, one per CPU,
and stream their items back in order: :func:`stream_shares`.

Why processes: a batched ensemble's controller and its per-member work (inking a page, the
metrics) are Python on one core, while only MuJoCo's steps use threads. Splitting the members
into one share per CPU, each share a whole batch (:class:`inkarm.sim.batch.BatchPlant`) in its
own process, puts every core to work on every part. The members of a share are the same runs
as in one big batch (a member's simulation does not depend on the others).

Why persistent and forked: a process that starts Python and imports MuJoCo costs about a second,
what a share of a small ensemble costs. The first share runs in this process (``here``: it
would wait otherwise, and its items need not travel); the others' workers are forked from this
process (the modules already imported; a few milliseconds each) when first needed and kept,
each waiting for its next share, so a sweep of several ensembles starts them once
(:func:`shutdown_workers` ends them; they are daemons, ended with this process too). A worker
tells its malloc to keep what it frees (each member allocates the pages of ink the previous one
freed: no page faults). The fork freezes what the worker inherits
(``gc.freeze``): it never collects an object of this process, such as a batch whose threads
it does not have. Where fork is not the platform's way, they are started by a forkserver that
has imported the ensemble's modules once.

What travels back: each item pickled, with every 2-D array of at least :data:`PAGE_BYTES` (the
canvas's page rasters) sent as its non-zero box only and rebuilt on zeroed pages (bit for bit;
a page of ink is mostly blank, so a member costs kilobytes of pipe, not 75 MB).

Errors: an :class:`inkarm.errors.InkarmError` raised in a worker is raised here, as it was; a
worker that dies (killed, out of memory) raises :class:`inkarm.errors.InkarmError` naming it.
Ctrl-C (or a caller that stops iterating, or any error) ends the workers of the interrupted
ensemble (the next one forks new ones): no worker goes on drawing for nobody.
"""

from __future__ import annotations

import atexit
import ctypes
import gc
import io
import itertools
import mmap
import multiprocessing
import os
import pickle
import queue
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterator
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from inkarm.errors import InkarmError

PAGE_BYTES = 1 << 20  # 2-D arrays this large travel as their non-zero box [bytes]
_POLL_S = 0.5  # how often a waiting parent checks that its workers are alive [s]
_PRELOAD = ["inkarm.jobs.ensemble", "mujoco", "numpy"]


def available_cpus() -> int:
    """The CPUs this process may run on."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def may_start_workers() -> bool:
    """Whether this process may have worker processes (a daemonic one, such as a pool's
    worker, may not)."""
    return not multiprocessing.current_process().daemon


# -- packing: pages as their non-zero boxes -----------------------------------------------------

def _rebuilt(shape: tuple[int, int], dtype: str, box: tuple[int, int, int, int] | None,
             crop: np.ndarray | None) -> np.ndarray:
    # On an anonymous map, not np.zeros: its pages are zeroed by the kernel when first touched
    # (a page of ink is mostly blank), where malloc may hand back a freed page it must clear.
    dtype_ = np.dtype(dtype)
    pages = mmap.mmap(-1, max(1, shape[0] * shape[1] * dtype_.itemsize))
    out = np.frombuffer(pages, dtype_, shape[0] * shape[1]).reshape(shape)
    if box is not None:
        r0, r1, c0, c1 = box
        out[r0:r1, c0:c1] = crop
    return out


def nonzero_box(array: np.ndarray) -> tuple[int, int, int, int] | None:
    """(r0, r1, c0, c1), half-open, of the elements of the 2-D ``array`` whose bits are not
    all zero (so -0.0 counts as ink: the box keeps every bit); None when all are zero."""
    bits = array.view(np.dtype(f"u{array.itemsize}"))
    rows = np.flatnonzero(bits.any(axis=1))
    if rows.size == 0:
        return None
    r0, r1 = int(rows[0]), int(rows[-1]) + 1
    cols = np.flatnonzero(bits[r0:r1].any(axis=0))
    return r0, r1, int(cols[0]), int(cols[-1]) + 1


class _Packer(pickle.Pickler):
    def reducer_override(self, obj: Any) -> Any:
        if (type(obj) is np.ndarray and obj.ndim == 2 and obj.nbytes >= PAGE_BYTES
                and obj.flags.c_contiguous and obj.dtype.kind in "biuf"
                and obj.dtype.itemsize in (1, 2, 4, 8)):
            box = nonzero_box(obj)
            crop = None if box is None else obj[box[0]:box[1], box[2]:box[3]].copy()
            return _rebuilt, (obj.shape, obj.dtype.str, box, crop)
        return NotImplemented


def pack(item: Any) -> bytes:
    """``item`` pickled, its large 2-D arrays as their non-zero boxes (:func:`pickle.loads`
    restores it, bit for bit)."""
    buffer = io.BytesIO()
    _Packer(buffer, protocol=pickle.HIGHEST_PROTOCOL).dump(item)
    return buffer.getvalue()


# -- the worker ---------------------------------------------------------------------------------

def _keep_freed_memory() -> None:
    """Let this worker's malloc keep (not unmap) what it frees: every member allocates pages of
    ink that the previous member just freed, and fresh pages from the kernel cost a page fault
    each (measured: 12-17 ms against 4.5 ms for an A4 canvas at 10 px/mm)."""
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL("libc.so.6")
    except OSError:  # not glibc
        return
    m_trim_threshold, m_mmap_threshold = -1, -3
    libc.mallopt(m_trim_threshold, 1 << 30)
    libc.mallopt(m_mmap_threshold, 1 << 28)


def _portable(error: BaseException) -> BaseException:
    """``error`` if it survives pickling, else an InkarmError carrying its traceback."""
    try:
        pickle.loads(pickle.dumps(error))
        return error
    except Exception:  # noqa: BLE001 - whatever stops it pickling, send the text
        text = "".join(traceback.format_exception(error)).rstrip()
        return InkarmError(f"an ensemble worker failed:\n{text}")


def _serve(tasks: Connection, results) -> None:
    """A worker's life: run each share it is sent, putting ("item", share, index, bytes) per
    item, ("progress", share, (fraction, phase)), then ("done", share, (count, pid, CPU [s]
    of the worker so far)) or ("error", share, exception), each tagged with the ensemble's
    id."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides what Ctrl-C ends
    _keep_freed_memory()
    pid = os.getpid()
    while True:
        try:
            task = tasks.recv()
        except (EOFError, OSError):
            return
        if task is None:
            return
        ident, share, work, args, reports = task

        def progress(fraction: float, phase: str, share=share, ident=ident) -> None:
            results.put((ident, "progress", share, (fraction, phase)))

        count = 0
        try:
            items = work(*args, progress=progress if reports else None)
            for count, item in enumerate(items, start=1):
                results.put((ident, "item", share, (count - 1, pack(item))))
        except BaseException as error:  # noqa: BLE001 - every failure goes back to the parent
            results.put((ident, "error", share, _portable(error)))
            continue
        results.put((ident, "done", share, (count, pid, time.process_time())))


# -- the pool -----------------------------------------------------------------------------------

class _Workers:
    """Worker processes of one start method, their task pipes and their shared result queue."""

    def __init__(self, size: int):
        methods = multiprocessing.get_all_start_methods()
        method = "fork" if sys.platform.startswith("linux") and "fork" in methods else \
            "forkserver" if "forkserver" in methods else "spawn"
        context = multiprocessing.get_context(method)
        if method == "forkserver":
            context.set_forkserver_preload(_PRELOAD)
        self.results = context.Queue()
        self.processes, self.tasks = [], []
        for _ in range(size):
            receive, send = context.Pipe(duplex=False)
            process = context.Process(target=_serve, args=(receive, self.results), daemon=True,
                                      name="inkarm-ensemble-worker")
            # A forked worker must never collect what it inherited: a batch of this process's
            # (its threads not forked) would join threads that do not exist there and abort.
            gc.freeze()
            try:
                process.start()
            finally:
                gc.unfreeze()
            receive.close()
            self.processes.append(process)
            self.tasks.append(send)

    @property
    def size(self) -> int:
        return len(self.processes)

    def dead(self) -> str | None:
        """A sentence naming a worker that has ended, or None."""
        for k, p in enumerate(self.processes):
            if not p.is_alive():
                return (f"ensemble worker {k} (pid {p.pid}) ended with exit code "
                        f"{p.exitcode}{' (killed: out of memory?)' if p.exitcode == -9 else ''}")
        return None

    def close(self, now: bool = False) -> None:
        """End the workers: asked to finish (or terminated at once, ``now``)."""
        for send in self.tasks:
            if not now:
                try:
                    send.send(None)
                except OSError:
                    pass
            send.close()
        for p in self.processes:
            if now:
                p.terminate()
            p.join(timeout=5.0)
            if p.is_alive():
                p.kill()
                p.join()
        self.results.close()
        self.results.cancel_join_thread()


_lock = threading.Lock()
_pool: _Workers | None = None  # the kept workers
_busy = False  # whether an ensemble is using them
_ids = itertools.count()
_cpu_by_pid: dict[int, float] = {}  # each worker's CPU time [s] when it last finished a share


def _take(size: int) -> tuple[_Workers, bool]:
    """Workers for one ensemble, at least ``size`` of them, and whether they are the kept ones
    (else a private pool, for an ensemble that starts while another is being iterated)."""
    global _pool, _busy
    with _lock:
        if not _busy:
            if _pool is not None and (_pool.size < size or _pool.dead()):
                _pool.close(now=True)
                _pool = None
            if _pool is None:
                _pool = _Workers(size)
            _busy = True
            return _pool, True
    return _Workers(size), False


def _give_back(pool: _Workers, kept: bool, finished: bool) -> None:
    global _pool, _busy
    if not kept:
        pool.close(now=not finished)
        return
    with _lock:
        if not finished:  # Ctrl-C, an error, or a caller that stopped: end the workers
            pool.close(now=True)
            _pool = None
        _busy = False


def shutdown_workers() -> None:
    """End the kept workers (the next ensemble starts new ones)."""
    global _pool
    with _lock:
        if _pool is not None and not _busy:
            _pool.close()
            _pool = None


atexit.register(shutdown_workers)


def worker_cpu_seconds() -> float:
    """CPU time [s] of every worker this process started (all threads, from its fork), as
    of the last share each finished (a kept worker is not a child that ended, so
    ``getrusage(RUSAGE_CHILDREN)`` does not count it)."""
    return sum(_cpu_by_pid.values())


def stream_shares(work: Callable[..., Iterator], shares: list[tuple],
                  progress: Callable[[float, str], None] | None = None,
                  here: bool = True) -> Iterator:
    """Run ``work(*share, progress=...)`` for every share at once, share 0 in this process
    (``here``; else in a worker too) and each other in its own worker process; yield the items
    of share 0 in order, then those of share 1, and so on. ``work`` is a module-level generator
    function (sent by reference). This process's share is iterated as its items are asked for,
    so what it does per item (a member's inking) runs while the workers go on.

    ``progress(fraction, phase)`` gets the fraction of the share furthest behind (so it never
    goes back), with that share's phase."""
    first = 1 if here else 0
    if len(shares) == first:
        yield from work(*shares[0], progress=progress)
        return
    pool, kept = _take(len(shares) - first)
    finished = False
    try:
        ident = next(_ids)
        for share in range(first, len(shares)):
            pool.tasks[share - first].send((ident, share, work, shares[share],
                                            progress is not None))
        inbox = _Inbox(pool, ident, len(shares), progress)
        if here:
            def report(fraction: float, phase: str) -> None:
                inbox.report(0, fraction, phase)
                inbox.drain()

            yield from work(*shares[0], progress=report if progress is not None else None)
        yield from inbox.items(first)
        finished = True
    finally:
        _give_back(pool, kept, finished)


class _Inbox:
    """What the workers of one ensemble sent: items waiting to be yielded, shares done, the
    progress of each share."""

    def __init__(self, pool: _Workers, ident: int, n_shares: int,
                 progress: Callable[[float, str], None] | None):
        self.pool, self.ident, self.progress = pool, ident, progress
        self.waiting: dict[tuple[int, int], bytes] = {}
        self.counts: dict[int, int] = {}
        self.fractions = [0.0] * n_shares
        self.phases = [""] * n_shares
        self.reported = -1.0

    def report(self, share: int, fraction: float, phase: str) -> None:
        self.fractions[share], self.phases[share] = fraction, phase
        if self.progress is None:
            return
        slowest = int(np.argmin(self.fractions))
        if self.fractions[slowest] > self.reported:
            self.reported = self.fractions[slowest]
            self.progress(self.reported, self.phases[slowest] or phase)

    def drain(self) -> None:
        """Take every message already sent, without waiting."""
        while self.receive(timeout=0.0):
            pass

    def receive(self, timeout: float) -> bool:
        """Take one message (waiting up to ``timeout`` [s]); False when none came. Raises a
        worker's error, or names a worker that died."""
        try:
            tag, kind, origin, payload = self.pool.results.get(timeout=timeout) if timeout \
                else self.pool.results.get_nowait()
        except queue.Empty:
            dead = self.pool.dead()
            if dead:
                raise InkarmError(f"{dead}; the ensemble is lost") from None
            return False
        if tag != self.ident:
            return True
        if kind == "item":
            self.waiting[(origin, payload[0])] = payload[1]
        elif kind == "done":
            self.counts[origin], pid, _cpu_by_pid[pid] = payload
        elif kind == "error":
            raise payload
        elif kind == "progress":
            self.report(origin, *payload)
        return True

    def items(self, share: int) -> Iterator:
        """The items of the workers' shares from ``share`` on, in order."""
        index = 0
        while share < len(self.fractions):
            if (share, index) in self.waiting:
                yield pickle.loads(self.waiting.pop((share, index)))
                index += 1
            elif self.counts.get(share) == index:
                share, index = share + 1, 0
            else:
                self.receive(timeout=_POLL_S)


__all__ = ["PAGE_BYTES", "available_cpus", "may_start_workers", "nonzero_box", "pack", "shutdown_workers",
           "stream_shares", "worker_cpu_seconds"]
