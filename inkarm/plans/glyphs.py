"""Asemic glyphs and tags (seed 000 sec. 4.2).

A glyph is m random targets drawn in polar coordinates about its centre; a genetic algorithm
orders them, maximising the distance between consecutive targets (an "inverse" travelling
salesman problem) while rewarding downward and left-to-right strokes, which a drawing hand
makes easily. The GA uses tournament selection, partially mapped crossover (PMX, Goldberg and
Lingle 1985), swap mutation and elitism. Five glyphs side by side, joined with ligatures, make
a tag that a :class:`~inkarm.plans.handstyles.Handstyle` turns into a trajectory.

Randomness comes only from the numpy Generator passed in (or seeded from an int), so a seed
reproduces a tag exactly.

Budgets (:mod:`inkarm.core.budget`): a tag's cost is estimated before the GA runs
(:func:`check_tag`): its glyphs against ``INKARM_MAX_TEXT``, the GA's individuals (glyphs x
population x (generations + 1), about 0.1 ms each) against ``INKARM_MAX_GA_INDIVIDUALS``
(:data:`GA_INDIVIDUALS`) and, given the time step, the LQT's time steps against
``INKARM_MAX_STEPS``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkarm.core.budget import GA_INDIVIDUALS, STEPS, TEXT, require
from inkarm.core.plan import MotorPlan
from inkarm.core.trajectory import A4_MM, MAX_COORD_MM, Drawing
from inkarm.errors import InputError
from inkarm.plans.handstyles import Handstyle, get_handstyle
from inkarm.plans.ligatures import join_ligatures
from inkarm.plans.targets import TargetSequence

"""Individuals the ordering GA may evaluate for one tag (about 0.1 ms each: ~30 s)."""
MAX_GLYPH_TARGETS = 1000
"""Most random targets in one glyph."""
MAX_GLYPH_SIZE = 1000.0
"""Largest glyph height in [mm]."""
MIN_GLYPH_SIZE = 0.1
"""Smallest glyph height in [mm]: below a pen's line width, and where the figure's size
underflows."""
DT_RANGE = (1e-4, 1.0)
"""Accepted LQT time steps of a tag in [s]."""

# -- the genetic algorithm ----------------------------------------------------------------


def pmx(a, b, lo: int, hi: int) -> np.ndarray:
    """Partially mapped crossover: the child of ``a`` that takes ``b``'s section [lo, hi).

    Goldberg and Lingle's procedure: for every position k of the matching section, the values
    a'[k] and b[k] swap places in the child a' (a copy of a), so the child holds b's section in
    place and keeps every other value of a at its position unless the mapping moved it. The
    other child is ``pmx(b, a, lo, hi)``.

    Args:
        a, b: Permutations of 0..m-1, (m,).
        lo, hi: The matching section, 0 <= lo <= hi <= m.
    """
    a = np.asarray(a)
    b = np.asarray(b)
    m = a.shape[0]
    if a.shape != (m,) or b.shape != (m,):
        raise InputError(
            f"pmx: parents must be 1-D of equal length, got shapes {a.shape} and {b.shape}"
        )
    if not (np.array_equal(np.sort(a), np.arange(m)) and np.array_equal(np.sort(b), np.arange(m))):
        raise InputError(
            f"pmx: parents must be permutations of 0..{m - 1}, got {a.tolist()} and {b.tolist()}"
        )
    if not 0 <= lo <= hi <= m:
        raise InputError(f"pmx: section [{lo}, {hi}) is not within 0..{m}")
    return _pmx(a.tolist(), b.tolist(), lo, hi)


def _pmx(a, b, lo: int, hi: int) -> np.ndarray:
    """:func:`pmx` without the checks (the GA's inner loop); ``where`` tracks each value's
    position in the child so every exchange is O(1)."""
    child = list(a)
    where = [0] * len(child)
    for i, v in enumerate(child):
        where[v] = i
    for k in range(lo, hi):
        v, u = b[k], child[k]
        j = where[v]
        child[k], child[j] = v, u
        where[v], where[u] = k, j
    return np.array(child)


def tournament(fitness: np.ndarray, size: int, rng: np.random.Generator) -> int:
    """Index of the fittest of ``size`` individuals drawn uniformly (with replacement)."""
    entrants = rng.integers(len(fitness), size=size)
    return int(entrants[np.argmax(fitness[entrants])])


def swap_mutation(order: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A copy of ``order`` with two distinct positions exchanged."""
    out = order.copy()
    i, j = rng.choice(len(order), size=2, replace=False)
    out[i], out[j] = out[j], out[i]
    return out


def ordering_fitness(points: np.ndarray, orders, direction_weight: float = 0.5):
    """Fitness of visiting ``points`` (m, 2) [mm] in ``orders`` (m,) or (P, m); higher is better.

        f = mean_i |v_i| / r  +  w * mean_i (max(0, -v_i,y) + max(0, v_i,x)) / |v_i|

    with v_i = p_{order[i+1]} - p_{order[i]} and r the largest distance of a point from the
    points' centroid: the first term is the (scale-free) distance between consecutive targets,
    the second rewards strokes going down (page y points up) and to the right. Returns a float
    for one order, an array (P,) for P orders.
    """
    orders = np.asarray(orders)
    p = points[orders]
    v = np.diff(p, axis=-2)
    length = np.linalg.norm(v, axis=-1)
    r = max(float(np.max(np.linalg.norm(points - points.mean(axis=0), axis=1))), 1e-12)
    unit = v / np.maximum(length, 1e-12)[..., None]
    direction = np.maximum(0.0, -unit[..., 1]) + np.maximum(0.0, unit[..., 0])
    f = np.mean(length, axis=-1) / r + direction_weight * np.mean(direction, axis=-1)
    return float(f) if orders.ndim == 1 else f


@dataclass(frozen=True)
class GAConfig:
    """Settings of the ordering GA.

    Attributes:
        population: Individuals per generation.
        generations: Generations after the initial one.
        tournament: Tournament size.
        crossover_rate: Probability that two parents are crossed (PMX) rather than copied.
        mutation_rate: Probability that a child gets a swap mutation.
        elite: Best individuals copied unchanged to the next generation (>= 1 keeps the best
            fitness from ever decreasing).
        direction_weight: w in :func:`ordering_fitness`.
    """

    population: int = 40
    generations: int = 50
    tournament: int = 3
    crossover_rate: float = 0.9
    mutation_rate: float = 0.5
    elite: int = 2
    direction_weight: float = 0.5

    def __post_init__(self) -> None:
        for key in ("population", "generations", "tournament", "elite"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise InputError(f"GAConfig {key}: expected a non-negative integer, got {value!r}")
        if self.population < 2 or not 1 <= self.tournament <= self.population:
            raise InputError(
                f"GAConfig: population must be >= 2 and tournament >= 1 and at most the "
                f"population, got {self.population} and {self.tournament}"
            )
        if self.elite > self.population:
            raise InputError(
                f"GAConfig elite: {self.elite} exceeds the population {self.population}"
            )
        for key in ("crossover_rate", "mutation_rate"):
            value = getattr(self, key)
            if not 0.0 <= value <= 1.0:
                raise InputError(f"GAConfig {key}: expected a probability in [0, 1], got {value}")


@dataclass(frozen=True)
class Evolution:
    """Result of :func:`evolve_order`: the best order and the best fitness per generation
    (generation 0 first)."""

    order: np.ndarray
    fitness: float
    history: np.ndarray


def evolve_order(
    points: np.ndarray, rng: np.random.Generator, cfg: GAConfig = GAConfig()
) -> Evolution:
    """Order ``points`` (m, 2) by the GA of seed 000 sec. 4.2 (see module docstring)."""
    m = len(points)
    if m < 2:
        raise InputError(f"evolve_order: need at least 2 points, got {m}")
    require(cfg.population * (cfg.generations + 1), GA_INDIVIDUALS,
            f"ordering GA of {cfg.population} individuals over {cfg.generations} generations",
            key="population", value=cfg.population)

    def score(pop: list[np.ndarray]) -> np.ndarray:
        return ordering_fitness(points, np.array(pop), cfg.direction_weight)

    pop = [rng.permutation(m) for _ in range(cfg.population)]
    fit = score(pop)
    history = [fit.max()]
    for _ in range(cfg.generations):
        ranked = np.argsort(-fit, kind="stable")
        children = [pop[i].copy() for i in ranked[: cfg.elite]]
        while len(children) < cfg.population:
            a = pop[tournament(fit, cfg.tournament, rng)]
            b = pop[tournament(fit, cfg.tournament, rng)]
            if rng.random() < cfg.crossover_rate:
                lo, hi = sorted(rng.integers(0, m + 1, size=2))
                pair = [_pmx(a, b, lo, hi), _pmx(b, a, lo, hi)]
            else:
                pair = [a.copy(), b.copy()]
            for child in pair:
                if rng.random() < cfg.mutation_rate:
                    child = swap_mutation(child, rng)
                children.append(child)
        pop = children[: cfg.population]
        fit = score(pop)
        history.append(fit.max())
    best = int(np.argmax(fit))
    return Evolution(pop[best], float(fit[best]), np.array(history))


# -- glyphs and tags ----------------------------------------------------------------------


def polar_targets(
    m: int, radius: float, rng: np.random.Generator, inner: float = 0.25
) -> np.ndarray:
    """m random points (m, 2) [mm] about the origin: angle ~ U[0, 2 pi), radius ~
    U[inner, 1] x ``radius`` [mm] (seed 000 Fig. 11a)."""
    angle = rng.uniform(0.0, 2.0 * np.pi, m)
    r = radius * rng.uniform(inner, 1.0, m)
    return np.column_stack([r * np.cos(angle), r * np.sin(angle)])


@dataclass(frozen=True)
class Tag:
    """An asemic tag: the motor plan and how it was made.

    Attributes:
        plan: One stroke (the five glyphs joined by ligatures).
        points: Per glyph, its random targets in page [mm], (m_k, 2), in drawing order.
        evolutions: Per glyph, the GA result (order and fitness history).
        style: The handstyle that set the covariances.
    """

    plan: MotorPlan
    points: tuple[np.ndarray, ...]
    evolutions: tuple[Evolution, ...]
    style: Handstyle

    def realise(self, dt: float = 0.01, page_size: tuple[float, float] = A4_MM) -> Drawing:
        """The tag as a Drawing (the LQT with the tag's style); its time steps are checked
        against ``INKARM_MAX_STEPS`` first."""
        if isinstance(dt, (int, float)) and np.isfinite(dt) and dt > 0:
            targets = sum(len(s.targets) for s in self.plan.strokes)
            per = max(1.0, self.style.segment_time / dt)
            require(targets * per, STEPS, f"LQT of {targets} targets, "
                    f"{self.style.segment_time:g} s each at dt = {dt:g} s", key="dt", value=dt)
        return self.style.realise(self.plan, dt=dt, page_size=page_size)


def check_tag(
    style: Handstyle | None = None,
    n_glyphs: int = 5,
    targets: tuple[int, int] = (4, 7),
    size: float = 12.0,
    ga: GAConfig = GAConfig(),
    dt: float | None = None,
) -> None:
    """Refuse a tag before any work: bad settings (:class:`InputError` with the ``key`` of
    the argument of :func:`make_tag`, or ``dt``) and costs over the budgets (module
    docstring); the LQT's time steps are estimated only given ``style`` and ``dt``."""
    if isinstance(n_glyphs, bool) or not isinstance(n_glyphs, (int, np.integer)) or n_glyphs < 1:
        raise InputError(f"make_tag: n_glyphs must be >= 1, got {n_glyphs}", key="n_glyphs",
                         value=n_glyphs)
    lo, hi = targets
    if not 2 <= lo <= hi <= MAX_GLYPH_TARGETS:
        raise InputError(
            f"make_tag: targets per glyph must satisfy 2 <= min <= max <= {MAX_GLYPH_TARGETS}, "
            f"got {targets}", key="targets", value=targets,
        )
    if not (isinstance(size, (int, float)) and MIN_GLYPH_SIZE <= size <= MAX_GLYPH_SIZE):
        raise InputError(
            f"make_tag: glyph size must be in [{MIN_GLYPH_SIZE:g}, {MAX_GLYPH_SIZE:g}] mm, got "
            f"{size} mm", key="size", value=size,
        )
    require(n_glyphs, TEXT, f"a tag of {n_glyphs} glyphs", key="n_glyphs", value=n_glyphs)
    if n_glyphs * 0.8 * size > MAX_COORD_MM:
        raise InputError(
            f"make_tag: {n_glyphs} glyphs of {size:g} mm span {n_glyphs * 0.8 * size:g} mm, "
            f"more than {MAX_COORD_MM:g} mm", key="size", value=size,
        )
    if style is not None and dt is not None:
        if not (isinstance(dt, (int, float)) and np.isfinite(dt) and dt > 0):
            raise InputError(f"must be a positive number of seconds, got {dt}", key="dt",
                             value=dt)
        if not DT_RANGE[0] <= dt <= DT_RANGE[1]:
            raise InputError(f"must lie in [{DT_RANGE[0]:g}, {DT_RANGE[1]:g}] s, got {dt:g}",
                             key="dt", value=dt)
        per = max(1.0, style.segment_time / dt)
        require(n_glyphs * hi * per, STEPS,
                f"LQT of {n_glyphs} glyphs of up to {hi} targets, {style.segment_time:g} s "
                f"each at dt = {dt:g} s", key="dt", value=dt)
    require(n_glyphs * ga.population * (ga.generations + 1), GA_INDIVIDUALS,
            f"ordering GA of {n_glyphs} glyphs, {ga.population} individuals over "
            f"{ga.generations} generations each", key="n_glyphs", value=n_glyphs)


def make_tag(
    style: Handstyle | str,
    seed: int | np.random.Generator = 0,
    n_glyphs: int = 5,
    targets: tuple[int, int] = (4, 7),
    size: float = 12.0,
    origin: tuple[float, float] | None = None,
    page_size: tuple[float, float] = A4_MM,
    ga: GAConfig = GAConfig(),
) -> Tag:
    """A tag of ``n_glyphs`` GA-ordered random glyphs joined into one ligatured stroke.

    Args:
        style: The :class:`~inkarm.plans.handstyles.Handstyle` (covariances, timing,
            ligature angle), or a preset's name.
        seed: Seed or numpy Generator; the only source of randomness.
        n_glyphs: Glyphs in the tag (seed 000 Fig. 11d uses five).
        targets: Inclusive range of the number of targets per glyph.
        size: Glyph height in [mm] (twice the polar radius); glyphs advance by 0.8 x size.
        origin: Centre of the first glyph in [mm]; None centres the tag on the page.
        page_size: (width, height) of the page in [mm].
        ga: GA settings.
    """
    style = get_handstyle(style) if isinstance(style, str) else style
    check_tag(style, n_glyphs, targets, size, ga)
    lo, hi = targets
    rng = np.random.default_rng(seed)
    advance = 0.8 * size
    if origin is None:
        origin = (page_size[0] / 2 - advance * (n_glyphs - 1) / 2, page_size[1] / 2)
    pieces, points, evolutions = [], [], []
    for k in range(n_glyphs):
        raw = polar_targets(int(rng.integers(lo, hi + 1)), size / 2, rng)
        evo = evolve_order(raw, rng, ga)
        pts = raw[evo.order] + (origin[0] + k * advance, origin[1])
        pieces.append(TargetSequence(pts, np.full(len(pts), k), np.zeros(len(pts), bool)))
        points.append(pts)
        evolutions.append(evo)
    joined = join_ligatures(pieces, max_gap=np.inf, max_turn=style.ligature_angle)
    return Tag(style.motor_plan(joined, rng, "glyphs"), tuple(points), tuple(evolutions), style)
