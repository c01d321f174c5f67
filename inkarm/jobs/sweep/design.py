"""Designs of a sweep: which scenario overrides to run, each point with a stable id.

An axis is one ``--set`` option over a dotted scenario key (``controller.force_n``):

    key=lo:hi:n   n values evenly spaced from lo to hi (integers when lo, hi and the step are)
    key=lo:hi     a range, for random designs only
    key=a,b,c     these values (numbers, true/false, or text such as an ink model's name)
    key=v         one value

Designs: the grid (every combination, the default), zip (the i-th value of every axis; the
axes must have the same length), and random (N points, ranges sampled by a Latin hypercube
(:class:`scipy.stats.qmc.LatinHypercube`, seeded), value lists by a seeded uniform choice).
Each design point is run once per seed of ``--seeds`` (the scenario's ``seed``), else once
with the scenario's own seed. A point's id is a digest of its overrides and seed, so that a
resumed sweep knows which points it has finished whatever order they ran in.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
from dataclasses import dataclass

import numpy as np

from inkarm.errors import InkarmError, InputError
from inkarm.jobs.scenario import Scenario

MAX_POINTS = 100_000  # a sweep is a table of runs: past this it is a typo, not a plan


@dataclass(frozen=True)
class Axis:
    """Values of one dotted key: ``values`` (a list) or a ``span`` (lo, hi) with a count."""

    key: str
    values: tuple = ()
    span: tuple[float, float] | None = None
    count: int | None = None
    integer: bool = False

    def check_counted(self) -> None:
        """Refuse a range without a count (a grid or zip needs lo:hi:n)."""
        if self.span is not None and self.count is None:
            raise InputError(f"{self.key}={self.span[0]:g}:{self.span[1]:g} is a range without "
                             "a count: give lo:hi:n for a grid or zip, or use --random N",
                             key="--set", value=self.key)

    @property
    def first(self):
        """The axis's first value, without making the others."""
        if self.span is None:
            return self.values[0]
        return round(self.span[0]) if self.integer else self.span[0]

    @property
    def size(self) -> int | None:
        """How many values a grid or zip design takes from the axis (None: a range without a
        count), known before any value is made."""
        return len(self.values) if self.span is None else self.count

    def grid_values(self) -> tuple:
        """The axis's values for a grid or zip design."""
        if self.span is None:
            return self.values
        self.check_counted()
        values = np.linspace(self.span[0], self.span[1], self.count)
        return tuple(round(float(v)) for v in values) if self.integer else \
            tuple(float(v) for v in values)


def _scalar(text: str, key: str):
    """A --set value: an integer, a number, true/false, or text."""
    word = text.strip()
    if word.lower() in ("true", "false"):
        return word.lower() == "true"
    for kind in (int, float):
        try:
            value = kind(word)
        except ValueError:
            continue
        if isinstance(value, float) and not math.isfinite(value):
            raise InputError(f"expected a finite number, got {word!r}", key=f"--set {key}",
                             value=text)
        return value
    if not word:
        raise InputError("empty value", key=f"--set {key}", value=text)
    return word


def parse_axis(text: str) -> Axis:
    """One ``--set`` option (see the module docstring)."""
    key, sep, spec = text.partition("=")
    key = key.strip()
    if not sep or not key or not spec.strip():
        raise InputError(f"expected KEY=lo:hi:n, KEY=a,b,c or KEY=value, got {text!r}",
                         key="--set", value=text)
    if ":" in spec:
        parts = spec.split(":")
        if len(parts) not in (2, 3):
            raise InputError(f"expected lo:hi or lo:hi:n, got {spec!r}", key=f"--set {key}",
                             value=text)
        lo, hi = (_scalar(p, key) for p in parts[:2])
        if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in (lo, hi)):
            raise InputError(f"a range needs numbers, got {spec!r}", key=f"--set {key}",
                             value=text)
        count = None
        if len(parts) == 3:
            count = _scalar(parts[2], key)
            if not isinstance(count, int) or isinstance(count, bool) or count < 1:
                raise InputError(f"expected a count n >= 1 in lo:hi:n, got {parts[2]!r}",
                                 key=f"--set {key}", value=text)
        integer = all(isinstance(v, int) for v in (lo, hi)) and (
            count is None or count == 1 or (hi - lo) % (count - 1) == 0)
        return Axis(key, span=(float(lo), float(hi)), count=count, integer=integer)
    return Axis(key, values=tuple(_scalar(v, key) for v in spec.split(",")))


def parse_seeds(text: str) -> tuple[int, ...]:
    """``--seeds``: ``a:b`` (a, a+1, ..., b-1) or ``a,b,c``."""
    try:
        bounds = [int(v) for v in text.split(":")] if ":" in text else None
        listed = None if bounds else [int(v) for v in text.split(",")]
    except ValueError:
        raise InputError(f"expected seeds as a:b or a,b,c (integers), got {text!r}",
                         key="--seeds", value=text) from None
    if bounds is not None:
        if len(bounds) != 2:
            raise InputError(f"expected seeds as a:b or a,b,c (integers), got {text!r}",
                             key="--seeds", value=text)
        if bounds[1] - bounds[0] > MAX_POINTS:  # refused before the range is made
            raise InputError(f"{bounds[1] - bounds[0]} seeds, more than the {MAX_POINTS} runs "
                             f"a sweep may have, got {text!r}", key="--seeds", value=text)
    seeds = tuple(range(*bounds)) if bounds is not None else tuple(listed)
    if not seeds or min(seeds) < 0:
        raise InputError(f"expected at least one seed, all >= 0, got {text!r}", key="--seeds",
                         value=text)
    return seeds


def check_design_size(axes: list[Axis], *, zip_axes: bool = False, random: int | None = None,
                      seeds: int = 1) -> int:
    """The number of runs the design asks for (points x ``seeds``), from the axes' sizes alone,
    refused past :data:`MAX_POINTS` before any point (or value) is made."""
    if random is not None:
        points = random
    else:
        for axis in axes:
            axis.check_counted()
        sizes = [axis.size or 0 for axis in axes]
        points = (max(sizes) if sizes else 0) if zip_axes else math.prod(sizes)
    runs = points * seeds
    if runs > MAX_POINTS:
        shape = "random" if random is not None else "zip" if zip_axes else " x ".join(
            str(a.size) for a in axes)
        raise InputError(f"{runs} runs ({shape} design, {seeds} seed(s)), more than the "
                         f"{MAX_POINTS} a sweep may have", key="--set")
    return runs


def grid_design(axes: list[Axis]) -> list[dict]:
    """Every combination of the axes' values, the last axis varying fastest."""
    keys = [a.key for a in axes]
    return [dict(zip(keys, combo)) for combo in
            itertools.product(*(a.grid_values() for a in axes))]


def zip_design(axes: list[Axis]) -> list[dict]:
    """The i-th value of every axis; the axes must be equally long."""
    columns = [a.grid_values() for a in axes]
    lengths = {a.key: len(c) for a, c in zip(axes, columns)}
    if len(set(lengths.values())) > 1:
        raise InputError(f"--zip needs axes of one length, got {lengths}", key="--zip")
    return [dict(zip(lengths, row)) for row in zip(*columns)]


def random_design(axes: list[Axis], n: int, seed: int = 0) -> list[dict]:
    """``n`` points: each range axis by a Latin hypercube over [lo, hi] (integers rounded),
    each list axis by a uniform choice, all from ``seed``."""
    from scipy.stats import qmc

    if n < 1:
        raise InputError(f"expected --random N >= 1, got {n}", key="--random", value=n)
    spans = [a for a in axes if a.span is not None]
    unit = qmc.LatinHypercube(d=len(spans), seed=seed).random(n) if spans else np.zeros((n, 0))
    rng = np.random.default_rng(seed)
    points = [{} for _ in range(n)]
    for j, axis in enumerate(spans):
        lo, hi = axis.span
        for point, u in zip(points, lo + unit[:, j] * (hi - lo)):
            point[axis.key] = round(float(u)) if axis.integer else float(u)
    for axis in axes:
        if axis.span is None:
            picks = rng.integers(len(axis.values), size=n)
            for point, k in zip(points, picks):
                point[axis.key] = axis.values[int(k)]
    return [{a.key: p[a.key] for a in axes} for p in points]


@dataclass(frozen=True)
class Point:
    """One run of a sweep: its position in the design, overrides and seed, and its id."""

    index: int
    params: dict
    seed: int
    point_id: str

    def overrides(self) -> dict:
        return {**self.params, "seed": self.seed}


def point_id(params: dict, seed: int) -> str:
    """A stable id of a point: a digest of its overrides and seed (not of its position)."""
    text = json.dumps({"params": params, "seed": seed}, sort_keys=True, allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def make_points(design: list[dict], seeds: tuple[int, ...]) -> list[Point]:
    """Every design point once per seed, numbered in that order."""
    points = [Point(i, params, seed, point_id(params, seed)) for i, (params, seed) in
              enumerate(itertools.product(design, seeds))]
    if len(points) > MAX_POINTS:
        raise InputError(f"{len(points)} runs, more than the {MAX_POINTS} a sweep may have",
                         key="--set")
    ids = [p.point_id for p in points]
    if len(set(ids)) != len(ids):
        raise InputError("the design repeats a point (the same values twice on an axis?)",
                         key="--set")
    return points


def with_point(scenario: Scenario, overrides: dict) -> Scenario:
    """``scenario`` with ``overrides`` applied; the scenario itself is left untouched (a copy
    is overridden: overriding reuses the tables of an inline plan)."""
    return copy.deepcopy(scenario).with_overrides(overrides)


def validate(scenario: Scenario, points: list[Point]) -> None:
    """Apply every point's overrides to ``scenario`` with the scenario's own checks, before
    anything runs; the first bad one is refused, naming the point and the key."""
    for p in points:
        try:
            with_point(scenario, p.overrides())
        except InkarmError as e:
            values = ", ".join(f"{k}={v!r}" for k, v in p.params.items())
            raise InputError(f"point {p.index} ({values}, seed {p.seed}): {e}",
                             key="--set") from None
