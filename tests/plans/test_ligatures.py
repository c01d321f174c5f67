"""Ligatures that keep the letters: no junction target sharper than the style's threshold,
and every target of the letters kept (the connector bends, swings over a bowl and loops into
it, or leaves an overshooting exit point to the next letter)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from inkarm.plans.fonts import HersheyFont
from inkarm.plans.handstyles import PRESETS
from inkarm.plans.layout import layout_text
from inkarm.plans.ligatures import join_ligatures, junction_turns
from inkarm.plans.targets import TargetSequence, glyph_targets
from inkarm.plans.text import plan_text, write_text


def _seq(points, letter):
    points = np.asarray(points, dtype=float)
    return TargetSequence(points, np.full(len(points), letter), np.zeros(len(points), bool))


def _kept_in_order(points: np.ndarray, path: np.ndarray) -> bool:
    """Every one of ``points`` is a target of ``path``, in the same order (a point repeated
    in place, as pieces of a letter that share an end, counts once)."""
    keep = np.ones(len(points), bool)
    keep[1:] = np.linalg.norm(np.diff(points, axis=0), axis=1) > 1e-9
    points = points[keep]
    j = 0
    for p in points:
        while j < len(path) and np.linalg.norm(path[j] - p) > 1e-9:
            j += 1
        if j == len(path):
            return False
        j += 1
    return True


def _junctions(seq: TargetSequence):
    return junction_turns(seq.means, seq.letters, seq.connectors)


# -- the rule on hand-made letters ----------------------------------------------------------


def _bowl():
    """An 'a'-like bowl of radius 2 about (3, 2), written anticlockwise from 2 o'clock round to
    3 o'clock, then up its right side; and a letter before it whose exit ends on the bowl's
    9 o'clock point heading up-right, as Hershey's script k ends on a following a."""
    angles = np.radians(np.arange(30, 361, 30))
    bowl = np.column_stack([3 + 2 * np.cos(angles), 2 + 2 * np.sin(angles)])
    bowl = np.vstack([bowl, [[5.2, 3.5]]])
    before = np.array([[-1.0, 0.0], [0.0, 1.0], [1.0, 2.0]])
    return _seq(before, 0), _seq(bowl, 1)


def test_a_bowl_entered_from_its_side_gets_a_connector_swinging_over_it():
    k, a = _bowl()
    # the straight connector (1, 2) -> (4.73, 3) heads 15 deg; the bowl leaves at 135: 120 deg
    (plain,) = join_ligatures([k, a], max_gap=5.0, max_turn=180.0)
    assert max(t for *_, t in _junctions(plain)) == pytest.approx(120.0)
    (joined,) = join_ligatures([k, a], max_gap=5.0, max_turn=100.0, eyelet=0.5)
    assert _kept_in_order(np.vstack([k.means, a.means]), joined.means)  # no letter target lost
    assert max(t for *_, t in _junctions(joined)) <= 100.0
    links = joined.means[len(k) : len(joined) - len(a)]
    assert len(links) >= 3 and joined.connectors[len(k) : len(k) + len(links) + 1].all()
    assert (joined.letters[len(k) :] == 1).all()  # the connector belongs to the a
    # it runs outside the bowl (never across it) and over its top, then loops into its start
    assert np.all(np.linalg.norm(links - [3, 2], axis=1) >= 2.0 - 1e-9)
    assert links[:, 1].max() > 4.0 + 0.2
    assert np.linalg.norm(links[-1] - a.means[0]) <= 0.5  # the eyelet, 0.5 across
    # seed 000's rule instead (no eyelet) drops targets of the letters
    (dropped,) = join_ligatures([k, a], max_gap=5.0, max_turn=100.0)
    assert len(dropped) < len(k) + len(a)


def test_an_exit_overshooting_into_the_next_letter_ends_where_the_letter_takes_over():
    # the exit (0, 1) ends on the next letter's side, far along its loop (no swing back over
    # the whole loop): turning 108 deg there, it is left to the next letter, which draws it
    before = _seq([[-2.0, -1.0], [-1.0, 0.0], [0.0, 1.0]], 0)
    loop = [[0.5, 0.0], [2.0, 0.5], [2.5, 2.0], [1.5, 3.0], [0.0, 2.5], [0.0, 0.5], [1.0, -0.5]]
    e = _seq(loop, 1)
    (joined,) = join_ligatures([before, e], max_gap=2.0, max_turn=100.0, eyelet=0.5)
    assert np.allclose(joined.means, np.vstack([before.means[:-1], e.means]))
    assert joined.connectors.tolist() == [False, False, True] + [False] * 6
    assert max(t for *_, t in _junctions(joined)) <= 100.0


def test_a_sharp_entry_between_letters_apart_gets_a_bending_target():
    first = _seq([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]], 0)
    second = _seq([[2.5, 0.2], [1.8, 1.0], [1.8, 3.0]], 1)  # turns back: 109 deg at (2.5, 0.2)
    (joined,) = join_ligatures([first, second], max_gap=2.0, max_turn=100.0, eyelet=0.5)
    assert len(joined) == 7 and _kept_in_order(np.vstack([first.means, second.means]), joined.means)
    assert joined.connectors.tolist() == [False, False, False, True, True, False, False]
    assert max(t for *_, t in _junctions(joined)) <= 100.0


def test_a_sharp_turn_at_a_shared_point_falls_back_to_seed_000s_rule():
    first = _seq([[0.0, 0.0], [1.0, 0.0]], 0)
    second = _seq([[1.0, 0.0], [0.2, 0.3], [0.0, 2.0]], 1)
    rule = join_ligatures([first, second], max_gap=1.0, max_turn=100.0)
    (joined,) = join_ligatures([first, second], max_gap=1.0, max_turn=100.0, eyelet=0.5)
    assert np.array_equal(joined.means, rule[0].means)


def test_each_junction_sees_only_the_two_letters_it_joins(monkeypatch):
    """Joining is linear in the text: every letter junction is handled once, on a window of
    the two letters (plus two context targets), however long the word."""
    from inkarm.plans import ligatures

    calls = []
    original = ligatures._join_letters

    def spy(context, first, second, *args):
        calls.append(len(context) + len(first) + len(second))
        return original(context, first, second, *args)

    monkeypatch.setattr(ligatures, "_join_letters", spy)
    font = HersheyFont("scripts", 2.0)
    windows = {}
    for n in (10, 40):
        calls.clear()
        pieces = glyph_targets(layout_text("mu" * n, font), 15.0, mark_size=0.4)
        assert len(join_ligatures(pieces, 0.9, 100.0, eyelet=0.2)) == 1  # one stroke
        assert len(calls) == 2 * n - 1  # one per junction
        windows[n] = max(calls)
    assert windows[40] == windows[10]


# -- written words --------------------------------------------------------------------------

WORDS = ["inkarm", "banana", "cocoa", "quad", "dog"]


@pytest.mark.parametrize("style", sorted(PRESETS))
@pytest.mark.parametrize("word", WORDS)
def test_no_junction_of_a_word_turns_more_than_the_style_threshold(word, style):
    tp = plan_text(word, PRESETS[style])
    turns = [j for s in tp.plan.strokes for j in _junctions_of(s)]
    assert len(turns) == len(word) - 1  # every pair of letters is joined
    worst = max(t for *_, t in turns)
    assert worst <= PRESETS[style].ligature_angle, [(word[a] + word[b], t) for a, b, t in turns]


def _junctions_of(stroke):
    return junction_turns(stroke.means, stroke.meta["letters"], stroke.meta["connectors"])


@pytest.mark.parametrize("style", ["faithful", "cursive"])
@pytest.mark.parametrize("threshold", [60.0, 140.0])
def test_other_thresholds_are_kept_too(style, threshold):
    style = replace(PRESETS[style], ligature_angle=threshold)
    tp = plan_text("inkarm banana cocoa quad dog", style)
    assert max(t for s in tp.plan.strokes for *_, t in _junctions_of(s)) <= threshold


def test_the_k_to_a_junction_of_inkarm_is_smooth_and_the_a_keeps_its_bowl():
    # Seed 000's rule applied once left a 133 deg turn at k -> a (cursive): the a starts on
    # the far side of its bowl and turns back over it. Applied until no junction was sharp,
    # it dropped the top of the bowl (font -> drawing 0.41 -> 2.96 mm, faithful).
    style = PRESETS["cursive"]
    tp = plan_text("inkarm", style)
    body = tp.plan.strokes[0]
    ka = [t for a, b, t in _junctions_of(body) if (a, b) == (2, 3)]
    assert len(ka) == 1 and ka[0] <= style.ligature_angle
    pieces = glyph_targets(list(tp.glyphs), style.thin_angle, mark_size=0.2 * tp.font.height)
    letter_targets = np.vstack([p.means for p in pieces if p.joinable])
    assert _kept_in_order(letter_targets, body.means)  # every letter's targets, the a's too
    dropper = plan_text("inkarm", replace(style, eyelet=0.0))  # seed 000's rule
    assert not _kept_in_order(letter_targets, dropper.plan.strokes[0].means)


# font -> drawing [mm] of "inkarm" (seed 0) with seed 000's rule applied once (the rule before
# it was made repeated), which left the 133 deg k -> a junction: the new rule, smooth at every
# junction, must keep the letters at least as well. Measured with the new rule: faithful 0.11,
# cursive 1.73, loose 2.04, italic 2.09, hurried 1.46, graffiti 1.33 (the stylised presets'
# worst letter is the i or the k, whose stems the smooth hands round off, not a junction).
ONE_PASS_FONT_TO_DRAWING = {
    "faithful": 0.44,
    "cursive": 1.73,
    "loose": 2.04,
    "italic": 2.09,
    "hurried": 1.59,
    "graffiti": 1.33,
}


@pytest.mark.parametrize("style", sorted(PRESETS))
def test_inkarm_keeps_its_letters_in_every_preset(style):
    fidelity = write_text("inkarm", PRESETS[style]).fidelity()
    assert fidelity.font_to_drawing <= ONE_PASS_FONT_TO_DRAWING[style] + 0.05, fidelity
    assert fidelity.drawing_to_font <= 0.7, fidelity
    if style == "faithful":
        assert fidelity.symmetric <= 0.25
