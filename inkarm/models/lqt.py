"""Gaussian-target linear quadratic tracking (LQT), seed 000 (MOCO paper sec. 3, GI paper sec. 4).

A chain of ``n`` integrators (eq. 1-4) is driven by its n-th derivative ``u`` to track an ordered
sequence of Gaussian targets N(mu_i, Sigma_i), each held ``segment_time`` [s] (eq. 5-7), or sparse
key-points (GI eq. 6-7), while the control cost (eq. 9) keeps it smooth. The optimum is the mean of
a Gaussian trajectory distribution (eq. 14-15) that :func:`sample` draws from.

Every public quantity is in millimetres and seconds: means in [mm], covariances in [mm^2],
``d`` in [mm], ``r`` in [(mm/s^n)^-2].

How it is solved (our formulation, equivalent to eq. 13 but banded):

* Position form. With Euler (eq. 4) the state is ``xi_t = (x_t, dx_t/dt, ..., d^(n-1)x_t/dt^(n-1))``
  with ``d^k x_t/dt^k = (Delta^k c)_t / dt^k`` and ``u_t = (Delta^n c)_t / dt^n`` where ``c_t = x_t``
  and ``Delta`` is the forward difference. With zero-order hold the position is a degree-n spline
  with knots on the grid; writing it in the cardinal B-spline basis with coefficients ``c_t`` gives
  the very same ``u_t = (Delta^n c)_t / dt^n`` and the state at step t is a short stencil of
  ``c_t .. c_{t+n-1}`` (B-spline values and derivatives at the knots). Both make the cost a banded
  least-squares problem in ``c`` with bandwidth n+1 steps.
* Start at rest on the first mean (xi_1 = (mu_1, 0, ..., 0)) pins ``c_0 = ... = c_{n-1} = mu_1``
  (a first key-point with a prescribed velocity pins them to that moving state instead); end at
  rest (zero derivatives at the last step, GI sec. 4.1, imposed exactly here instead of the
  paper's precision of 1e10) ties ``c_{N-1} = ... = c_{N+n-2}``. With Euler the positions lag the
  continuous-time optimum by (n - 1) / 2 steps (the n pinned positions centre on t = (n-1) dt / 2).
* Two linear-time solvers: ``"cholesky"`` forms the banded normal equations (LAPACK pbtrf), fast,
  followed by one step of iterative refinement whose residual is computed from differences of the
  solution (not from the rounded normal matrix); ``"augmented"`` solves Bjorck's augmented system,
  with the control residuals as extra unknowns interleaved in time (LAPACK gbsv), which avoids
  squaring the condition number and stays accurate at orders 6-7. ``"auto"`` picks Cholesky only
  where a bound on its conditioning says it is safe. ``"batch"`` is the dense eq. 13 in its
  square-root least-squares form (lstsq on the stacked system), kept as the test oracle.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache
from math import comb

import numpy as np
from scipy.interpolate import BSpline
from scipy.linalg import eig_banded, expm, lapack, lstsq, null_space, solve_triangular

from inkarm.core.plan import StrokePlan, check_covariance
from inkarm.core.trajectory import Trajectory
from inkarm.errors import InputError, PlanError, SolverError

MAX_ORDER = 7
SOLVERS = ("auto", "cholesky", "augmented", "batch")
_EPS = np.finfo(float).eps


# --------------------------------------------------------------------------------------------
# configuration


@dataclass(frozen=True)
class LQTConfig:
    """Settings of the LQT.

    Attributes:
        order: n, order of the integrator chain, 1..7 (eq. 3); 4 is the papers' usual choice.
        dt: Time step Delta_t in [s].
        d: Maximum displacement in [mm]: R = I / (omega^n d)^2 with omega = 2 pi / segment_time
            (seed 000 eq. 9). Exactly one of ``d`` and ``r`` is given.
        r: Raw control weight in [(mm/s^n)^-2] (GI sec. 3.2, R = r I).
        discretisation: ``"euler"`` (eq. 4, default) or ``"zoh"`` (zero-order hold).
        end_at_rest: Zero derivatives at the last step (GI sec. 4.1).
        solver: ``"auto"``, ``"cholesky"``, ``"augmented"`` or ``"batch"`` (see module docstring).
    """

    order: int = 4
    dt: float = 0.01
    d: float | None = 5.0
    r: float | None = None
    discretisation: str = "euler"
    end_at_rest: bool = True
    solver: str = "auto"

    def __post_init__(self) -> None:
        if isinstance(self.order, bool) or not isinstance(self.order, (int, np.integer)):
            raise InputError(
                f"LQTConfig order: expected an integer 1..{MAX_ORDER}, got {self.order!r}"
            )
        if not 1 <= self.order <= MAX_ORDER:
            raise InputError(f"LQTConfig order: expected 1..{MAX_ORDER}, got {self.order}")
        if not _positive_number(self.dt):
            raise InputError(f"LQTConfig dt: must be a positive number of seconds, got {self.dt}")
        if (self.d is None) == (self.r is None):
            raise InputError(
                f"LQTConfig: give exactly one of d (max displacement in mm) and r (raw control "
                f"weight), got d={self.d}, r={self.r} (d defaults to 5.0: pass d=None with r)"
            )
        if self.d is not None and not _positive_number(self.d):
            raise InputError(f"LQTConfig d: must be a positive number of mm, got {self.d}")
        if self.r is not None and not _positive_number(self.r):
            raise InputError(f"LQTConfig r: must be a positive number, got {self.r}")
        if self.discretisation not in ("euler", "zoh"):
            raise InputError(
                f"LQTConfig discretisation: expected 'euler' or 'zoh', got {self.discretisation!r}"
            )
        if self.solver not in SOLVERS:
            raise InputError(f"LQTConfig solver: expected one of {SOLVERS}, got {self.solver!r}")
        object.__setattr__(self, "order", int(self.order))
        object.__setattr__(self, "dt", float(self.dt))

    def control_weight(self, segment_time: float) -> float:
        """r such that R = r I, in [(mm/s^n)^-2] (seed 000 eq. 9).

        The paper prints omega = 2 pi T_s (MOCO eq. 9) and omega = 2 pi T / (m - 1) (GI eq. 10);
        both are dimensionally a typo for a frequency with the segment duration as period, which is
        what the authors' code computes: omega = 2 pi / T_s.
        """
        if self.r is not None:
            return float(self.r)
        omega = 2.0 * np.pi / segment_time
        return 1.0 / (omega**self.order * self.d) ** 2


def _positive_number(value) -> bool:
    try:
        v = float(value)
    except (TypeError, ValueError):
        return False
    return bool(np.isfinite(v) and v > 0)


@dataclass(frozen=True)
class Reference:
    """An extra quadratic tracking term (seed 000 eq. 18-19) on one derivative of the position.

    Cost: sum over ``steps`` of (x^(k)_t - value_t)^T precision_t (x^(k)_t - value_t).

    Attributes:
        derivative: k, 0 (position) .. order - 1 (only state entries can be observed).
        precision: (D, D) or (len(steps), D, D) symmetric positive semi-definite weights in
            [(mm/s^k)^-2].
        value: Reference (D,) or (len(steps), D) in [mm/s^k]; zero by default (eq. 20).
        steps: Time-step indices where the term applies; all steps by default.
    """

    derivative: int
    precision: np.ndarray
    value: np.ndarray | None = None
    steps: np.ndarray | None = None


def velocity_direction_reference(v, weight: float = 1.0) -> Reference:
    """The velocity reference of seed 000 eq. 20-21: zero velocity with precision weight v v^T.

    As printed, this costs weight (v . dx/dt)^2, i.e. it penalises the velocity component *along*
    ``v`` and so pushes the motion across it (the paper's Fig. 5b is ambiguous about which was
    meant); pass the perpendicular vector to favour motion along a direction. ``v`` is
    dimensionless, ``weight`` in [(mm/s)^-2].
    """
    v = np.asarray(v, dtype=float)
    if v.ndim != 1 or not np.all(np.isfinite(v)) or not np.any(v):
        raise InputError(f"velocity reference: expected a finite non-zero vector, got {v.tolist()}")
    if not _positive_number(weight):
        raise InputError(f"velocity reference weight: must be positive, got {weight}")
    return Reference(derivative=1, precision=weight * np.outer(v, v))


# --------------------------------------------------------------------------------------------
# the banded problem


class _Block:
    """Rows sqrt(P_t) (sum_j a_tj c_{t+j} / dt^k - v_t) of the least-squares problem.

    Attributes:
        derivative: k, the rows observe x^(k).
        steps: (T,) time steps t.
        coef: (T, S) stencil on c_t .. c_{t+S-1} / dt^k, tail merged (see _merged).
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
        return a if self.repeat == 1 else np.repeat(a, self.repeat, axis=0)

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


@dataclass(frozen=True)
class _Problem:
    n: int
    dim: int
    n_steps: int  # N
    n_coef: int  # L: distinct coefficients c_0 .. c_{L-1}; the first n are fixed at mu_1
    dt: float
    origin: np.ndarray  # mu_1: the problem is solved in coordinates relative to it
    control: float  # sqrt(r) / dt^n: the whitened control rows are control * Delta^n c
    blocks: tuple[_Block, ...]
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
def _state_stencils(n: int, discretisation: str) -> tuple[np.ndarray, ...]:
    """Stencils s_k (k = 0..n-1) with x^(k)_t = sum_j s_k[j] c_{t+j} / dt^k.

    Euler: forward differences. ZOH: derivatives of the cardinal B-spline of degree n at the
    knots (the position is sum_i c_i B_n(tau - i + n)).
    """
    if discretisation == "euler":
        return tuple(_difference(k) for k in range(n))
    spline = BSpline.basis_element(np.arange(n + 2, dtype=float), extrapolate=False)
    at = n - np.arange(n, dtype=float)  # B_n(n - j) multiplies c_{t+j}
    out = []
    for k in range(n):
        values = spline.derivative(k)(at) if k else spline(at)
        out.append(np.asarray(values, dtype=float))
    return tuple(out)


@lru_cache(maxsize=16)
def _difference(k: int) -> np.ndarray:
    """Coefficients of the forward difference Delta^k on c_t .. c_{t+k}."""
    return np.array([(-1) ** (k - j) * comb(k, j) for j in range(k + 1)], dtype=float)


def _merged(steps: np.ndarray, stencil: np.ndarray, n_coef: int) -> np.ndarray:
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


def _time_grid(stroke: StrokePlan, cfg: LQTConfig) -> tuple[int, int]:
    """(steps per segment, N)."""
    ratio = stroke.segment_time / cfg.dt
    per = round(ratio)
    if per >= 1 and abs(ratio - per) > 1e-6 * ratio:
        raise PlanError(
            f"stroke segment_time: {stroke.segment_time} s is not a whole number of dt = {cfg.dt} s "
            f"steps ({ratio:.4g}); the targets would be held {per * cfg.dt:g} s instead"
        )
    if per < 1:
        raise PlanError(
            f"stroke segment_time: {stroke.segment_time} s is shorter than dt = {cfg.dt} s"
        )
    m = len(stroke.targets)
    if stroke.keypoints:
        if m < 2:
            raise PlanError("stroke: key-point interpolation needs at least 2 key-points, got 1")
        n_steps = (m - 1) * per + 1
    else:
        n_steps = m * per
    if n_steps < cfg.order + 1:
        raise PlanError(
            f"stroke: {n_steps} time steps (segment_time {stroke.segment_time} s / dt {cfg.dt} s "
            f"x {m} targets) but order {cfg.order} needs at least {cfg.order + 1}; "
            "use a smaller dt or a longer segment_time"
        )
    return per, n_steps


def _as_steps(name: str, value, shape: tuple[int, ...], count: int) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.shape == shape:
        arr = np.broadcast_to(arr, (count, *shape))
    if arr.shape != (count, *shape):
        raise InputError(f"{name}: expected shape {shape} or {(count, *shape)}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: contains NaN or inf")
    return arr


def _reference_block(i: int, ref: Reference, prob_args: dict) -> _Block:
    n, dim, n_steps, n_coef, dt, stencils = (
        prob_args[k] for k in ("n", "dim", "n_steps", "n_coef", "dt", "stencils")
    )
    where = f"reference {i}"
    if not isinstance(ref, Reference):
        raise InputError(f"{where}: expected a Reference, got {type(ref).__name__}")
    k = ref.derivative
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 0 <= k < n:
        raise InputError(
            f"{where} derivative: expected an integer 0..{n - 1} (order - 1), got {k!r}"
        )
    steps = np.arange(n_steps) if ref.steps is None else np.asarray(ref.steps)
    if steps.ndim != 1 or steps.size == 0 or steps.dtype.kind not in "iu":
        raise InputError(f"{where} steps: expected a non-empty 1-D array of integers")
    if steps.min() < 0 or steps.max() >= n_steps:
        raise InputError(
            f"{where} steps: must lie in 0..{n_steps - 1}, got {steps.min()}..{steps.max()}"
        )
    prec = _as_steps(f"{where} precision", ref.precision, (dim, dim), steps.size)
    if np.max(np.abs(prec - np.swapaxes(prec, 1, 2))) > 1e-9 * max(np.max(np.abs(prec)), 1e-300):
        raise InputError(f"{where} precision: not symmetric")
    if np.min(np.linalg.eigvalsh(prec)) < -1e-9 * max(np.max(np.abs(prec)), 1e-300):
        raise InputError(f"{where} precision: not positive semi-definite")
    value = np.zeros(dim) if ref.value is None else ref.value
    value = _as_steps(f"{where} value", value, (dim,), steps.size)
    if k == 0:
        value = value - prob_args["origin"]
    coef = _merged(steps, stencils[k], n_coef) / dt**k
    return _Block(k, steps, coef, np.array(prec, dtype=float), np.array(value, dtype=float))


def _problem(stroke: StrokePlan, cfg: LQTConfig, references=()) -> _Problem:
    if not isinstance(stroke, StrokePlan):
        raise InputError(f"LQT: expected a StrokePlan, got {type(stroke).__name__}")
    if not isinstance(cfg, LQTConfig):
        raise InputError(f"LQT: expected an LQTConfig, got {type(cfg).__name__}")
    n, dim, dt = cfg.order, stroke.dim, cfg.dt
    per, n_steps = _time_grid(stroke, cfg)
    n_coef = n_steps if cfg.end_at_rest else n_steps + n - 1
    stencils = _state_stencils(n, cfg.discretisation)
    means, covs = stroke.means, stroke.covs
    origin = means[0]
    precisions = stroke.precisions  # Sigma_i^-1, eq. 6
    m = len(means)
    if stroke.keypoints:  # GI eq. 6-7: each key-point weighs at a single step
        steps = np.arange(m) * per
    else:  # seed 000 eq. 6: target i held for per steps, s = {1, 1, 2, 2, ...}
        steps = _arange(n_steps)
    coef = _merged(steps, stencils[0], n_coef) if stencils[0].size > 1 else _ones(steps.size)
    shifted = means - origin
    weighted = (precisions @ shifted[:, :, None])[:, :, 0]
    repeat = 1 if stroke.keypoints else per  # eq. 6: target i held for per steps
    blocks = [_Block(0, steps, coef, precisions, shifted, weighted, repeat)]
    vel = getattr(stroke, "velocities", None)
    if vel is not None:  # GI sec. 4.3: key-points augmented with velocities (Bezier mimicking)
        if n < 2:
            raise PlanError(
                "stroke velocities: need order >= 2 (velocity must be part of the state)"
            )
        known = np.flatnonzero(np.all(np.isfinite(vel), axis=1))
        if known.size:
            vsteps = np.minimum(known * per, n_steps - 1)
            vprec = np.broadcast_to(np.eye(dim) / stroke.velocity_var, (known.size, dim, dim))
            vcoef = _merged(vsteps, stencils[1], n_coef) / dt
            blocks.append(_Block(1, vsteps, vcoef, vprec.copy(), vel[known]))
    args = {
        "n": n,
        "dim": dim,
        "n_steps": n_steps,
        "n_coef": n_coef,
        "dt": dt,
        "stencils": stencils,
        "origin": origin,
    }
    for i, ref in enumerate(references):
        blocks.append(_reference_block(i, ref, args))
    r = cfg.control_weight(stroke.segment_time)
    control = np.sqrt(r) / dt**n
    start = _start_coefficients(stroke, n, dim, dt, stencils)
    control_target = None
    if start.any():  # the fixed coefficients move to the right-hand sides
        blocks = [_shift_block(b, start, n) for b in blocks]
        rows = _Block(n, np.arange(n), _merged(np.arange(n), _difference(n), n_coef), None, None)
        control_target = np.zeros((n_steps - 1, dim))
        control_target[:n] = -control * _apply_fixed(rows, start, n)
    everywhere = not stroke.keypoints and cfg.discretisation == "euler"
    floor = 1.0 / np.max(covs.trace(axis1=1, axis2=2)) if everywhere else 0.0
    ceiling = np.abs(precisions).sum(axis=1).max() if len(blocks) == 1 else np.nan
    return _Problem(
        n,
        dim,
        n_steps,
        n_coef,
        dt,
        origin,
        control,
        tuple(blocks),
        cfg.discretisation,
        cfg.end_at_rest,
        floor,
        ceiling,
        start,
        control_target,
    )


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


def _apply_fixed(block: _Block, start: np.ndarray, n: int) -> np.ndarray:
    """(T, D) part of the block's rows A_t c that comes from the fixed c_0 .. c_{n-1}."""
    out = np.zeros((block.steps.size, start.shape[1]))
    for j in range(block.coef.shape[1]):
        idx = block.steps + j
        mask = idx < n
        out[mask] += block.coef[mask, j, None] * start[idx[mask]]
    return out


def _shift_block(block: _Block, start: np.ndarray, n: int) -> _Block:
    """The block with targets v_t - A_t c_fixed, so that the fixed coefficients can be dropped."""
    value = block.value - _apply_fixed(block, start, n)
    weighted = (block.precision @ value[:, :, None])[:, :, 0]
    return _Block(block.derivative, block.steps, block.coef, block.precision, value, weighted)


# --------------------------------------------------------------------------------------------
# normal equations in LAPACK lower band storage: ab[off, col] = H[col + off, col]


def _band_add(ab: np.ndarray, block: _Block, n: int, dim: int) -> None:
    """ab += sum_t A_t^T P_t A_t for one block (free unknowns interleaved: (c_i - n) * D + d)."""
    n_free = ab.shape[1] // dim
    t, coef, prec = block.steps, block.coef, block.precision
    start, width = block.start, coef.shape[1]
    for j1 in range(width):
        for j2 in range(j1, width):
            w = coef[:, j1] * coef[:, j2] if width > 1 else coef[:, 0] ** 2
            if start >= 0:  # rows lo..hi-1 have c_{t+j1}, c_{t+j2} both free
                lo, hi = max(n - start - j1, 0), min(n_free + n - start - j2, t.size)
                if hi <= lo:
                    continue
                rows = slice(lo, hi)
                c0 = (start + lo + j1 - n) * dim
            else:
                rows = np.flatnonzero((t + j1 >= n) & (t + j2 - n < n_free))
                if rows.size == 0:
                    continue
                cols = (t[rows] + j1 - n) * dim
            w = w[rows]
            for d1 in range(dim):
                for d2 in range(d1 if j1 == j2 else 0, dim):
                    val = w if prec is None else w * prec[rows, d2, d1]
                    if prec is None and d1 != d2:
                        continue
                    off = (j2 - j1) * dim + d2 - d1
                    if start >= 0:
                        ab[off, c0 + d1 : c0 + d1 + dim * (hi - lo) : dim] += val
                    else:
                        ab[off, cols + d1] += val


def _rhs_add(rhs: np.ndarray, block: _Block, g: np.ndarray, n: int) -> None:
    """rhs (..., n_free, D) += A^T g for rows g (..., T, D) already weighted by P_t."""
    n_free = rhs.shape[-2]
    t, coef, start = block.steps, block.coef, block.start
    for j in range(coef.shape[1]):
        if start >= 0:
            lo, hi = max(n - start - j, 0), min(n_free + n - start - j, t.size)
            if hi > lo:
                c0 = start + lo + j - n
                rhs[..., c0 : c0 + hi - lo, :] += coef[lo:hi, j, None] * g[..., lo:hi, :]
        else:
            cols = t + j - n
            ok = (cols >= 0) & (cols < n_free)
            if ok.any():
                rhs[..., cols[ok], :] += coef[ok, j, None] * g[..., ok, :]


@lru_cache(maxsize=32)
def _control_rows(n: int, n_steps: int, n_coef: int) -> np.ndarray:
    """(N-1, n+1) merged Delta^n stencils of the controls u_0 .. u_{N-2}."""
    coef = _merged(np.arange(n_steps - 1), _difference(n), n_coef)
    coef.flags.writeable = False
    return coef


@lru_cache(maxsize=32)
def _control_band(n: int, dim: int, n_steps: int, n_coef: int) -> np.ndarray:
    """Lower band of (Delta^n)^T Delta^n (x) I_D on the free unknowns, unscaled."""
    ab = np.zeros(((n + 1) * dim, (n_coef - n) * dim))
    _band_add(
        ab, _Block(n, np.arange(n_steps - 1), _control_rows(n, n_steps, n_coef), None, None), n, dim
    )
    ab.flags.writeable = False
    return ab


def _obs_band(prob: _Problem) -> np.ndarray:
    """Lower band of the tracking part sum_blocks A^T P A, bandwidth of the widest stencil."""
    width = max(b.coef.shape[1] for b in prob.blocks)
    ab = np.zeros((width * prob.dim, prob.n_free * prob.dim))
    first = prob.blocks[0]
    if len(prob.blocks) == 1 and width == 1 and first.start == 0:  # Euler, every step tracked
        count = prob.n_steps - prob.n
        rows = ab.reshape(prob.dim, prob.n_free, prob.dim)
        for off in range(prob.dim):  # ab[off, t D + d] = P_t[d + off, d]
            diagonal = np.diagonal(first.targets_precision, -off, 1, 2)
            rows[off, :count, : prob.dim - off] = np.repeat(diagonal, first.repeat, 0)[prob.n :]
        return ab
    for block in prob.blocks:
        _band_add(ab, block, prob.n, prob.dim)
    return ab


def _rhs(prob: _Problem, noise: tuple | None = None) -> np.ndarray:
    """A^T b, (n_free, D); with noise (rng, K): (K, n_free, D) for perturbed targets."""
    shape = (prob.n_free, prob.dim) if noise is None else (noise[1], prob.n_free, prob.dim)
    rhs = np.zeros(shape)
    blocks = prob.blocks
    first = blocks[0]
    if noise is None and first.coef.shape[1] == 1 and first.start == 0:  # Euler, every step
        rhs[: prob.n_steps - prob.n] = first.weighted[prob.n :]  # c_t = x_t: A^T b = P_t v_t
        blocks = blocks[1:]
    for block in blocks:
        g = block.weighted
        if noise is not None:
            rng, k = noise
            # y_t ~ N(v_t, P_t^-1): P_t y_t = P_t v_t + L_t z with P_t = L_t L_t^T
            z = rng.standard_normal((block.value.shape[0], block.value.shape[1], k))
            g = g + np.swapaxes(_psd_sqrt(block.precision) @ z, 0, 2).swapaxes(1, 2)
        _rhs_add(rhs, block, g, prob.n)
    return rhs


def _psd_sqrt(prec: np.ndarray) -> np.ndarray:
    """L_t with L_t L_t^T = P_t for positive semi-definite P_t (Cholesky where definite)."""
    try:
        return np.linalg.cholesky(prec)
    except np.linalg.LinAlgError:
        w, v = np.linalg.eigh(prec)
        return v * np.sqrt(np.clip(w, 0.0, None))[:, None, :]


def _extend(prob: _Problem, c: np.ndarray, with_start: bool = False) -> np.ndarray:
    """All coefficients c_0 .. c_{N+n-2} (..., N+n-1, D) from the free ones; the fixed ones are 0
    (as in the shifted right-hand sides) or, with_start, their values."""
    ext = np.zeros((*c.shape[:-2], prob.n_steps + prob.n - 1, prob.dim))
    if with_start:
        ext[..., : prob.n, :] = prob.start
    ext[..., prob.n : prob.n_coef, :] = c
    ext[..., prob.n_coef :, :] = c[..., -1:, :]
    return ext


def _control_adjoint(prob: _Problem, e: np.ndarray) -> np.ndarray:
    """control * (Delta^n)^T e for rows e (..., N-1, D) -> (..., n_free, D).

    The adjoint of the forward difference is minus the backward difference with zero padding.
    """
    n = prob.n
    full = np.zeros((*e.shape[:-2], e.shape[-2] + 2 * n, e.shape[-1]))
    full[..., n:-n, :] = e
    full = _differences(full, n)  # on c_0 .. c_{N+n-2}
    out = full[..., n : prob.n_coef, :]
    if prob.n_coef < full.shape[-2]:  # tied tail c_{N-1} = ... = c_{N+n-2}
        out[..., -1, :] += full[..., prob.n_coef :, :].sum(axis=-2)
    return out * (prob.control if n % 2 == 0 else -prob.control)


def _normal_residual(prob: _Problem, obs: np.ndarray, rhs: np.ndarray, c: np.ndarray) -> np.ndarray:
    """rhs - H c, with the control part computed as (Delta^n)^T (Delta^n c) from differences.

    The differences of the solution are accurate to their own size, whereas the rounded normal
    matrix loses the tracking precisions next to its control entries of size ~4^n control^2.
    """
    flat = c.reshape(*c.shape[:-2], -1)
    hc = obs[0] * flat
    for off in range(1, obs.shape[0]):
        hc[..., off:] += obs[off, :-off] * flat[..., :-off]
        hc[..., :-off] += obs[off, :-off] * flat[..., off:]
    e = _differences(_extend(prob, c), prob.n)
    return rhs - hc.reshape(c.shape) - prob.control * _control_adjoint(prob, e)


def _differences(a: np.ndarray, n: int) -> np.ndarray:
    """Delta^n along axis -2 by repeated differences (each exact to its own rounding)."""
    for _ in range(n):
        a = a[..., 1:, :] - a[..., :-1, :]
    return a


# --------------------------------------------------------------------------------------------
# solvers


def _precision_loss(prob: _Problem, obs: np.ndarray) -> float:
    """eps * (a bound on cond of the normal matrix): about 10x the relative error of Cholesky.

    lambda_max <= 4^n control^2 + max row sum of |tracking part| (Gershgorin); lambda_min >= the
    smallest tracking precision when every step is tracked in position (Euler), else unknown.
    """
    if prob.floor <= 0:
        return np.inf
    ceiling = prob.ceiling
    if not ceiling >= 0:
        rows = np.abs(obs).sum(axis=0)
        for off in range(1, obs.shape[0]):
            rows[off:] += np.abs(obs[off, :-off])
        ceiling = rows.max()
    return _EPS * (4.0**prob.n * prob.control**2 + ceiling) / prob.floor


def _normal_band(prob: _Problem, obs: np.ndarray) -> np.ndarray:
    """Lower band of the normal matrix H = control^2 (Delta^n)^T Delta^n + tracking part."""
    band = prob.control**2 * _control_band(prob.n, prob.dim, prob.n_steps, prob.n_coef)
    band[: obs.shape[0]] += obs
    return band


class _Factor:
    """A factorisation of the banded problem, reused for the mean and every sample."""

    def __init__(self, prob: _Problem, method: str):
        self.prob = prob
        self.obs = _obs_band(prob)
        loss = _precision_loss(prob, self.obs)
        if method == "auto":
            # one refinement step squares the relative error (measured: < 1e-8 up to loss 1e-3)
            method = "cholesky" if loss < 1e-4 else "augmented"
        self.refine = loss > 1e-9
        self.method = method
        if method == "cholesky":
            self._factor_cholesky()
        else:
            self._factor_augmented()

    # normal equations ------------------------------------------------------------------------
    def _factor_cholesky(self) -> None:
        chol, info = lapack.dpbtrf(_normal_band(self.prob, self.obs), lower=1)
        if info != 0:
            raise SolverError(
                f"LQT normal equations not positive definite (pbtrf info {info}): too "
                "ill-conditioned for them; use solver='augmented' (and method='exact' to sample)"
            )
        self.chol = chol

    def _chol_solve(self, rhs: np.ndarray) -> np.ndarray:
        b = rhs.reshape(rhs.shape[0], -1).T if rhs.ndim == 3 else rhs.reshape(-1)
        x, info = lapack.dpbtrs(self.chol, b, lower=1)
        if info != 0:
            raise SolverError(f"LQT banded solve failed (pbtrs info {info})")
        return x.T.reshape(rhs.shape) if rhs.ndim == 3 else x.reshape(rhs.shape)

    # augmented system ------------------------------------------------------------------------
    def _factor_augmented(self) -> None:
        p = self.prob
        diag = self.obs[0][self.obs[0] > 0]
        # Bjorck's scaling: beta^2, the weight of the control residuals, at the geometric mean of
        # the extreme tracking precisions keeps K about as well conditioned as the stacked rows
        self.beta = float(np.sqrt(np.min(diag) * np.max(diag))) ** 0.5 if diag.size else 1.0
        s = _augmented_structure(p.n, p.dim, p.n_steps, p.n_coef, self.obs.shape[0] // p.dim)
        vals = np.concatenate(
            [
                self.obs[s.obs_mask],
                self.obs[s.obs_mask_upper],
                self.beta * p.control * s.ctrl_values,
                np.full(s.n_y, -(self.beta**2)),
            ]
        )
        ab = np.zeros((2 * s.kl + s.ku + 1, s.size))
        ab.flat[s.flat] = vals
        lu, piv, info = lapack.dgbtrf(ab, s.kl, s.ku)
        if info != 0:
            raise SolverError(f"LQT augmented system singular (gbtrf info {info})")
        self.lu, self.piv, self.s = lu, piv, s

    def _aug_solve(self, rhs: np.ndarray, zc: np.ndarray | None = None) -> np.ndarray:
        p, s = self.prob, self.s
        many = rhs.ndim == 3
        k = rhs.shape[0] if many else 1
        b = np.zeros((s.size, k))
        b[s.x_pos] = rhs.reshape(k, -1).T
        if zc is not None:  # control targets: beta E x - beta^2 y = beta z
            b[s.y_pos] = self.beta * np.broadcast_to(zc, (k, *zc.shape[-2:])).reshape(k, -1).T
        x, info = lapack.dgbtrs(self.lu, s.kl, s.ku, b, self.piv)
        if info != 0:
            raise SolverError(f"LQT augmented solve failed (gbtrs info {info})")
        out = x[s.x_pos].T.reshape(k, p.n_free, p.dim)
        return out if many else out[0]

    # public ----------------------------------------------------------------------------------
    def mean(self) -> np.ndarray:
        """Free coefficients (n_free, D) of the optimum."""
        if self.method == "augmented":
            return self._aug_solve(_rhs(self.prob), self.prob.control_target)
        rhs = _rhs(self.prob)
        if self.prob.control_target is not None:
            rhs += _control_adjoint(self.prob, self.prob.control_target)
        c = self._chol_solve(rhs)
        if self.refine:  # one step of iterative refinement with an accurately computed residual
            c += self._chol_solve(_normal_residual(self.prob, self.obs, rhs, c))
        return c

    def samples(self, k: int, rng: np.random.Generator) -> np.ndarray:
        """K exact draws (K, n_free, D) of the coefficients, reusing the factorisation.

        Cholesky (H = L L^T): c = c_hat + L^-T z, z ~ N(0, I), whose covariance is H^-1, the
        posterior covariance of the coefficients. Augmented: perturbation sampling, re-solving
        with targets y_t ~ N(mu_t, Sigma_t) and control residual targets z ~ N(0, I).
        """
        p = self.prob
        if self.method == "cholesky":
            z = rng.standard_normal((k, p.n_free * p.dim)).T
            dev, info = lapack.dtbtrs(self.chol, z, uplo="L", trans="T")
            if info != 0:
                raise SolverError(f"LQT banded triangular solve failed (tbtrs info {info})")
            return self.mean() + dev.T.reshape(k, p.n_free, p.dim)
        rhs = _rhs(p, noise=(rng, k))
        zc = rng.standard_normal((k, p.n_steps - 1, p.dim))
        if p.control_target is not None:
            zc += p.control_target
        return self._aug_solve(rhs, zc)


@dataclass(frozen=True)
class _AugStructure:
    size: int
    kl: int
    ku: int
    flat: np.ndarray
    obs_mask: np.ndarray
    obs_mask_upper: np.ndarray
    ctrl_values: np.ndarray
    n_y: int
    x_pos: np.ndarray
    y_pos: np.ndarray


@lru_cache(maxsize=32)
def _augmented_structure(
    n: int, dim: int, n_steps: int, n_coef: int, obs_width: int
) -> _AugStructure:
    """Index structure of K = [[H_obs, beta E^T], [beta E, -beta^2 I]] in LAPACK gb storage.

    Unknowns: the free coefficients x_i (i = n..L-1) and the whitened control residuals y_t
    (t = 0..N-2), each y_t placed beside x at the centre of its stencil so that K is banded.
    """
    n_free = n_coef - n
    rows = _control_rows(n, n_steps, n_coef)
    n_ctrl = n_steps - 1
    # ordering keys: x_i at 2 i, y_t at 2 clip(t + ceil(n / 2), n, L - 1) + 1
    x_key = np.repeat(2 * np.arange(n, n_coef), dim)
    y_key = np.repeat(2 * np.clip(np.arange(n_ctrl) + (n + 1) // 2, n, n_coef - 1) + 1, dim)
    keys = np.concatenate([x_key, y_key])
    order = np.argsort(keys, kind="stable")
    pos = np.empty_like(order)
    pos[order] = np.arange(order.size)
    x_pos, y_pos = pos[: x_key.size], pos[x_key.size :]
    size = order.size
    # tracking block entries from the lower band storage (off, col) -> (col + off, col)
    off, col = np.indices((obs_width * dim, n_free * dim))
    obs_mask = col + off < n_free * dim
    r_obs, c_obs = x_pos[(col + off)[obs_mask]], x_pos[col[obs_mask]]
    upper = obs_mask & (off > 0)
    r_up, c_up = x_pos[col[upper]], x_pos[(col + off)[upper]]
    # control entries: y_t,d with x_{t+j},d
    t, j = np.indices(rows.shape)
    i = t + j
    ok = (i >= n) & (i < n_coef)
    t, j, i = t[ok], j[ok], i[ok]
    d = np.arange(dim)
    yi = (t[:, None] * dim + d).ravel()
    xi = ((i[:, None] - n) * dim + d).ravel()
    ctrl_values = np.repeat(rows[t, j], dim)
    r_c = np.concatenate([y_pos[yi], x_pos[xi]])
    c_c = np.concatenate([x_pos[xi], y_pos[yi]])
    r_all = np.concatenate([r_obs, r_up, r_c, y_pos])
    c_all = np.concatenate([c_obs, c_up, c_c, y_pos])
    kl = int(max(np.max(r_all - c_all), 0))
    ku = int(max(np.max(c_all - r_all), 0))
    flat = (kl + ku + r_all - c_all) * size + c_all
    return _AugStructure(
        size,
        kl,
        ku,
        flat,
        obs_mask,
        upper,
        np.concatenate([ctrl_values, ctrl_values]),
        y_pos.size,
        x_pos,
        y_pos,
    )


def _positions(prob: _Problem, c_free: np.ndarray, derivative: int = 0) -> np.ndarray:
    """x^(k)_t (..., N, D) in [mm/s^k] from free coefficients (..., n_free, D)."""
    ext = _extend(prob, c_free, with_start=True)
    stencil = _state_stencils(prob.n, prob.discretisation)[derivative]
    if stencil.size == 1:
        out = ext[..., : prob.n_steps, :] * stencil[0]
    else:
        out = np.zeros((*c_free.shape[:-2], prob.n_steps, prob.dim))
        for j, a in enumerate(stencil):
            if a:
                out += a * ext[..., j : j + prob.n_steps, :]
    if derivative:
        out /= prob.dt**derivative
    if derivative == 0:
        out += prob.origin
    return out


# --------------------------------------------------------------------------------------------
# batch oracle (eq. 10-13 in square-root least-squares form)


def system_matrices(
    order: int, dim: int, dt: float, discretisation: str = "euler"
) -> tuple[np.ndarray, np.ndarray]:
    """Discrete A (nD, nD) and B (nD, D) of the integrator chain (eq. 3-4, or zero-order hold)."""
    n = order
    a_bar = np.kron(np.eye(n, k=1), np.eye(dim))
    b_bar = np.kron(np.eye(n)[:, -1:], np.eye(dim))
    if discretisation == "euler":
        return np.eye(n * dim) + dt * a_bar, dt * b_bar  # eq. 4
    big = np.zeros(((n + 1) * dim, (n + 1) * dim))
    big[: n * dim, : n * dim] = a_bar
    big[: n * dim, n * dim :] = b_bar
    e = expm(big * dt)
    return e[: n * dim, : n * dim], e[: n * dim, n * dim :]


def _batch(prob: _Problem, with_cov: bool = False):
    """Dense eq. 13 with stacked [Q^1/2 S_u; R^1/2] and lstsq; end at rest as exact constraints.

    Returns states (N, nD) relative to the origin and, with_cov, the position covariance (N D, N D).
    """
    n, dim, N, dt = prob.n, prob.dim, prob.n_steps, prob.dt
    a, b = system_matrices(n, dim, dt, prob.discretisation)
    nd = n * dim
    blocks = [b]  # A^k B, k = 0..N-2
    for _ in range(N - 2):
        blocks.append(a @ blocks[-1])
    blocks.append(np.zeros_like(b))
    lag = np.arange(N)[:, None] - 1 - np.arange(N - 1)[None, :]  # t - 1 - s
    lag[lag < 0] = N - 1  # the zero block above the diagonal
    su = np.array(blocks)[lag].transpose(0, 2, 1, 3).reshape(N * nd, (N - 1) * dim)  # eq. 11
    xi1 = np.zeros(nd)  # relative coordinates: xi_1 = (mu_1, v_1, 0, ...) becomes (0, v_1, 0, ...)
    stencil = np.zeros((n, n))
    for k, s in enumerate(_state_stencils(n, prob.discretisation)):
        stencil[k, : s.size] = s / dt**k
    xi1[:] = (stencil @ prob.start).reshape(-1)
    free = [xi1]  # S_xi xi_1 (eq. 10)
    for _ in range(N - 1):
        free.append(a @ free[-1])
    free = np.concatenate(free)
    rows, rhs = [], []
    for block in prob.blocks:
        k = block.derivative
        sel = np.zeros((dim, nd))
        sel[:, k * dim : (k + 1) * dim] = np.eye(dim)
        roots = _psd_sqrt(block.precision)
        v_all = _original_values(prob, block)
        for t, root, v in zip(block.steps, roots, v_all):
            rows.append(root.T @ sel @ su[t * nd : (t + 1) * nd])
            rhs.append(root.T @ (v - sel @ free[t * nd : (t + 1) * nd]))
    r = (prob.control * dt**n) ** 2
    rows.append(np.sqrt(r) * np.eye((N - 1) * dim))
    rhs.append(np.zeros((N - 1) * dim))
    big_a, big_b = np.vstack(rows), np.concatenate(rhs)
    if prob.end_at_rest and n > 1:
        last = su[(N - 1) * nd + dim : N * nd].copy()  # derivatives of the last state
        target = -free[(N - 1) * nd + dim : N * nd]
        norms = np.linalg.norm(last, axis=1)
        last, target = last / norms[:, None], target / norms
        basis = null_space(last)
        u0 = lstsq(last, target)[0]
        w = lstsq(big_a @ basis, big_b - big_a @ u0)[0]
        u = u0 + basis @ w
    else:
        basis = np.eye((N - 1) * dim)
        u = lstsq(big_a, big_b)[0]
    states = (su @ u + free).reshape(N, nd)
    if not with_cov:
        return states, None
    _, tri = np.linalg.qr(big_a @ basis)
    half = solve_triangular(tri, basis.T, trans="T")  # R^-T Z^T, Sigma_u = Z R^-1 R^-T Z^T
    pos_rows = np.concatenate([np.arange(t * nd, t * nd + dim) for t in range(N)])
    sx = su[pos_rows] @ half.T  # S_u Z R^-1 restricted to positions
    return states, sx @ sx.T  # eq. 15: Sigma_x = S_u Sigma_u S_u^T


def _original_values(prob: _Problem, block: _Block) -> np.ndarray:
    """The block's targets before the fixed start was folded in (the batch keeps xi_1)."""
    return block.value + _apply_fixed(block, prob.start, prob.n)


# --------------------------------------------------------------------------------------------
# public API


def solve(stroke: StrokePlan, cfg: LQTConfig = LQTConfig(), references=()) -> Trajectory:
    """The optimal (mean) trajectory of ``stroke``: t from 0 in [s], pos (N, D) in [mm], vel [mm/s].

    Each target is held segment_time / dt steps (a whole number, else PlanError), so
    N = m * segment_time / dt (key-points: (m - 1) * segment_time / dt + 1, one key-point every
    segment_time). The movement
    starts at rest on the first mean and, with ``cfg.end_at_rest``, ends at rest. With wide
    covariances (e.g. variance 100 mm^2 and d = 5 mm at order 4) the path smooths through the
    targets with about one speed peak per segment; with tight covariances it stops at every target
    and rings (the high-order chain overshoots and oscillates around each held mean).

    Args:
        stroke: Targets and timing.
        cfg: Solver settings.
        references: Extra :class:`Reference` terms (seed 000 eq. 18-21).
    """
    prob = _problem(stroke, cfg, tuple(references))
    n, dim = prob.n, prob.dim
    if cfg.solver == "batch":
        states, _ = _batch(prob)
        pos = states[:, :dim] + prob.origin
        vel = states[:, dim : 2 * dim] if n > 1 else _first_difference(prob, pos)
    else:
        pos, vel = _outputs(prob, _Factor(prob, cfg.solver).mean())
    _check_finite(pos)
    _check_finite(vel)
    return Trajectory.from_checked(_times(prob.n_steps, prob.dt), pos, vel)


@lru_cache(maxsize=32)
def _times(n_steps: int, dt: float) -> np.ndarray:
    """The time grid t_k = k dt in [s] (shared, read-only)."""
    t = np.arange(n_steps) * dt
    t.flags.writeable = False
    return t


def _outputs(prob: _Problem, c_free: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions [mm] and velocities [mm/s] (N, D) from the free coefficients."""
    if prob.discretisation == "zoh":
        pos = _positions(prob, c_free)
        return pos, (_positions(prob, c_free, 1) if prob.n > 1 else _first_difference(prob, pos))
    ext = _extend(
        prob, c_free, with_start=True
    )  # Euler: c is the position, velocity its forward difference
    vel = np.diff(ext[: prob.n_steps + 1] if prob.n > 1 else ext[: prob.n_steps], axis=0) / prob.dt
    if prob.n == 1:  # first-order chain: the velocity is the control, 0 after the last step
        vel = np.vstack([vel, np.zeros((1, prob.dim))])
    return ext[: prob.n_steps] + prob.origin, vel


def _first_difference(prob: _Problem, pos: np.ndarray) -> np.ndarray:
    """Velocity of a first-order chain: its control u_t = (x_{t+1} - x_t) / dt, 0 at the end."""
    vel = np.zeros_like(pos)
    vel[:-1] = np.diff(pos, axis=0) / prob.dt
    return vel


def _check_finite(arr: np.ndarray) -> None:
    if not np.isfinite(arr.sum()):  # NaN and inf propagate into the sum
        raise SolverError("LQT produced non-finite positions (ill-posed plan or overflow)")


def sample(
    stroke: StrokePlan,
    cfg: LQTConfig = LQTConfig(),
    k: int = 100,
    seed=None,
    method: str = "exact",
    references=(),
    components: int | None = 9,
) -> np.ndarray:
    """K draws (K, N, D) in [mm] from the trajectory distribution (seed 000 eq. 14-15, 22).

    ``method="exact"``: exact draws in O(N) each, never forming the dense covariance. In the
    banded position form the posterior of the free coefficients is N(c_hat, H^-1) with H the
    normal matrix (the image of eq. 15's Sigma_xi = S_u Sigma_u S_u^T under the invertible map
    u <-> c). With the Cholesky solver a draw is c_hat + L^-T z (H = L L^T, one banded triangular
    solve). With the augmented solver it is perturbation sampling: re-solve the same factorised
    system, all K draws as K right-hand sides, with perturbed targets y_t ~ N(mu_t, Sigma_t) and
    controls pulled towards u0 ~ N(0, R^-1); the solution is linear in (y, u0), its mean is the
    optimum and its covariance Sigma_u (S_u^T Q S_u + R) Sigma_u = Sigma_u, mapped through S_u.
    (GI eq. 22 scales Sigma_xi by a residual variance sigma; we keep sigma = 1, the MOCO form.)

    ``method="eigen"``: the paper's eq. 16-17 with the ``components`` largest eigenpairs of the
    position covariance (the smallest of the banded precision, via LAPACK); ``components=None``
    uses all of them. The paper uses 5 to 9; fewer components under-represent the variance.

    Args:
        seed: None, an int or a numpy Generator.
    """
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise InputError(f"sample k: expected a positive integer number of draws, got {k!r}")
    if method not in ("exact", "eigen"):
        raise InputError(f"sample method: expected 'exact' or 'eigen', got {method!r}")
    rng = np.random.default_rng(seed)
    prob = _problem(stroke, cfg, tuple(references))
    solver = "auto" if cfg.solver == "batch" else cfg.solver
    if method == "exact":
        factor = _Factor(prob, solver)
        c = factor.samples(int(k), rng)
        out = _positions(prob, c)
    else:
        if components is not None and (
            isinstance(components, bool)
            or not isinstance(components, (int, np.integer))
            or components < 1
        ):
            raise InputError(
                f"sample components: expected a positive integer or None, got {components!r}"
            )
        factor = _Factor(prob, "cholesky")
        band = _normal_band(prob, factor.obs)
        count = band.shape[1] if components is None else min(int(components), band.shape[1])
        # eq. 17: the largest covariance eigenpairs are the smallest of the banded precision
        lam, vec = eig_banded(band, lower=True, select="i", select_range=(0, count - 1))
        z = rng.standard_normal((int(k), count))
        draws = factor.mean().reshape(-1) + (z / np.sqrt(lam)) @ vec.T  # eq. 16
        out = _positions(prob, draws.reshape(int(k), prob.n_free, prob.dim))
    _check_finite(out)
    return out


def covariance(stroke: StrokePlan, cfg: LQTConfig = LQTConfig(), references=()) -> np.ndarray:
    """Dense position covariance (N, D, N, D) in [mm^2] from the batch form (eq. 15); small N only."""
    prob = _problem(stroke, cfg, tuple(references))
    _, cov = _batch(prob, with_cov=True)
    return cov.reshape(prob.n_steps, prob.dim, prob.n_steps, prob.dim)


def semi_tied_covariances(m: int, H, h, rho: float = 0.0, seed=None) -> np.ndarray:
    """m covariances Sigma_i = H D_i H^T with D_i = h_i I, h_i ~ N(h, rho) (seed 000 eq. 22).

    Args:
        m: Number of targets.
        H: (D, D) oblique basis, non-singular (its columns are the shared axes).
        h: Magnitude, > 0; with unit-length columns of H, Sigma_i has variances h_i in [mm^2].
        rho: Variance of the perturbation of h (eq. 22 writes N(h, rho)); 0 = all equal. Draws
            h_i <= 0 are redrawn (a covariance must stay positive definite).
        seed: None, an int or a numpy Generator.
    Returns:
        (m, D, D) symmetric positive definite covariances.
    """
    if isinstance(m, bool) or not isinstance(m, (int, np.integer)) or m < 1:
        raise InputError(f"semi_tied_covariances m: expected a positive integer, got {m!r}")
    basis = np.asarray(H, dtype=float)
    if basis.ndim != 2 or basis.shape[0] != basis.shape[1] or not 1 <= basis.shape[0] <= 3:
        raise InputError(
            f"semi_tied_covariances H: expected a square (D, D) matrix, D in 1..3, got shape {basis.shape}"
        )
    if not np.all(np.isfinite(basis)):
        raise InputError("semi_tied_covariances H: contains NaN or inf")
    if np.linalg.matrix_rank(basis) < basis.shape[0]:
        raise InputError(f"semi_tied_covariances H: singular basis {basis.tolist()}")
    if not _positive_number(h):
        raise InputError(f"semi_tied_covariances h: must be a positive number, got {h}")
    try:
        rho = float(rho)
    except (TypeError, ValueError):
        raise InputError(f"semi_tied_covariances rho: expected a number, got {rho!r}") from None
    if not np.isfinite(rho) or rho < 0:
        raise InputError(f"semi_tied_covariances rho: must be >= 0, got {rho}")
    mags = np.full(int(m), float(h))
    if rho > 0:
        rng = np.random.default_rng(seed)
        mags = rng.normal(h, np.sqrt(rho), int(m))
        for _ in range(1000):
            bad = mags <= 0
            if not bad.any():
                break
            mags[bad] = rng.normal(h, np.sqrt(rho), int(bad.sum()))
        else:
            raise InputError(
                f"semi_tied_covariances: h = {h} with rho = {rho} gives no positive draws"
            )
    covs = mags[:, None, None] * (basis @ basis.T)[None]
    for i, c in enumerate(covs):
        check_covariance(c, basis.shape[0], f"semi-tied covariance {i}")
    return 0.5 * (covs + np.swapaxes(covs, 1, 2))
