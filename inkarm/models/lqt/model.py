"""The LQT of one stroke as an object (:class:`LQT`), and the functional API over it."""

from __future__ import annotations

import math
from functools import cached_property, lru_cache

import numpy as np

from inkarm.core.plan import StrokePlan
from inkarm.core.trajectory import Trajectory
from inkarm.errors import InputError, SolverError
from inkarm.models.lqt import cost, oracle, structure
from inkarm.models.lqt.config import DEFAULT_CONFIG, LQTConfig
from inkarm.models.lqt.problem import Problem, build_problem, positions
from inkarm.models.lqt.solvers import Factor, eigen_draws

SAMPLING = ("exact", "eigen")


class LQT:
    """The trajectory distribution of one stroke (seed 000 eq. 13-15), solved once.

    The banded problem is built (and every input checked, the time steps and the memory of
    the solve against their budgets, :mod:`.cost`) at construction; it is factorised
    at most once, on first use, and the mean, every call to :meth:`sample` and
    :meth:`covariance` reuse that factorisation. A stroke of a shape solved before (same
    configuration, timing and covariances, :mod:`.structure`) reuses that shape's problem
    structure and factorisation: only its means are checked and assembled. With
    ``config.solver == "batch"`` the mean
    and covariance come from the dense oracle (:mod:`.oracle`) and draws from the ``"auto"``
    factorisation.

    Args:
        stroke: Targets and timing.
        config: Solver settings.
        references: Extra :class:`Reference` terms (seed 000 eq. 18-21).
    """

    def __init__(
        self, stroke: StrokePlan, config: LQTConfig = DEFAULT_CONFIG, references=()
    ) -> None:
        self.stroke = stroke
        self.config = config
        self.references = tuple(references)
        self._factor: Factor | None = None
        self._c: np.ndarray | None = None
        self._problem: Problem | None = None
        key = structure.shape_key(stroke, config, self.references)
        self._structure = structure.find(key, stroke)
        if self._structure is None:
            self._problem = build_problem(stroke, config, self.references)
            self._structure = structure.remember(key, self._problem)
        if config.solver == "batch":
            prob = self.problem
            cost.require(
                cost.batch_bytes(prob.n_steps, prob.dim, prob.n),
                f"memory of the dense LQT oracle ({prob.n_steps} steps x {prob.dim}-D, "
                f"order {prob.n}; O(N^2), use another solver)",
            )
            cost.require_time(
                cost.batch_seconds(prob.n_steps, prob.dim),
                f"time of the dense LQT oracle ({prob.n_steps} steps x {prob.dim}-D; "
                f"O((N D)^3), use another solver)", key="solver", value="batch",
            )

    @property
    def problem(self) -> Problem:
        """The banded problem of the stroke (:mod:`.problem`); for a kept shape, assembled from
        its structure on first use (the mean of held targets needs their A^T b only)."""
        if self._problem is None:
            self._problem = self._structure.problem(self.stroke)
        return self._problem

    @property
    def method(self) -> str:
        """``"cholesky"`` or ``"augmented"``: the factorisation used (or that will be)."""
        if self._factor is not None:
            return self._factor.method
        prob = self.problem
        solver = "auto" if self.config.solver == "batch" else self.config.solver
        return cost.expected_method(solver, prob.n, prob.control, prob.floor, prob.ceiling)

    @property
    def factor(self) -> Factor:
        """The banded factorisation (computed on first use, then kept, with the shape's
        structure where it is kept)."""
        if self._factor is None:
            solver = "auto" if self.config.solver == "batch" else self.config.solver
            if self._structure is None:
                self._factor = Factor(self.problem, solver)
            else:
                self._factor = self._structure.factor(solver)
        return self._factor

    @property
    def _coefficients(self) -> np.ndarray:
        """Free coefficients (n_free, D) of the optimum (computed once)."""
        if self._c is None:
            kept = self._structure
            if self._problem is None and kept.held:  # the template's rows, this stroke's b
                self._c = self.factor.mean(kept.template, kept.rhs(self.stroke))
            else:
                self._c = self.factor.mean(self.problem)
        return self._c

    @cached_property
    def _batch_states(self) -> np.ndarray:
        """States (N, nD) of the dense oracle (solver "batch")."""
        return oracle.batch(self.stroke, self.config, self.references)[0]

    @property
    def _shape(self) -> Problem:
        """The stroke's problem if assembled, else its kept shape's template (the same rows,
        time grid and structure; other means)."""
        return self._structure.template if self._problem is None else self._problem

    @property
    def times(self) -> np.ndarray:
        """t_k = k dt in [s], (N,) (shared, read-only)."""
        return _times(self._shape.n_steps, self._shape.dt)

    def mean(self) -> Trajectory:
        """The optimal (mean) trajectory: t from 0 in [s], pos (N, D) in [mm], vel [mm/s].

        Each target is held segment_time / dt steps (a whole number, else PlanError), so
        N = m segment_time / dt (key-points: (m - 1) segment_time / dt + 1, one key-point every
        segment_time). The movement starts at rest on the first mean (or moving, when the first
        key-point prescribes a velocity) and, with ``end_at_rest``, ends at rest (unless the
        last step prescribes a non-zero velocity, see :func:`.config.rests_at_end`). With wide covariances (e.g. variance 100 mm^2 and
        d = 5 mm at order 4) the path smooths through the targets with about one speed peak
        per segment; with tight covariances it stops at every target and rings (the
        high-order chain overshoots and oscillates around each held mean).
        """
        if self.config.solver != "batch":
            c = self._coefficients
            shape = self._shape
            pos, vel = _outputs(shape, c, self.stroke.means[0])
            return Trajectory.from_checked(_times(shape.n_steps, shape.dt), pos, vel)
        prob = self.problem
        states = self._batch_states
        pos = states[:, : prob.dim].copy()
        vel = states[:, prob.dim : 2 * prob.dim].copy() if prob.n > 1 else _control(prob, pos)
        _check_finite(pos)
        _check_finite(vel)
        return Trajectory.from_checked(_times(prob.n_steps, prob.dt), pos, vel)

    def sample(
        self, k: int = 100, seed=None, method: str = "exact", components: int | None = 9
    ) -> np.ndarray:
        """K draws (K, N, D) of the position path in [mm] (seed 000 eq. 14-15).

        ``method="exact"``: exact draws in O(N) each, never forming the dense covariance
        (:meth:`Factor.samples`). (GI eq. 22 scales Sigma_xi by a residual variance sigma; we
        keep sigma = 1, the MOCO form.) ``method="eigen"``: the paper's eq. 16-17 with the
        ``components`` largest eigenpairs of the covariance, None = all of them; the paper uses
        5 to 9, and fewer components under-represent the variance.

        Args:
            k: Number of draws; their memory (:mod:`.cost`:
                about 8 k N D (4 or 7) bytes exact, plus 8 (N D)^2 for eigen) is checked
                against INKARM_MAX_MEMORY_MB before drawing, and for eigen its O((N D)^3)
                time (about 0.3 ns (N D)^3, 2.5 ns with all components) against
                INKARM_MAX_COMPUTE_S.
            seed: None, an int or a numpy Generator.
        """
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
            raise InputError(
                f"expected a positive integer number of draws, got {k!r}", key="k", value=k
            )
        if method not in SAMPLING:
            raise InputError(
                f"expected 'exact' or 'eigen', got {method!r}",
                key="method",
                value=method,
                choices=SAMPLING,
            )
        if components is not None and (
            isinstance(components, bool)
            or not isinstance(components, (int, np.integer))
            or components < 1
        ):
            raise InputError(
                f"expected a positive integer or None, got {components!r}",
                key="components",
                value=components,
            )
        prob = self.problem
        cost.require(
            cost.sample_bytes(int(k), prob.n_steps, prob.dim, self.method, method),
            f"memory of {int(k)} {method} draws of the LQT ({prob.n_steps} steps x "
            f"{prob.dim}-D)",
        )
        if method == "eigen":
            size = prob.n_free * prob.dim
            cost.require_time(
                cost.eigen_seconds(prob.n_steps, prob.dim, components),
                f"time of {int(k)} eigen draws of the LQT ({prob.n_steps} steps x {prob.dim}-D: "
                f"{'all' if components is None else components} eigenpairs of a dense {size} x "
                f"{size} matrix, O((N D)^3); method='exact', the default, draws in O(N))",
                key="method", value=method,
            )
        rng = np.random.default_rng(seed)
        if method == "exact":
            c = self.factor.samples(int(k), rng, self._coefficients, self.problem)
        else:
            c = eigen_draws(self.factor, self._coefficients, int(k), components, rng)
        out = positions(self.problem, c)
        _check_finite(out)
        return out

    def covariance(self) -> np.ndarray:
        """Dense position covariance (N, D, N, D) in [mm^2] (seed 000 eq. 15).

        From the factorisation: Sigma_x = M H^-1 M^T, H^-1 the posterior covariance of the
        free coefficients and M their linear map to positions; O(N^2) memory, about
        8 (N D)^2 (4 or 6) bytes (:mod:`.cost`), checked against INKARM_MAX_MEMORY_MB first,
        and O((N D)^3) time, checked against INKARM_MAX_COMPUTE_S.
        """
        prob = self.problem
        n, d = prob.n_steps, prob.dim
        batch = self.config.solver == "batch"
        cost.require(
            cost.batch_bytes(n, d, prob.n, with_cov=True) if batch
            else cost.covariance_bytes(n, d, self.method),
            f"memory of the dense LQT covariance ({n} steps x {d}-D: ({n * d})^2 entries)",
        )
        cost.require_time(
            cost.batch_seconds(n, d, with_cov=True) if batch
            else cost.covariance_seconds(n, d, self.method),
            f"time of the dense LQT covariance ({n} steps x {d}-D: O((N D)^3) with N D = "
            f"{n * d})",
        )
        if batch:
            cov = oracle.batch(self.stroke, self.config, self.references, with_cov=True)[1]
            return cov.reshape(n, d, n, d)
        inv = self.factor.inverse()  # H^-1, (K, K)
        size = inv.shape[0]
        half = positions(prob, inv.reshape(size, prob.n_free, d), affine=False)  # (M H^-1)^T
        cov = positions(prob, half.reshape(size, n * d).T.reshape(n * d, prob.n_free, d),
                        affine=False).reshape(n * d, n * d)
        cov = 0.5 * (cov + cov.T)
        _check_finite(cov)
        return cov.reshape(n, d, n, d)


def solve(stroke: StrokePlan, cfg: LQTConfig = DEFAULT_CONFIG, references=()) -> Trajectory:
    """The optimal (mean) trajectory of ``stroke``: ``LQT(stroke, cfg, references).mean()``."""
    return LQT(stroke, cfg, references).mean()


def sample(
    stroke: StrokePlan,
    cfg: LQTConfig = DEFAULT_CONFIG,
    k: int = 100,
    seed=None,
    method: str = "exact",
    references=(),
    components: int | None = 9,
) -> np.ndarray:
    """K draws (K, N, D) in [mm]: ``LQT(stroke, cfg, references).sample(k, seed, method,
    components)`` (seed 000 eq. 14-17)."""
    return LQT(stroke, cfg, references).sample(k, seed, method, components)


def covariance(stroke: StrokePlan, cfg: LQTConfig = DEFAULT_CONFIG, references=()) -> np.ndarray:
    """Dense position covariance (N, D, N, D) in [mm^2]: ``LQT(stroke, cfg,
    references).covariance()`` (eq. 15)."""
    return LQT(stroke, cfg, references).covariance()


@lru_cache(maxsize=32)
def _times(n_steps: int, dt: float) -> np.ndarray:
    """The time grid t_k = k dt in [s] (shared, read-only)."""
    t = np.arange(n_steps) * dt
    t.flags.writeable = False
    return t


def _outputs(prob: Problem, c_free: np.ndarray, origin: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
    """Positions [mm] and velocities [mm/s] (N, D) from the free coefficients, checked
    finite (SolverError). ``origin``: mu_1 [mm]; an Euler ``prob`` may be the template of the
    stroke's shape (:mod:`.structure`: all but the origin and the targets are the stroke's)."""
    if prob.discretisation == "zoh":
        pos = positions(prob, c_free)
        vel = positions(prob, c_free, 1) if prob.n > 1 else _control(prob, pos)
        _check_finite(pos)
        _check_finite(vel)
        return pos, vel
    # Euler: c_t is x_t; x_0 .. x_N from the fixed start, the free c and the tied tail (at
    # rest, and for n = 1: the velocity is the control, 0 after the last step)
    n, n_steps = prob.n, prob.n_steps
    ext = np.zeros((n_steps + 1, prob.dim))
    if prob.control_target is not None:  # a moving start: its fixed c_0 .. c_{n-1} are not 0
        ext[:n] = prob.start
    last = min(prob.n_coef, n_steps + 1)
    ext[n:last] = c_free[: last - n]
    ext[last:] = c_free[-1]
    vel = ext[1:] - ext[:-1]
    vel /= prob.dt
    _check_finite(vel)  # every position enters a velocity: non-finite ones show there
    return ext[:n_steps] + origin, vel


def _control(prob: Problem, pos: np.ndarray) -> np.ndarray:
    """Velocity of a first-order chain: its control u_t = (x_{t+1} - x_t) / dt, 0 at the end."""
    vel = np.zeros_like(pos)
    vel[:-1] = np.diff(pos, axis=0) / prob.dt
    return vel


def _check_finite(arr: np.ndarray) -> None:
    if not math.isfinite(arr.sum()):  # NaN and inf propagate into the sum
        raise SolverError("LQT produced non-finite values (ill-posed plan or overflow)")
