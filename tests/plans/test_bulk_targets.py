"""Targets built in bulk (inkarm.plans.targets, inkarm.plans.ligatures,
inkarm.plans.handstyles): thinning, subdividing and de-duplicating all of a text's glyph
strokes at once, turning angles on Python floats, and strokes checked as arrays rather than
target by target, give exactly the targets and plans of the one-at-a-time code they
replace."""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np
import pytest

import inkarm.core.plan as plan_module
from inkarm.analysis.density import turning_angles
from inkarm.core.plan import GaussianTarget, StrokePlan
from inkarm.models.lqt import semi_tied_covariances
from inkarm.plans import fonts, layout, ligatures, targets, text
from inkarm.plans.handstyles import PRESETS

# -- the references: one polyline, one vertex, one target at a time ---------------------------


def reference_dedupe(points):
    keep = np.ones(len(points), bool)
    keep[1:] = np.linalg.norm(np.diff(points, axis=0), axis=1) > 1e-6
    return points[keep]


def reference_thin(points, min_turn):
    pts = reference_dedupe(np.asarray(points, dtype=float))
    if min_turn <= 0 or len(pts) <= 2:
        return pts
    kept = [0]
    for i in range(1, len(pts) - 1):
        chord = pts[i] - pts[kept[-1]]
        edge = pts[i + 1] - pts[i]
        turn = np.degrees(np.abs(np.arctan2(chord[0] * edge[1] - chord[1] * edge[0], chord @ edge)))
        if turn >= min_turn:
            kept.append(i)
    kept.append(len(pts) - 1)
    return pts[kept]


def reference_subdivide(points, max_spacing):
    if max_spacing is None or len(points) < 2:
        return points
    out = [points[:1]]
    for a, b in pairwise(points):
        k = max(1, int(np.ceil(np.linalg.norm(b - a) / max_spacing)))
        out.append(a + np.outer(np.arange(1, k + 1) / k, b - a))
    return np.vstack(out)


def _polylines(seed, n=300):
    """Polylines on a coarse grid (repeated points, straight runs, reversals) far from 0."""
    rng = np.random.default_rng(seed)
    out = []
    for k in rng.integers(0, 9, n):
        p = 40.0 + np.round(rng.normal(size=(int(k), 2)) * 4) / 4
        out.append(np.repeat(p, rng.integers(1, 3, len(p)), axis=0) if len(p) else p.reshape(0, 2))
    return out


def test_dedupe_thin_and_subdivide_in_bulk_are_the_references():
    polylines = _polylines(0)
    deduped = targets._dedupe_all(polylines)
    for p, d in zip(polylines, deduped):
        np.testing.assert_array_equal(d, reference_dedupe(p))
        assert d.shape == reference_dedupe(p).shape
    for min_turn in (0.0, 15.0, 45.0, 90.0):
        thinned = [targets.thin_polyline(p, min_turn) for p in polylines]
        for p, t in zip(polylines, thinned):
            np.testing.assert_array_equal(t, reference_thin(p, min_turn))
        for spacing in (None, 0.1, 0.7):
            for t, s in zip(thinned, targets._subdivide_all(thinned, spacing)):
                np.testing.assert_array_equal(s, reference_subdivide(t, spacing))
                np.testing.assert_array_equal(targets.subdivide(t, spacing), s)


def test_turning_angle_on_floats_is_turning_angles_to_rounding():
    # (the same operations in the same order; numpy 2.4's norm and arctan2 kernels may round
    # the last bit differently from math.sqrt and math.atan2)
    rng = np.random.default_rng(1)
    for _ in range(3000):
        pts = rng.normal(size=(3, 2)) * 10.0 ** rng.uniform(-5, 3, (3, 1))
        if np.linalg.norm(pts[1] - pts[0]) <= 1e-6 or np.linalg.norm(pts[2] - pts[1]) <= 1e-6:
            continue
        want = float(np.degrees(turning_angles(pts)[1]))
        assert ligatures._turn_angle(*pts.tolist()) == pytest.approx(want, rel=1e-12, abs=1e-12)
    means = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 1.0]])  # a repeated target
    assert (ligatures._turn_at(means, 1) == ligatures._turn_at(means.tolist(), 2)
            == pytest.approx(90.0))
    assert ligatures._turn_at(means, 0) is None


def reference_glyph_targets(placed, thin_angle, max_spacing, mark_size):
    out, marks = [], []
    for k, pg in enumerate(placed):
        for stroke in pg.strokes:
            pts = reference_subdivide(reference_thin(stroke, thin_angle), max_spacing)
            is_mark = float(np.max(np.ptp(pts, axis=0))) <= mark_size
            seq = (pts, np.full(len(pts), pg.index), np.zeros(len(pts), bool), not is_mark)
            (marks if is_mark else out).append(seq)
        if k + 1 == len(placed) or placed[k + 1].index != pg.index + 1:
            out += marks
            marks = []
    return out


def test_glyph_targets_are_the_reference():
    font = fonts.HersheyFont("scripts", 4.0)
    placed = layout.layout_text("Quick jiggly fox, 42 ij!\nzebra", font)
    for thin, spacing in ((15.0, None), (0.0, 0.6), (30.0, 0.3)):
        got = targets.glyph_targets(placed, thin, spacing, mark_size=0.8)
        want = reference_glyph_targets(placed, thin, spacing, 0.8)
        assert len(got) == len(want)
        for seq, (means, letters, connectors, joinable) in zip(got, want):
            np.testing.assert_array_equal(seq.means, means)
            np.testing.assert_array_equal(seq.letters, letters)
            np.testing.assert_array_equal(seq.connectors, connectors)
            assert seq.joinable == joinable


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_covariances_and_stroke_plans_are_those_built_target_by_target(name):
    style = PRESETS[name]
    for m in (1, 3, 40):
        got = style.covariances(m, np.random.default_rng(m))
        want = semi_tied_covariances(
            m, style.basis, style.h, rho=style.rho, seed=np.random.default_rng(m)
        )
        np.testing.assert_array_equal(got, want)
        assert got.flags.writeable
    means = np.cumsum(np.random.default_rng(2).normal(size=(25, 2)), axis=0)
    plan = style.stroke_plan(means, np.random.default_rng(4), {"letters": (1, 2)})
    covs = style.covariances(25, np.random.default_rng(4))
    want = StrokePlan(
        tuple(map(GaussianTarget, means, covs)), style.segment_time, meta={"letters": (1, 2)}
    )
    assert plan == want and hash(plan) == hash(want)
    np.testing.assert_array_equal(plan.covs, want.covs)


def test_a_motor_plan_checks_each_stroke_as_arrays(monkeypatch):
    """No covariance is checked one matrix at a time: one batch per stroke (and rho = 0
    styles check their one covariance once)."""
    calls = []
    check = plan_module.check_covariance
    monkeypatch.setattr(plan_module, "check_covariance", lambda *a: calls.append(1) or check(*a))
    tp = text.plan_text("minimum wage jiggly quaff", PRESETS["cursive"], height=5.0)
    assert len(tp.plan.strokes) >= 4 and not calls
    meta = tp.plan.strokes[0].meta
    assert all(type(i) is int for i in meta["letters"])
    assert all(type(c) is bool for c in meta["connectors"])


def test_a_bad_mean_raises_the_targets_own_error():
    with pytest.raises(plan_module.PlanError, match=r"^target mean: NaN or inf"):
        PRESETS["cursive"].stroke_plan(
            np.array([[0.0, 0.0], [np.nan, 1.0]]), np.random.default_rng(0)
        )


def _reference_turn_angle(p, q, r):
    """_turn_angle before it was written out for the plane (any dimension, generator sums)."""
    u = [b - a for a, b in zip(p, q)]
    v = [b - a for a, b in zip(q, r)]
    nu = math.sqrt(sum(c * c for c in u))
    nv = math.sqrt(sum(c * c for c in v))
    a = [c * nv for c in u]
    b = [c * nu for c in v]
    minus = math.sqrt(sum((x - y) * (x - y) for x, y in zip(a, b)))
    plus = math.sqrt(sum((x + y) * (x + y) for x, y in zip(a, b)))
    return math.degrees(2.0 * math.atan2(minus, plus))


def _reference_distinct_index(pts, i, step, keep=None):
    here = pts[i]
    j = i + step
    while 0 <= j < len(pts):
        if (keep is None or keep[j]) and math.sqrt(
            sum((a - b) * (a - b) for a, b in zip(pts[j], here))
        ) > ligatures.SAME_POINT:
            return j
        j += step
    return None


def test_plane_turn_angle_and_distinct_index_equal_the_general_ones_bit_for_bit():
    rng = np.random.default_rng(5)
    for _ in range(2000):
        pts = (rng.normal(size=(3, 2)) * 10.0 ** rng.uniform(-8, 3, (3, 1))).tolist()
        assert ligatures._turn_angle(*pts) == _reference_turn_angle(*pts)
        path = (np.cumsum(rng.normal(size=(8, 2)), axis=0)
                * 10.0 ** rng.uniform(-7, 0, (8, 1)) * ligatures.SAME_POINT * 1e6).tolist()
        keep = rng.random(8) < 0.7
        i, step = int(rng.integers(8)), int(rng.choice([-1, 1]))
        for k in (None, keep):
            assert (ligatures._distinct_index(path, i, step, k)
                    == _reference_distinct_index(path, i, step, k))
