"""The part of an LQT solve that strokes of one shape share, kept between calls: the
problem's structure, the factorisation of its normal matrix and the refinement rule.

H = control^2 (Delta^n)^T Delta^n + sum_t A_t^T P_t A_t (seed 000 eq. 6-9, :mod:`.normal`) and
its factor depend on the configuration, the time grid and the targets' precisions, never on the
means, which enter the right-hand side A^T b only. A stroke's *shape* (configuration,
segment_time, key-points, the covariances (m, D, D)) keys a small LRU of :class:`Structure`.
A stroke whose shape is known is checked for its means only (its covariances and time grid
passed before) and solved with the kept factor: the mean costs the banded back-substitutions
and O(N) NumPy, no assembly and no factorisation. Where the only rows track targets held at
every step (Euler, the usual plans: :func:`.normal.held_targets`), A^T b comes straight from
the means (:meth:`Structure.rhs`) and the stroke's problem is assembled only for draws or the
covariance. In ``inkarm write`` the words of one
handstyle with as many targets share a shape (measured: 97 % of the 790 strokes of 2,000
characters of pangrams hit, 2 of the 16 of one sentence; none where rho > 0 perturbs every
covariance); ``inkarm draw`` solves one stroke per process, so there nothing repeats.

Strokes with velocities or extra references are not kept (their fixed start and extra rows
depend on the values). Bounded: at most :data:`MAX_ENTRIES` shapes and :data:`MAX_MB` of
estimated solve memory (:func:`.cost.solve_bytes`), the least recently used dropped first.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from inkarm.core import budget
from inkarm.core.plan import StrokePlan
from inkarm.models.lqt import cost
from inkarm.models.lqt.config import LQTConfig, check_stroke_ranges
from inkarm.models.lqt.normal import held_rhs, held_targets
from inkarm.models.lqt.problem import Problem
from inkarm.models.lqt.solvers import Factor

MAX_ENTRIES = 64
MAX_MB = 64.0

_CACHE: OrderedDict[tuple, Structure] = OrderedDict()  # each of its operations is atomic


class Structure:
    """The shape of a stroke's problem (every part of :class:`.Problem` but the means) and its
    factorisations, made once and shared by the strokes of that shape.

    Attributes:
        template: The problem of the first stroke of this shape.
        solve_bytes: Estimated memory of a solve [bytes] (:func:`.cost.solve_bytes`).
        held: Whether its only rows track held targets at every step (Euler,
            :func:`.normal.held_targets`): a mean then needs :meth:`rhs`, not :meth:`problem`.
    """

    def __init__(self, template: Problem, solve_bytes: float) -> None:
        self.template = template
        self.solve_bytes = solve_bytes
        self.held = held_targets(template)
        self._factors: dict[str, Factor] = {}

    @staticmethod
    def values(stroke: StrokePlan, precisions: np.ndarray) -> tuple:
        """The origin mu_1 (D,), the targets' values v_i = mu_i - mu_1 (m, D) and P_i v_i
        (m, D) [mm^-1] (eq. 6) of ``stroke`` under the shape's ``precisions`` (m, D, D)."""
        means = stroke.means
        origin = means[0]
        shifted = means - origin
        return origin, shifted, (precisions @ shifted[:, :, None])[:, :, 0]

    def rhs(self, stroke: StrokePlan) -> np.ndarray:
        """A^T b (n_free, D) of ``stroke`` for a shape of held targets (:attr:`held`), the
        rows of the template and the means of ``stroke``, without assembling its problem."""
        first = self.template.blocks[0]
        weighted = self.values(stroke, first.targets_precision)[2]
        return held_rhs(self.template, weighted, first.repeat)

    def problem(self, stroke: StrokePlan) -> Problem:
        """The problem of ``stroke`` (this shape): the template with the origin mu_1 and the
        targets' values v_i = mu_i - mu_1, P_i v_i (eq. 6) of ``stroke``."""
        first = self.template.blocks[0]
        origin, shifted, weighted = self.values(stroke, first.targets_precision)
        block = first.with_values(shifted, weighted)
        prob = object.__new__(Problem)  # a copy of the (frozen) template with two fields new
        prob.__dict__.update(self.template.__dict__, origin=origin, blocks=(block,))
        return prob

    def factor(self, solver: str) -> Factor:
        """The factorisation for ``solver`` (``"auto"``, ``"cholesky"`` or ``"augmented"``),
        made on first use and kept."""
        factor = self._factors.get(solver)
        if factor is None:
            factor = self._factors[solver] = Factor(self.template, solver)
        return factor

    def within_budgets(self) -> bool:
        """Whether the steps and the memory of a solve still fit INKARM_MAX_STEPS and
        INKARM_MAX_MEMORY_MB (settings may change between calls; the full build raises)."""
        return (self.template.n_steps <= budget.STEPS.value
                and self.solve_bytes / budget.MB <= budget.MEMORY_MB.value)


def shape_key(stroke, cfg, references: tuple) -> tuple | None:
    """The key of ``stroke``'s shape under ``cfg``; None where it is not kept (velocities,
    references, or inputs that are not a StrokePlan and an LQTConfig)."""
    if references or not isinstance(stroke, StrokePlan) or not isinstance(cfg, LQTConfig):
        return None
    if stroke.velocities is not None:
        return None
    covs = stroke.covs
    return (cfg.solver, cfg.order, cfg.dt, cfg.d, cfg.r, cfg.discretisation, cfg.end_at_rest,
            stroke.segment_time, stroke.keypoints, covs.shape, covs.tobytes())


def find(key: tuple | None, stroke: StrokePlan) -> Structure | None:
    """The kept structure of ``key`` whose budgets still hold, with ``stroke``'s means checked
    (:func:`.config.check_stroke_ranges`, means only: the covariances are the kept ones);
    None when unknown."""
    found = None if key is None else _CACHE.get(key)
    if found is None or not found.within_budgets():
        return None
    try:
        _CACHE.move_to_end(key)
    except KeyError:  # dropped meanwhile by another thread: still valid for this call
        pass
    check_stroke_ranges(stroke, means_only=True)
    return found


def remember(key: tuple | None, prob: Problem) -> Structure | None:
    """Keep the structure of ``prob`` (a problem built for ``key``'s stroke) under ``key``."""
    if key is None:
        return None
    method = cost.expected_method(key[0], prob.n, prob.control, prob.floor, prob.ceiling)
    found = Structure(prob, cost.solve_bytes(prob.n_steps, prob.dim, prob.n, method))
    if found.solve_bytes > MAX_MB * budget.MB:
        return found
    _CACHE[key] = found
    while len(_CACHE) > MAX_ENTRIES or _kept_bytes() > MAX_MB * budget.MB:
        try:
            _CACHE.popitem(last=False)
        except KeyError:  # emptied meanwhile by another thread
            break
    return found


def clear() -> None:
    """Forget every kept structure."""
    _CACHE.clear()


def _kept_bytes() -> float:
    return sum(s.solve_bytes for s in list(_CACHE.values()))  # list(): one atomic snapshot
