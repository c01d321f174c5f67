"""The LQT as a banded least-squares problem in position coefficients (our formulation,
equivalent to seed 000 eq. 13).

Unknowns: coefficients c_0 .. c_{L-1} (each (D,), relative to the first mean mu_1, [mm]).

* Euler (eq. 4): c_t = x_t; the state xi_t = (x_t, dx_t/dt, ...) has d^k x_t/dt^k =
  (Delta^k c)_t / dt^k and the control u_t = (Delta^n c)_t / dt^n, Delta the forward difference.
* Zero-order hold: the position is a degree-n spline with knots on the grid; in the cardinal
  B-spline basis with coefficients c_t the control is again u_t = (Delta^n c)_t / dt^n and the
  state at step t is a short stencil of c_t .. c_{t+n-1} (B-spline values and derivatives at
  the knots).

Every cost term is then a row block sqrt(P_t) (sum_j a_tj c_{t+j} / dt^k - v_t) (a
:class:`Block`), and the control rows sqrt(r) (Delta^n c)_t / dt^n: bandwidth n + 1 steps.
The start xi_1 = (mu_1, v_1, 0, ...) pins c_0 .. c_{n-1}; end at rest (GI sec. 4.1, exactly,
instead of the paper's precision 1e10) ties c_{N-1} = ... = c_{N+n-2}, L = N; a free end has
L = N + n - 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache
from math import comb

import numpy as np

from inkarm.core.plan import StrokePlan
from inkarm.errors import InputError, PlanError
from inkarm.models.lqt import cost
from inkarm.models.lqt.config import (
    LQTConfig,
    check_reference,
    check_stroke_ranges,
    rests_at_end,
    time_grid,
    velocity_steps,
)


class Block:
    """Rows sqrt(P_t) (sum_j a_tj c_{t+j} / dt^k - v_t) of the least-squares problem.

    Attributes:
        derivative: k, the rows observe x^(k).
        steps: (T,) time steps t.
        coef: (T, S) stencil on c_t .. c_{t+S-1} / dt^k, tail merged (see :func:`merged`).
        repeat: Each given precision / value holds for ``repeat`` consecutive rows (stepwise
            targets, eq. 6); ``precision``, ``value`` and ``weighted`` expand them on demand.
        targets_precision, targets_value: (T / repeat, D, D) and (T / repeat, D); the values
            relative to the origin; precision None = identity.
    """

    def __init__(self, derivative, steps, coef, precision, value, weighted=None, repeat=1):
        self.derivative, self.steps, self.coef, self.repeat = derivative, steps, coef, repeat
        self.targets_precision, self.targets_value = precision, value
        self._weighted = weighted

    def _expand(self, a: np.ndarray) -> np.ndarray:
        return a if self.repeat == 1 else a.repeat(self.repeat, axis=0)

    @cached_property
    def precision(self) -> np.ndarray | None:
        """(T, D, D) P_t."""
        p = self.targets_precision
        return None if p is None else self._expand(p)

    @cached_property
    def value(self) -> np.ndarray | None:
        """(T, D) v_t, shifted so that c_0 = 0."""
        v = self.targets_value
        return None if v is None else self._expand(v)

    @cached_property
    def weighted(self) -> np.ndarray:
        """(T, D) P_t v_t."""
        w = self._weighted
        if w is None:
            w = (self.targets_precision @ self.targets_value[:, :, None])[:, :, 0]
        return self._expand(w)

    @cached_property
    def start(self) -> int:
        """steps[0] when the steps are consecutive (slices instead of fancy indexing), else -1."""
        t = self.steps
        return int(t[0]) if t[-1] - t[0] == t.size - 1 else -1

    def with_values(self, value: np.ndarray, weighted: np.ndarray) -> Block:
        """The same rows (steps, stencil, precisions) towards other targets ``value`` (T /
        repeat, D), with ``weighted`` = P v (expanded at once: every solve reads it); what was
        derived from the structure is shared."""
        block = Block(self.derivative, self.steps, self.coef, self.targets_precision, value,
                      weighted, self.repeat)
        cached = block.__dict__
        cached["weighted"] = block._expand(weighted)
        for name in ("start", "precision"):
            if name in self.__dict__:
                cached[name] = self.__dict__[name]
        return block


@dataclass(frozen=True)
class Problem:
    """The banded problem of one stroke (all arrays relative to ``origin``)."""

    n: int
    dim: int
    n_steps: int  # N
    n_coef: int  # L: distinct coefficients c_0 .. c_{L-1}; the first n are fixed
    dt: float
    origin: np.ndarray  # mu_1: the problem is solved in coordinates relative to it
    control: float  # sqrt(r) / dt^n: the whitened control rows are control * Delta^n c
    blocks: tuple[Block, ...]
    discretisation: str
    end_at_rest: bool
    floor: float  # lower bound on the tracking precision at every step (0 if some step is free)
    ceiling: float  # upper bound on the tracking precision (Gershgorin), nan if other blocks
    start: np.ndarray  # (n, D) the fixed c_0 .. c_{n-1} relative to the origin (0 when at rest)
    control_target: np.ndarray | None  # (N-1, D) whitened control targets from a moving start

    @property
    def n_free(self) -> int:
        return self.n_coef - self.n


@lru_cache(maxsize=64)
def state_stencils(n: int, discretisation: str) -> tuple[np.ndarray, ...]:
    """Stencils s_k (k = 0..n-1) with x^(k)_t = sum_j s_k[j] c_{t+j} / dt^k.

    Euler: forward differences. ZOH: derivatives of the cardinal B-spline of degree n at the
    knots (the position is sum_i c_i B_n(tau - i + n)).
    """
    if discretisation == "euler":
        return tuple(difference(k) for k in range(n))
    from scipy.interpolate import BSpline  # zoh only: the default (euler) goes without it

    spline = BSpline.basis_element(np.arange(n + 2, dtype=float), extrapolate=False)
    at = n - np.arange(n, dtype=float)  # B_n(n - j) multiplies c_{t+j}
    out = []
    for k in range(n):
        values = spline.derivative(k)(at) if k else spline(at)
        out.append(np.asarray(values, dtype=float))
    return tuple(out)


@lru_cache(maxsize=16)
def difference(k: int) -> np.ndarray:
    """Coefficients of the forward difference Delta^k on c_t .. c_{t+k}."""
    return np.array([(-1) ** (k - j) * comb(k, j) for j in range(k + 1)], dtype=float)


def merged(steps: np.ndarray, stencil: np.ndarray, n_coef: int) -> np.ndarray:
    """(T, S) stencil rows with the coefficients of c beyond c_{L-1} added onto c_{L-1}.

    End at rest ties c_{N-1} = ... = c_{N+n-2}, so their coefficients merge.
    """
    coef = np.tile(stencil, (steps.size, 1))
    for row in np.flatnonzero(steps + stencil.size > n_coef):
        last = n_coef - 1 - steps[row]
        coef[row, last] += coef[row, last + 1 :].sum()
        coef[row, last + 1 :] = 0.0
    return coef


@lru_cache(maxsize=32)
def _arange(count: int) -> np.ndarray:
    steps = np.arange(count)
    steps.flags.writeable = False
    return steps


@lru_cache(maxsize=32)
def _ones(count: int) -> np.ndarray:
    ones = np.ones((count, 1))
    ones.flags.writeable = False
    return ones


@dataclass(frozen=True)
class Sizing:
    """The size of the problem of a stroke, known before anything is allocated."""

    per: int  # steps per segment
    n_steps: int  # N
    dim: int
    order: int
    method: str  # the factorisation "auto" will pick (or the one asked for)
    control: float  # sqrt(r) / dt^n
    floor: float
    ceiling: float

    @property
    def solve_bytes(self) -> float:
        """Estimated memory of building, factorising and solving (:mod:`.cost`)."""
        return cost.solve_bytes(self.n_steps, self.dim, self.order, self.method)

    def describe(self, what: str) -> str:
        return f"{what} ({self.n_steps} steps x {self.dim}-D, order {self.order}, {self.method})"


def sizing(stroke: StrokePlan, cfg: LQTConfig, references=()) -> Sizing:
    """Check the ranges of ``stroke`` and its time steps against INKARM_MAX_STEPS
    (:func:`.config.time_grid`), and size its problem, without allocating it."""
    check_stroke_ranges(stroke)
    n = cfg.order
    per, n_steps = time_grid(stroke, cfg)
    control = np.sqrt(cfg.control_weight(stroke.segment_time)) / cfg.dt**n  # R = r I, eq. 9
    everywhere = not stroke.keypoints and cfg.discretisation == "euler"
    floor = 1.0 / np.max(stroke.covs.trace(axis1=1, axis2=2)) if everywhere else 0.0
    single = not references and not velocity_steps(stroke, per)[0].size
    ceiling = np.abs(stroke.precisions).sum(axis=1).max() if single else np.nan
    method = cost.expected_method(cfg.solver, n, control, floor, ceiling)
    return Sizing(per, n_steps, stroke.dim, n, method, float(control), float(floor),
                  float(ceiling))


def build_problem(stroke: StrokePlan, cfg: LQTConfig, references=()) -> Problem:
    """Validate the inputs and assemble the banded problem of ``stroke``; its time steps and
    the memory of the solve are checked against their budgets first (:func:`sizing`)."""
    if not isinstance(stroke, StrokePlan):
        raise InputError(
            f"expected a StrokePlan, got {type(stroke).__name__}", key="stroke", value=stroke
        )
    if not isinstance(cfg, LQTConfig):
        raise InputError(f"expected an LQTConfig, got {type(cfg).__name__}", key="cfg", value=cfg)
    n, dim, dt = cfg.order, stroke.dim, cfg.dt
    size = sizing(stroke, cfg, references)
    cost.require(size.solve_bytes, size.describe("memory of the LQT solve"))
    per, n_steps, control, floor, ceiling = (size.per, size.n_steps, size.control, size.floor,
                                             size.ceiling)
    at_rest = rests_at_end(stroke, cfg, per, n_steps)
    n_coef = n_steps if at_rest else n_steps + n - 1
    stencils = state_stencils(n, cfg.discretisation)
    means, precisions = stroke.means, stroke.precisions  # Sigma_i^-1, eq. 6
    origin = means[0]
    if stroke.keypoints:  # GI eq. 6-7: each key-point weighs at a single step
        steps = np.arange(len(means)) * per
    else:  # seed 000 eq. 6: target i held for per steps, s = {1, 1, 2, 2, ...}
        steps = _arange(n_steps)
    coef = merged(steps, stencils[0], n_coef) if stencils[0].size > 1 else _ones(steps.size)
    shifted = means - origin
    weighted = (precisions @ shifted[:, :, None])[:, :, 0]
    repeat = 1 if stroke.keypoints else per
    blocks = [Block(0, steps, coef, precisions, shifted, weighted, repeat)]
    blocks += _velocity_blocks(stroke, n, dt, per, n_coef, stencils)
    for i, ref in enumerate(references):
        blocks.append(_reference_block(check_reference(i, ref, n, dim, n_steps), origin, dt,
                                       n_coef, stencils))
    start = _start_coefficients(stroke, n, dim, dt, stencils)
    control_target = None
    if start.any():  # the fixed coefficients move to the right-hand sides
        blocks = [_shift_block(b, start, n) for b in blocks]
        rows = Block(n, np.arange(n), merged(np.arange(n), difference(n), n_coef), None, None)
        control_target = np.zeros((n_steps - 1, dim))
        control_target[:n] = -control * apply_fixed(rows, start, n)
    return Problem(n, dim, n_steps, n_coef, dt, origin, control, tuple(blocks),
                   cfg.discretisation, at_rest, floor, ceiling, start, control_target)


def _velocity_blocks(stroke, n, dt, per, n_coef, stencils) -> list[Block]:
    """GI sec. 4.3: key-points augmented with velocities (Bezier mimicking)."""
    if stroke.velocities is None:
        return []
    if n < 2:
        raise PlanError(
            f"need order >= 2 (the velocity must be part of the state), got order {n}",
            key="velocities",
            value=stroke.velocities,
        )
    known, vsteps = velocity_steps(stroke, per)
    if not known.size:
        return []
    dim = stroke.dim
    vprec = np.broadcast_to(np.eye(dim) / stroke.velocity_var, (known.size, dim, dim))
    vcoef = merged(vsteps, stencils[1], n_coef) / dt
    return [Block(1, vsteps, vcoef, vprec.copy(), stroke.velocities[known])]


def _reference_block(ref, origin: np.ndarray, dt: float, n_coef: int, stencils) -> Block:
    """Rows of an extra tracking term (seed 000 eq. 18-19) on x^(k)."""
    k = ref.derivative
    value = ref.value - origin if k == 0 else ref.value
    coef = merged(ref.steps, stencils[k], n_coef) / dt**k
    return Block(k, ref.steps, coef, ref.precision, value)


def _start_coefficients(stroke: StrokePlan, n: int, dim: int, dt: float, stencils) -> np.ndarray:
    """c_0 .. c_{n-1} (n, D) relative to mu_1 for the initial state xi_1 = (mu_1, v_1, 0, ...).

    At rest (v_1 = 0) they are all 0. A first key-point with a prescribed velocity (Bezier
    mimicking, GI sec. 4.3) starts moving: solve the n x n system state_k = s_k . c / dt^k.
    """
    start = np.zeros((n, dim))
    vel = stroke.velocities
    if vel is None or n < 2 or not np.all(np.isfinite(vel[0])) or not np.any(vel[0]):
        return start
    state = np.zeros((n, dim))
    state[1] = vel[0]
    stencil = np.zeros((n, n))
    for k, s in enumerate(stencils):
        stencil[k, : s.size] = s / dt**k
    return np.linalg.solve(stencil, state)


def apply_fixed(block: Block, start: np.ndarray, n: int) -> np.ndarray:
    """(T, D) part of the block's rows A_t c that comes from the fixed c_0 .. c_{n-1}."""
    out = np.zeros((block.steps.size, start.shape[1]))
    for j in range(block.coef.shape[1]):
        idx = block.steps + j
        mask = idx < n
        out[mask] += block.coef[mask, j, None] * start[idx[mask]]
    return out


def _shift_block(block: Block, start: np.ndarray, n: int) -> Block:
    """The block with targets v_t - A_t c_fixed, so that the fixed coefficients can be dropped."""
    value = block.value - apply_fixed(block, start, n)
    weighted = (block.precision @ value[:, :, None])[:, :, 0]
    return Block(block.derivative, block.steps, block.coef, block.precision, value, weighted)


def extend(prob: Problem, c: np.ndarray, with_start: bool = False) -> np.ndarray:
    """All coefficients c_0 .. c_{N+n-2} (..., N+n-1, D) from the free ones; the fixed ones are 0
    (as in the shifted right-hand sides) or, with_start, their values."""
    n, n_coef = prob.n, prob.n_coef
    ext = np.zeros(c.shape[:-2] + (prob.n_steps + n - 1, prob.dim))
    if c.ndim == 2:
        if with_start:
            ext[:n] = prob.start
        ext[n:n_coef] = c
        ext[n_coef:] = c[-1]
        return ext
    if with_start:
        ext[..., :n, :] = prob.start
    ext[..., n:n_coef, :] = c
    ext[..., n_coef:, :] = c[..., -1:, :]
    return ext


def positions(prob: Problem, c_free: np.ndarray, derivative: int = 0, affine: bool = True):
    """x^(k)_t (..., N, D) in [mm/s^k] from free coefficients (..., n_free, D).

    ``affine=False`` gives the linear part only (fixed start and origin left out), the map
    whose covariance image is the position covariance.
    """
    stencil = state_stencils(prob.n, prob.discretisation)[derivative]
    if derivative == 0 and stencil.size == 1 and stencil[0] == 1.0:  # Euler: x_t = c_t
        return _euler_positions(prob, c_free, affine)
    ext = extend(prob, c_free, with_start=affine)
    if stencil.size == 1:
        out = ext[..., : prob.n_steps, :] * stencil[0]
    else:
        out = np.zeros((*c_free.shape[:-2], prob.n_steps, prob.dim))
        for j, a in enumerate(stencil):
            if a:
                out += a * ext[..., j : j + prob.n_steps, :]
    if derivative:
        out /= prob.dt**derivative
    if derivative == 0 and affine:
        out += prob.origin
    return out


def _euler_positions(prob: Problem, c_free: np.ndarray, affine: bool) -> np.ndarray:
    """x_t = c_t (..., N, D): the fixed start then the free coefficients (the tied tail lies
    beyond step N - 1), plus the origin when ``affine``; written in place, one pass."""
    n, n_steps = prob.n, prob.n_steps
    out = np.empty(c_free.shape[:-2] + (n_steps, prob.dim))
    out[..., :n, :] = prob.start + prob.origin if affine else 0.0
    free = c_free[..., : n_steps - n, :]
    if affine:
        np.add(free, prob.origin, out=out[..., n:, :])
    else:
        out[..., n:, :] = free
    return out


def psd_sqrt(prec: np.ndarray) -> np.ndarray:
    """L_t with L_t L_t^T = P_t for positive semi-definite P_t (Cholesky where definite)."""
    try:
        return np.linalg.cholesky(prec)
    except np.linalg.LinAlgError:
        w, v = np.linalg.eigh(prec)
        return v * np.sqrt(np.clip(w, 0.0, None))[:, None, :]
