"""Asemic glyphs: PMX, tournament selection, the ordering GA with elitism, tags (seed 000 sec. 4.2)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.errors import InputError
from inkarm.plans.glyphs import (
    GAConfig,
    evolve_order,
    make_tag,
    ordering_fitness,
    pmx,
    polar_targets,
    swap_mutation,
    tournament,
)
from inkarm.plans.handstyles import PRESETS


def _pmx_by_mapping(a, b, lo, hi):
    """Slow reference PMX: copy b's section, fill the rest from a, repairing duplicates by
    following the section's mapping b[k] -> a[k] until a value outside the section is found."""
    child = [None] * len(a)
    child[lo:hi] = b[lo:hi]
    mapping = {b[k]: a[k] for k in range(lo, hi)}
    for k in list(range(lo)) + list(range(hi, len(a))):
        v = a[k]
        while v in mapping:
            v = mapping[v]
        child[k] = v
    return child


# -- PMX ----------------------------------------------------------------------------------


def test_pmx_hand_worked_example():
    # Worked by hand with Goldberg and Lingle's position-wise exchanges, section [3, 6):
    #   a' = 0 1 2 | 3 4 5 | 6 7, take b's 1 6 0:
    #   swap 3<->1: 0 3 2 1 4 5 6 7;  swap 4<->6: 0 3 2 1 6 5 4 7;  swap 5<->0: 5 3 2 1 6 0 4 7
    a = [0, 1, 2, 3, 4, 5, 6, 7]
    b = [3, 7, 5, 1, 6, 0, 2, 4]
    assert pmx(a, b, 3, 6).tolist() == [5, 3, 2, 1, 6, 0, 4, 7]
    # the other child, b' taking a's 3 4 5: swap 1<->3, 6<->4, 0<->5 in b
    #   3 7 5 1 6 0 2 4 -> 1 7 5 3 6 0 2 4 -> 1 7 5 3 4 0 2 6 -> 1 7 0 3 4 5 2 6
    assert pmx(b, a, 3, 6).tolist() == [1, 7, 0, 3, 4, 5, 2, 6]


def test_pmx_follows_a_chain_of_mappings():
    # section [0, 2) of b = 2 0 1 4 3 into a = 0 1 2 3 4: 0->2 then 1->0->2 (a chain)
    #   swap 0<->2: 2 1 0 3 4;  swap 1<->0: 2 0 1 3 4
    assert pmx([0, 1, 2, 3, 4], [2, 0, 1, 4, 3], 0, 2).tolist() == [2, 0, 1, 3, 4]
    # the other child, a's 0 1 into b = 2 0 1 4 3: swap 2<->0: 0 2 1 4 3; swap 2<->1: 0 1 2 4 3
    assert pmx([2, 0, 1, 4, 3], [0, 1, 2, 3, 4], 0, 2).tolist() == [0, 1, 2, 4, 3]


@st.composite
def _parents(draw):
    m = draw(st.integers(1, 12))
    a = draw(st.permutations(range(m)))
    b = draw(st.permutations(range(m)))
    lo = draw(st.integers(0, m))
    hi = draw(st.integers(lo, m))
    return list(a), list(b), lo, hi


@given(_parents())
@settings(max_examples=200, deadline=None)
def test_pmx_children_are_permutations_that_inherit_the_section(parents):
    a, b, lo, hi = parents
    child = pmx(a, b, lo, hi)
    assert sorted(child.tolist()) == list(range(len(a)))
    assert child[lo:hi].tolist() == b[lo:hi]
    section = set(b[lo:hi])
    for k in list(range(lo)) + list(range(hi, len(a))):
        if a[k] not in section:
            assert child[k] == a[k]  # values untouched by the mapping stay in place
    assert child.tolist() == _pmx_by_mapping(a, b, lo, hi)


@pytest.mark.parametrize(
    "a, b, lo, hi, message",
    [
        ([0, 1, 2], [0, 1], 0, 1, "equal length"),
        ([0, 1, 1], [0, 1, 2], 0, 1, "permutations of 0..2"),
        ([0, 1, 2], [2, 1, 0], 2, 4, r"section \[2, 4\) is not within 0..3"),
        ([0, 1, 2], [2, 1, 0], 2, 1, r"section \[2, 1\)"),
    ],
)
def test_pmx_errors(a, b, lo, hi, message):
    with pytest.raises(InputError, match=message):
        pmx(a, b, lo, hi)


# -- selection, mutation, fitness ---------------------------------------------------------


def test_tournament_returns_the_fittest_entrant():
    fitness = np.array([0.1, 5.0, 0.3, 0.2])
    rng = np.random.default_rng(0)
    assert tournament(fitness, 200, rng) == 1  # 200 draws include index 1 (p = 1 - 0.75^200)
    wins = np.bincount([tournament(fitness, 1, rng) for _ in range(4000)], minlength=4)
    assert np.all(np.abs(wins / 4000 - 0.25) < 0.03)  # size 1: uniform


def test_swap_mutation_exchanges_exactly_two_positions():
    order = np.arange(10)
    out = swap_mutation(order, np.random.default_rng(3))
    assert sorted(out) == list(range(10))
    assert np.count_nonzero(out != order) == 2
    assert np.array_equal(order, np.arange(10))


def test_ordering_fitness_by_hand():
    # unit square corners; centroid (0.5, 0.5), r = sqrt(0.5)
    pts = np.array([[0, 1], [1, 1], [0, 0], [1, 0]], dtype=float)
    order = np.array([0, 1, 2, 3])  # right, down-left diagonal, right
    lengths = np.array([1.0, np.sqrt(2), 1.0])
    direction = np.array([1.0, np.sqrt(0.5), 1.0])  # (max(0,-y) + max(0,x)) / |v|
    expected = lengths.mean() / np.sqrt(0.5) + 0.5 * direction.mean()
    assert ordering_fitness(pts, order, 0.5) == pytest.approx(expected)
    batch = ordering_fitness(pts, np.array([order, order[::-1]]), 0.5)
    assert batch[0] == pytest.approx(expected)
    assert batch[1] < batch[0]  # same lengths, but up and leftwards


# -- the GA -------------------------------------------------------------------------------


@given(seed=st.integers(0, 2**32 - 1), m=st.integers(3, 9))
@settings(max_examples=25, deadline=None)
def test_with_elitism_the_best_fitness_never_decreases(seed, m):
    rng = np.random.default_rng(seed)
    pts = polar_targets(m, 5.0, rng)
    evo = evolve_order(pts, rng, GAConfig(population=12, generations=15, elite=1))
    assert len(evo.history) == 16
    assert np.all(np.diff(evo.history) >= 0.0)
    assert evo.fitness == pytest.approx(evo.history[-1])
    assert evo.fitness == pytest.approx(ordering_fitness(pts, evo.order))
    assert sorted(evo.order.tolist()) == list(range(m))


def test_ga_gets_close_to_the_brute_force_optimum():
    gaps = []
    for seed in range(6):
        rng = np.random.default_rng(seed)
        pts = polar_targets(6, 5.0, rng)
        every = np.array(list(itertools.permutations(range(6))))
        scores = ordering_fitness(pts, every)
        evo = evolve_order(pts, rng)
        gaps.append((scores.max() - evo.fitness) / (scores.max() - np.median(scores)))
    assert max(gaps) < 0.2  # within 20% of the way from a typical order to the best one
    assert np.mean(np.isclose(gaps, 0.0)) >= 0.5  # and usually exactly optimal


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"population": 1}, "population must be >= 2"),
        ({"elite": 50}, "elite: 50 exceeds the population 40"),
        ({"mutation_rate": 1.5}, r"mutation_rate: expected a probability in \[0, 1\]"),
        ({"generations": -1}, "generations: expected a non-negative integer"),
        ({"tournament": 0}, "tournament >= 1"),
        ({"tournament": 41}, "at most the population, got 40 and 41"),
    ],
)
def test_ga_config_errors(kwargs, message):
    with pytest.raises(InputError, match=message):
        GAConfig(**kwargs)


def test_polar_targets_lie_in_the_annulus():
    pts = polar_targets(500, 6.0, np.random.default_rng(1), inner=0.25)
    r = np.linalg.norm(pts, axis=1)
    assert r.min() >= 1.5 - 1e-12 and r.max() <= 6.0 + 1e-12
    angles = np.arctan2(pts[:, 1], pts[:, 0])
    assert np.histogram(angles, bins=4, range=(-np.pi, np.pi))[0].min() > 90


# -- tags ---------------------------------------------------------------------------------


def test_tag_is_five_glyphs_joined_into_one_stroke():
    tag = make_tag(PRESETS["graffiti"], seed=4)
    assert len(tag.points) == 5 and len(tag.evolutions) == 5
    assert all(4 <= len(p) <= 7 for p in tag.points)
    (stroke,) = tag.plan.strokes
    assert set(stroke.meta["glyphs"]) == set(range(5))
    assert len(stroke.targets) <= sum(len(p) for p in tag.points)  # ligatures may drop some
    centres = [p.mean(axis=0)[0] for p in tag.points]
    assert np.all(np.diff(centres) > 0)  # glyphs run left to right


def test_a_fixed_seed_reproduces_the_tag_exactly():
    style = PRESETS["graffiti"]
    a = make_tag(style, seed=11).realise()
    b = make_tag(style, seed=11).realise()
    assert len(a.strokes) == len(b.strokes)
    for s, t in zip(a.strokes, b.strokes):
        assert np.array_equal(s.t, t.t) and np.array_equal(s.pos, t.pos)


def test_different_seeds_give_different_tags():
    style = PRESETS["graffiti"]
    means = [make_tag(style, seed=s).plan.strokes[0].means for s in range(4)]
    for i, j in itertools.combinations(range(4), 2):
        assert means[i].shape != means[j].shape or not np.allclose(means[i], means[j])


def test_tag_accepts_a_generator_and_a_preset_name_and_centres_on_the_page():
    tag = make_tag("cursive", seed=np.random.default_rng(5), page_size=(200.0, 100.0))
    assert tag.style is PRESETS["cursive"]
    allpts = np.vstack(tag.points)
    centre = 0.5 * (allpts.min(axis=0) + allpts.max(axis=0))
    assert abs(centre[0] - 100.0) < 12.0 and abs(centre[1] - 50.0) < 12.0


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"n_glyphs": 0}, "n_glyphs must be >= 1"),
        ({"targets": (1, 3)}, "2 <= min <= max"),
        ({"targets": (5, 3)}, "2 <= min <= max"),
        ({"size": 0.0}, r"glyph size must be in \[0.1, 1000\] mm"),
        ({"size": 1e-300}, r"glyph size must be in \[0.1, 1000\] mm, got 1e-300"),
        ({"size": 1e300}, r"glyph size must be in \[0.1, 1000\] mm"),
        ({"targets": (2, 10**9)}, "2 <= min <= max <= 1000"),
        ({"n_glyphs": 100_000}, r"a tag of 100000 glyphs: .*INKARM_MAX_TEXT"),
        ({"n_glyphs": 1_000}, r"ordering GA of 1000 glyphs.*INKARM_MAX_GA_INDIVIDUALS"),
        ({"ga": GAConfig(population=10**6)}, r"about 2.55e\+08 individuals"),
        ({"n_glyphs": 2000, "size": 1000.0}, "span 1.6e\\+06 mm"),
    ],
)
def test_make_tag_errors(kwargs, message):
    with pytest.raises(InputError, match=message):
        make_tag(PRESETS["graffiti"], **kwargs)


def test_evolve_order_needs_two_points():
    with pytest.raises(InputError, match="need at least 2 points, got 1"):
        evolve_order(np.zeros((1, 2)), np.random.default_rng(0))


def test_check_tag_bounds_the_lqt_before_the_ga_runs(monkeypatch):
    from inkarm.core.budget import BudgetError
    from inkarm.plans import glyphs

    monkeypatch.setattr(glyphs, "evolve_order", lambda *a: pytest.fail("the GA ran"))
    style = PRESETS["graffiti"]
    with pytest.raises(BudgetError, match=r"LQT of 200 glyphs") as info:
        glyphs.check_tag(style, 200, dt=1e-4)
    assert info.value.key == "dt"
    with pytest.raises(InputError, match=r"must lie in \[0.0001, 1\] s") as info:
        glyphs.check_tag(style, 5, dt=1e-300)
    assert info.value.key == "dt"


def test_evolve_order_refuses_a_ga_over_budget():
    from inkarm.core.budget import BudgetError

    with pytest.raises(BudgetError, match="INKARM_MAX_GA_INDIVIDUALS") as info:
        evolve_order(np.zeros((4, 2)), np.random.default_rng(0),
                     GAConfig(population=1000, generations=10**6))
    assert info.value.key == "population"


def test_realising_a_tag_checks_its_time_steps():
    from inkarm.core.budget import BudgetError

    tag = make_tag(PRESETS["graffiti"], seed=0, n_glyphs=2)
    with pytest.raises(BudgetError, match="INKARM_MAX_STEPS"):
        tag.realise(dt=1e-9)
