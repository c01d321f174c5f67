"""Alternating blocks: time a subject and its reference in turns, so that load hits both alike.

A benchmark that times all of its subject and then all of its reference measures the load of two
different minutes. Here the cases run in blocks, ``A A A, B B B, A A A, B B B, ...`` (``repeats``
calls to a block, ``blocks`` blocks to a case); a block's time is the median of its calls, a
case's time the median of its blocks, and a ratio is the quotient of two such medians:

    t_block = median(t_1 .. t_repeats),   t_case = median(t_block,1 .. t_block,blocks),
    ratio   = t_subject / t_reference.

One burst of load then spoils one block of one case, not the ratio. The load average
(``os.getloadavg()``, 1 minute) is read before the first block and after the last, for the line
printed beside each table::

    result = interleave({"inkarm": run, "reference": baseline}, blocks=5, repeats=3)
    print(result.ratio("inkarm", "reference"))     # median over median, dimensionless
    print(result.load_line())    # "Load average (1 min) 1.9 before, 2.3 after, on 2 cores."

``clock`` times each call (default ``time.perf_counter``, wall [s]; pass ``time.process_time``
for this process's CPU). With ``clock=None`` each call returns its own duration [s], for cases
that time a child process or exclude their set-up; ``timed(fn)`` makes a plain callable such a
case.
"""

from __future__ import annotations

import os
import statistics
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass


def load_average() -> float:
    """The 1-minute load average of the machine (``os.getloadavg()[0]``)."""
    return os.getloadavg()[0]


def load_line(before: float, after: float | None = None) -> str:
    """One markdown sentence: the load average before and after a measurement, and the cores."""
    after = load_average() if after is None else after
    return (f"Load average (1 min) {before:.1f} before, {after:.1f} after, "
            f"on {os.cpu_count()} cores.")


@dataclass(frozen=True)
class Blocks:
    """Per case, the median of each block [s], in the order run; the load around them."""

    times: dict[str, list[float]]
    load_before: float
    load_after: float

    def median(self, name: str) -> float:
        """The median of the case's block medians [s]."""
        return statistics.median(self.times[name])

    def ratio(self, subject: str, reference: str) -> float:
        """median(subject) / median(reference); > 1 means the subject takes longer."""
        return self.median(subject) / self.median(reference)

    def spread(self, name: str) -> float:
        """Slowest block over fastest block of a case (1.0 = steady)."""
        return max(self.times[name]) / min(self.times[name])

    def load_line(self) -> str:
        """The load average before the first and after the last block, one sentence."""
        return load_line(self.load_before, self.load_after)


def timed(fn: Callable[[], object], clock: Callable[[], float] = time.perf_counter,
          ) -> Callable[[], float]:
    """``fn`` as a case that returns its own duration [s] (to mix with such cases)."""
    def case() -> float:
        start = clock()
        fn()
        return clock() - start
    return case


def _call(fn: Callable[[], object], clock: Callable[[], float] | None) -> float:
    return float(fn()) if clock is None else timed(fn, clock)()  # type: ignore[arg-type]


def interleave(cases: Mapping[str, Callable[[], object]], *, blocks: int = 5,
               repeats: int | Mapping[str, int] = 3, warmup: int = 1,
               clock: Callable[[], float] | None = time.perf_counter) -> Blocks:
    """Run the cases in alternating blocks and keep each block's median time.

    Each case is first called ``warmup`` times untimed (imports, caches), then the blocks run in
    turn: block k of every case, in the mapping's order, before block k + 1 of any. ``repeats``
    is the calls a block, for every case or per case name (a slow reference may take one).
    """
    counts = {name: repeats[name] if isinstance(repeats, Mapping) else repeats for name in cases}
    if blocks < 1 or min(counts.values()) < 1:
        raise ValueError(f"interleave: blocks and repeats must be >= 1, got {blocks}, {counts}")
    for fn in cases.values():
        for _ in range(warmup):
            fn()
    before = load_average()
    times: dict[str, list[float]] = {name: [] for name in cases}
    for _ in range(blocks):
        for name, fn in cases.items():
            times[name].append(statistics.median(_call(fn, clock) for _ in range(counts[name])))
    return Blocks(times, before, load_average())
