"""Restyle keeps a drawing's layers (meta["layers"], one vpype layer id per stroke), says which
strokes it dropped, restyles in a handstyle (RestyleConfig.from_handstyle), and bounds the
memory of its longest solve, not of all strokes together."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.core.budget import BudgetError
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError
from inkarm.plans.handstyles import PRESETS
from inkarm.plans.restyle import RestyleConfig, check_restyle, restyle


def _line(x0: float, n: int = 40, length: float = 10.0, bend: float = 0.0) -> Trajectory:
    s = np.linspace(0.0, 1.0, n)
    pos = np.column_stack([x0 + length * s, bend * np.sin(np.pi * s)])
    return Trajectory(t=s, pos=pos)


def test_layers_follow_the_kept_strokes_and_dropped_ones_are_listed():
    strokes = [_line(0), _line(20, n=2), _line(40, bend=3.0), _line(60, n=1), _line(80)]
    drawing = Drawing(strokes, meta={"layers": np.array([3, 1, 3, 2, 7], dtype=np.int64)})
    out = restyle(drawing, RestyleConfig(compression=0.8)).drawing
    assert len(out.strokes) == 3
    np.testing.assert_array_equal(out.meta["layers"], [3, 3, 7])
    assert out.meta["layers"].dtype == np.int64
    assert out.meta["restyle_dropped"] == (1, 3)
    # each kept stroke is the restyle of its own input, in order
    for got, x0 in zip(out.strokes, (0, 40, 80)):
        assert got.pos[0] == pytest.approx([x0, 0.0])


def test_without_layers_and_drops_the_meta_stays_empty():
    out = restyle(Drawing([_line(0), _line(20)]), RestyleConfig(compression=0.8)).drawing
    assert out.meta == {}


@pytest.mark.parametrize("layers", [np.array([1]), np.array([1, 0]), np.array([1.0, 2.0]),
                                    [[1, 2]], "12", np.array([True, True])])
def test_bad_layers_are_refused_naming_the_key(layers):
    drawing = Drawing([_line(0), _line(20)], meta={"layers": layers})
    with pytest.raises(InputError, match=r"layers: expected one integer layer id >= 1 per "
                                         r"stroke \(2\)") as e:
        restyle(drawing)
    assert e.value.key == "layers"


def test_a_handstyle_sets_order_d_and_its_covariances():
    hand = PRESETS["cursive"]
    cfg = RestyleConfig.from_handstyle(hand, compression=0.8, segment_time=hand.segment_time)
    assert (cfg.style, cfg.order, cfg.d, cfg.hand) == ("handstyle", hand.order, hand.d, hand)
    result = restyle(Drawing([_line(0, bend=4.0)]), cfg)
    covs = np.array([t.cov for t in result.plan.strokes[0].targets])
    expected = hand.h * hand.basis @ hand.basis.T  # seed 000 eq. 22, rho = 0
    np.testing.assert_allclose(covs, np.broadcast_to(expected, covs.shape), rtol=1e-12)
    assert result.plan.strokes[0].segment_time == pytest.approx(hand.segment_time)


def test_a_handstyle_with_magnitude_noise_follows_the_seed():
    hand = PRESETS["hurried"]
    drawing = Drawing([_line(0, bend=4.0), _line(20, bend=-3.0)])

    def covs(seed):
        plan = restyle(drawing, RestyleConfig.from_handstyle(hand, seed=seed)).plan
        return np.array([t.cov for s in plan.strokes for t in s.targets])

    np.testing.assert_array_equal(covs(5), covs(5))
    assert not np.allclose(covs(5), covs(6))


@pytest.mark.parametrize("kwargs, key, message", [
    ({"style": "handstyle"}, "hand", "style 'handstyle' needs hand, a Handstyle"),
    ({"style": "handstyle", "hand": "cursive"}, "hand", "needs hand, a Handstyle"),
    ({"hand": PRESETS["loose"]}, "style",
     "a hand is given: expected style 'handstyle', got 'geometric'"),
])
def test_handstyle_config_errors(kwargs, key, message):
    with pytest.raises(InputError, match=message) as e:
        RestyleConfig(**kwargs)
    assert e.value.key == key


def test_a_handstyle_refuses_a_3d_stroke():
    s = np.linspace(0.0, 1.0, 30)
    drawing = Drawing([Trajectory(t=s, pos=np.column_stack([s, s, 0 * s]))])
    with pytest.raises(InputError, match="a handstyle's covariances are 2 x 2; the stroke has 3"):
        restyle(drawing, RestyleConfig.from_handstyle(PRESETS["faithful"]))


def test_memory_is_bounded_by_the_longest_stroke(monkeypatch):
    # 4,000 bytes a step (order 4, 2-D); 1 MB holds 262 steps. 600 samples at compression
    # 0.95 give 20 targets of 5 steps: 100 steps a stroke.
    monkeypatch.setenv("INKARM_MAX_MEMORY_MB", "1")
    cfg = RestyleConfig(compression=0.95, segment_time=0.05)
    many = Drawing([_line(20.0 * i, n=600) for i in range(10)])
    check_restyle(many, cfg)  # 1,000 steps in all, solved 100 at a time
    with pytest.raises(BudgetError, match="MB"):
        check_restyle(Drawing([_line(0.0, n=6000)]), cfg)  # 1,000 steps in one solve


def test_a_short_stroke_is_held_long_enough_for_the_chain_order():
    # 3 samples in 0.02 s: 3 targets (every sample, fewer than MIN_TARGETS) of 1 step, fewer
    # than the order-4 chain's 5 steps
    short = Trajectory(t=[0.0, 0.01, 0.02], pos=[[0.0, 0.0], [0.2, 0.0], [0.4, 0.0]])
    result = restyle(Drawing([short, _line(10.0)]), RestyleConfig(order=4))
    assert len(result.drawing.strokes) == 2
    assert result.plan.strokes[0].segment_time == pytest.approx(0.02)  # 2 steps x 3 targets
