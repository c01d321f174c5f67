"""Text to motor plans: Hershey glyphs in mm, layout, targets, ligatures, fidelity to the font."""

from __future__ import annotations

import string
from itertools import pairwise

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.analysis.density import turning_angles
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError, ScenarioError
from inkarm.plans.fidelity import (
    TextFidelity,
    font_deviation,
    outline_deviation,
    sample_letters,
    text_fidelity,
)
from inkarm.plans.fonts import HersheyFont
from inkarm.plans.handstyles import PRESETS
from inkarm.plans.layout import PageLayout, layout_text
from inkarm.plans.ligatures import join_ligatures
from inkarm.plans.targets import TargetSequence, glyph_targets, subdivide, thin_polyline
from inkarm.plans.text import plan_text, write_text


def _seq(points, letter, joinable=True):
    points = np.asarray(points, dtype=float)
    return TargetSequence(
        points, np.full(len(points), letter), np.zeros(len(points), bool), joinable
    )


# -- fonts --------------------------------------------------------------------------------


@pytest.mark.parametrize("height", [5.0, 10.0, 23.0])
def test_glyphs_are_scaled_so_the_cap_height_is_the_letter_height(height):
    font = HersheyFont("scripts", height)
    capital = np.vstack(font.glyph("H").strokes)
    small = np.vstack(font.glyph("n").strokes)
    assert capital[:, 1].max() == pytest.approx(height)  # Hershey cap line
    assert small[:, 1].min() == pytest.approx(0.0)  # base line, y up
    assert small[:, 0].min() == pytest.approx(0.0)  # n starts at its left bearing
    assert font.glyph("n").advance == pytest.approx(18 / 21 * height)  # 18 units of 21


def test_a_missing_glyph_is_named_with_its_code_point():
    with pytest.raises(InputError, match=r"font 'scripts' has no glyph for 'é' \(U\+00E9\)"):
        HersheyFont().glyph("é")


def test_unknown_font_lists_the_fonts():
    with pytest.raises(InputError, match="unknown font 'comic'; available: .*scripts"):
        HersheyFont("comic")


def test_bad_height():
    with pytest.raises(InputError, match="letter height must be a positive number of mm, got -1"):
        HersheyFont("scripts", -1.0)


# -- layout -------------------------------------------------------------------------------


def test_layout_wraps_words_at_the_right_margin():
    font = HersheyFont("scripts", 10.0)
    layout = PageLayout(page_size=(120.0, 200.0), margins=(10.0, 15.0, 10.0, 10.0))
    text = "one two three four five six seven"
    placed = layout_text(text, font, layout)
    assert "".join(g.char for g in placed) == text.replace(" ", "")
    assert max(s[:, 0].max() for g in placed for s in g.strokes) <= 120.0 - 15.0
    baselines = sorted({g.origin[1] for g in placed}, reverse=True)
    assert baselines[0] == pytest.approx(200.0 - 10.0 - 10.0)  # one cap height below the top
    assert np.allclose(np.diff(baselines), -20.0)  # line height 2 x letter height
    assert len(baselines) >= 2
    starts = [0] + [k + 1 for k, c in enumerate(text) if c == " "]
    for start in starts:
        word = text[start:].split(" ")[0]
        rows = {g.origin[1] for g in placed if start <= g.index < start + len(word)}
        assert len(rows) == 1, f"{word!r} was split"
    for line in baselines:  # each line starts at the left margin
        assert min(g.origin[0] for g in placed if g.origin[1] == line) == pytest.approx(10.0)
    # greedy: the first word of each next line would not have fitted on the line above
    for upper, lower in pairwise(baselines):
        last = max((g for g in placed if g.origin[1] == upper), key=lambda g: g.index)
        word_start = min(g.index for g in placed if g.origin[1] == lower)
        word = text[word_start:].split(" ")[0]
        width = sum(font.glyph(c).advance for c in word)
        end_of_last = last.origin[0] + font.glyph(last.char).advance
        assert end_of_last + font.glyph(" ").advance + width > 120.0 - 15.0


def test_layout_new_lines_and_indices_follow_the_text():
    font = HersheyFont("scripts", 10.0)
    placed = layout_text("ab\ncd", font)
    assert [(g.char, g.index) for g in placed] == [("a", 0), ("b", 1), ("c", 3), ("d", 4)]
    a, c = placed[0], placed[2]
    assert np.vstack(a.strokes)[:, 0].min() == pytest.approx(np.vstack(c.strokes)[:, 0].min())
    dy = np.vstack(a.strokes)[:, 1].min() - np.vstack(c.strokes)[:, 1].min()
    assert dy == pytest.approx(20.0, abs=1.0)  # default line height 2 x letter height


def test_a_word_longer_than_the_line_is_broken_between_letters():
    font = HersheyFont("scripts", 10.0)
    layout = PageLayout(page_size=(60.0, 200.0), margins=(5.0, 5.0, 5.0, 5.0))
    placed = layout_text("mmmmmmmmmm", font, layout)
    assert max(s[:, 0].max() for g in placed for s in g.strokes) <= 55.0
    assert len({round(float(np.vstack(g.strokes)[:, 1].min()), 3) for g in placed}) > 1


@pytest.mark.parametrize(
    "text, layout, message",
    [
        ("", PageLayout(), "text is empty"),
        ("  \n ", PageLayout(), "text is empty"),
        ("naïve", PageLayout(), r"no glyph for 'ï' \(U\+00EF\)"),
        ("a\n" * 40, PageLayout(), "text does not fit on the page"),
    ],
)
def test_layout_errors(text, layout, message):
    with pytest.raises(InputError, match=message):
        layout_text(text, HersheyFont("scripts", 10.0), layout)


@pytest.mark.parametrize(
    "text, message",
    [
        ("inkar\rm", r"^text: control character U\+000D \(carriage return\) at index 5; .*\\n$"),
        ("\r\n", r"U\+000D \(carriage return\) at index 0"),  # named, not "text is empty"
        ("a\x00b", r"^text: control character U\+0000 \(null\) at index 1$"),
        ("\x1b[1mab", r"U\+001B \(escape\) at index 0"),
        ("ab\x08c", r"U\+0008 \(backspace\) at index 2"),
        ("ab\x7f", r"U\+007F \(delete\) at index 2"),
        ("a\x85b", r"U\+0085 \(next line\) at index 1; new lines are"),
        ("a\x9bb", r"U\+009B \(C1 control\) at index 1"),
    ],
)
def test_control_characters_are_refused_by_name(text, message):
    with pytest.raises(InputError, match=message):
        layout_text(text, HersheyFont("scripts", 10.0))


def test_new_lines_and_tabs_are_layout_not_control_characters():
    placed = layout_text("a\tb\nc", HersheyFont("scripts", 10.0))
    assert [(g.char, g.index) for g in placed] == [("a", 0), ("b", 2), ("c", 4)]
    assert placed[0].origin[1] == placed[1].origin[1] > placed[2].origin[1]


def test_page_layout_errors():
    with pytest.raises(InputError, match="leave no room"):
        PageLayout(page_size=(50.0, 50.0), margins=(30.0, 30.0, 5.0, 5.0))
    with pytest.raises(InputError, match="line height must be positive"):
        PageLayout(line_height=0.0)


# -- targets ------------------------------------------------------------------------------


def test_thinning_keeps_ends_and_corners_and_drops_straight_runs():
    pts = np.array([[0, 0], [1, 0], [2, 0], [3, 0], [3, 1], [3, 2], [3, 2]], dtype=float)
    assert np.array_equal(thin_polyline(pts, 10.0), [[0, 0], [3, 0], [3, 2]])
    assert len(thin_polyline(pts, 0.0)) == 6  # only the duplicate goes


def test_thinning_a_polygonal_arc_keeps_one_target_per_angle_step():
    theta = np.radians(np.arange(0, 181, 5))  # 5 deg per vertex on a half circle
    arc = np.column_stack([np.cos(theta), np.sin(theta)])
    kept = thin_polyline(arc, 30.0)
    heading = np.degrees(np.arctan2(*np.diff(kept, axis=0).T[::-1]))
    assert 5 <= len(kept) <= 9  # about 180 / 30 + 1
    assert np.all(np.abs(np.diff(np.unwrap(np.radians(heading)))) <= np.radians(60) + 1e-9)


@given(spacing=st.floats(0.05, 3.0))
@settings(max_examples=30, deadline=None)
def test_subdivide_bounds_edges_and_keeps_vertices(spacing):
    pts = np.array([[0, 0], [5, 0], [5, 0.3], [1, 4]], dtype=float)
    out = subdivide(pts, spacing)
    assert np.max(np.linalg.norm(np.diff(out, axis=0), axis=1)) <= spacing + 1e-9
    for p in pts:
        assert np.min(np.linalg.norm(out - p, axis=1)) < 1e-12
    assert subdivide(pts, None) is pts


def test_dots_are_delayed_to_the_end_of_the_word_and_never_joined():
    font = HersheyFont("scripts", 10.0)
    placed = layout_text("in it", font)
    pieces = glyph_targets(placed, 0.0, mark_size=2.0)
    order = [(int(p.letters[0]), p.joinable) for p in pieces]
    # i: dot (stroke 0) delayed after "in"; n; then "it" likewise
    assert order[-1] == (3, False)
    dots = [k for k, (_, j) in enumerate(order) if not j]
    assert [order[k][0] for k in dots] == [0, 3]
    assert dots[0] == max(k for k, (i, _) in enumerate(order) if i <= 1)


# -- ligatures ----------------------------------------------------------------------------


def test_same_letter_pieces_join_without_dropping_the_cusp():
    a = _seq([[0, 0], [0, 5], [0.2, 0]], 0)  # down-up-down: a retrace cusp
    b = _seq([[0.5, 0.5], [2, 3]], 0)
    (joined,) = join_ligatures([a, b], max_gap=1.0, max_turn=100.0)
    assert np.array_equal(joined.means, np.vstack([a.means, b.means]))
    assert joined.connectors.tolist() == [False, False, False, True, False]


def test_neighbouring_letters_drop_sharp_junction_targets():
    # letter 0 ends going right; letter 1 starts by heading back left: a hook at the joint
    a = _seq([[0, 0], [4, 0], [5, 0]], 0)
    b = _seq([[5.5, 0], [5, 1], [5, 4]], 1)
    (joined,) = join_ligatures([a, b], max_gap=2.0, max_turn=100.0)
    # turning at (5,0): from +x to (0.5,0) -> 0 deg, kept; at (5.5,0): back to (-0.5,1) -> ~117
    # deg, dropped; then (5,0) turns 90 deg up to (5,1), under the threshold: done
    assert np.allclose(joined.means, [[0, 0], [4, 0], [5, 0], [5, 1], [5, 4]])
    assert joined.letters.tolist() == [0, 0, 0, 1, 1]
    assert joined.connectors.tolist() == [False, False, False, True, False]
    (kept,) = join_ligatures([a, b], max_gap=2.0, max_turn=170.0)
    assert len(kept) == 6


def test_the_ligature_rule_is_applied_until_no_junction_is_sharp():
    # dropping the hook (5.5, 0) leaves (5, 0) -> (4.8, 0.3), a 124 deg turn: that goes too
    a = _seq([[0, 0], [4, 0], [5, 0]], 0)
    b = _seq([[5.5, 0], [4.8, 0.3], [5, 1], [5, 4]], 1)
    (joined,) = join_ligatures([a, b], max_gap=2.0, max_turn=100.0)
    assert np.degrees(turning_angles(joined.means)).max() <= 100.0
    assert len(joined) == 5 and np.allclose(joined.means[[0, -2, -1]], [[0, 0], [5, 1], [5, 4]])
    assert joined.letters.tolist() == [0, 0, 1, 1, 1]
    assert joined.connectors.tolist() == [False, False, True, False, False]


def test_the_cascade_never_drops_a_letters_last_target():
    a = _seq([[0, 0], [4, 0], [5, 0]], 0)
    b = _seq([[5.5, 0], [3, 1], [3, 4]], 1)  # every target of letter 0 but its start goes
    (joined,) = join_ligatures([a, b], max_gap=2.0, max_turn=100.0)
    assert np.allclose(joined.means, [[0, 0], [3, 1], [3, 4]])
    # a two-target letter between sharp joins keeps its last target
    pieces = [_seq([[0, 0], [1, 0]], 0), _seq([[1.5, 0], [1.2, 0.5]], 1)]
    pieces.append(_seq([[1.0, 0.6], [5, 0.6]], 2))
    (word,) = join_ligatures(pieces, max_gap=1.0, max_turn=100.0)
    assert word.letters.tolist() == [0, 0, 1, 2]
    assert np.allclose(word.means[2], [1.2, 0.5])


def test_a_target_repeated_in_place_turns_where_the_path_turns():
    # after the first drop, letter 1's (5, 0) sits on letter 0's end: the turn there counts
    a = _seq([[0, 0], [4, 0], [5, 0]], 0)
    b = _seq([[6, 0.5], [5, 0], [4, 0.5], [4, 3]], 1)
    (joined,) = join_ligatures([a, b], max_gap=2.0, max_turn=100.0)
    assert np.degrees(turning_angles(joined.means)).max() <= 100.0
    assert len(joined) < 7


def test_shared_end_point_counts_once():
    a = _seq([[0, 0], [1, 0]], 0)
    b = _seq([[1, 0], [2, 0.5]], 1)
    (joined,) = join_ligatures([a, b], max_gap=0.5, max_turn=100.0)
    assert np.allclose(joined.means, [[0, 0], [1, 0], [2, 0.5]])
    assert not joined.connectors.any()


@pytest.mark.parametrize(
    "b",
    [
        _seq([[5, 0], [6, 0]], 1),  # gap 4 > 1
        _seq([[1.5, 0], [2, 0]], 2),  # not the next letter (a space between)
        _seq([[1.5, 0], [2, 0]], 1, joinable=False),  # a delayed dot
    ],
)
def test_pieces_that_stay_apart(b):
    a = _seq([[0, 0], [1, 0]], 0)
    assert len(join_ligatures([a, b], max_gap=1.0, max_turn=100.0)) == 2


def test_inkarm_in_a_script_style_is_ligatured():
    tp = plan_text("inkarm", PRESETS["cursive"])
    assert len(tp.plan.strokes) < len("inkarm")
    assert len(tp.plan.strokes) == 2  # the word and the i's dot
    body = tp.plan.strokes[0]
    assert set(body.meta["letters"]) == set(range(6))
    assert len(body.meta["connectors"]) == len(body.targets)


# -- realised text --------------------------------------------------------------------------


def test_the_most_faithful_style_stays_within_1mm_of_every_letter():
    text = f"{string.ascii_lowercase[:13]} {string.ascii_lowercase[13:]} HIKMRWY 1470"
    tp, drawing = write_text(text, PRESETS["faithful"], height=10.0)
    deviation = outline_deviation(tp, drawing)
    assert set(deviation) == {i for i, c in enumerate(text) if c != " "}
    worst = max(deviation.values())
    assert worst <= 1.0, {text[i]: round(d, 2) for i, d in deviation.items() if d > 1.0}


def test_expressive_styles_depart_further_from_the_font_than_the_faithful_one():
    text = "inkarm"
    worst = {
        name: max(outline_deviation(*write_text(text, PRESETS[name])).values())
        for name in ("faithful", "loose", "graffiti")
    }
    assert worst["faithful"] < worst["loose"] and worst["faithful"] < worst["graffiti"]


def test_outline_deviation_oracle_on_a_drawing_along_the_targets():
    tp = plan_text("na", PRESETS["faithful"])
    strokes, shifted = [], []
    for plan in tp.plan.strokes:
        per = 4
        pos = np.repeat(plan.means, per, axis=0)  # each target held, exactly on the outline
        t = np.arange(len(pos)) * plan.segment_time / per
        strokes.append(Trajectory(t=t, pos=pos))
        shifted.append(Trajectory(t=t, pos=pos + [0.0, 0.3]))
    on = outline_deviation(tp, Drawing(strokes))
    assert max(on.values()) < 1e-9
    off = outline_deviation(tp, Drawing(shifted))
    assert 0.0 < max(off.values()) <= 0.3 + 1e-9


def _held_targets(tp, shift=(0.0, 0.0), keep=1.0) -> Drawing:
    """A drawing that holds each target in turn (straight between them), shifted by ``shift``
    [mm], each stroke cut after the fraction ``keep`` of its samples."""
    strokes = []
    for plan in tp.plan.strokes:
        pos = np.repeat(plan.means, 4, axis=0) + shift
        t = np.arange(len(pos)) * plan.segment_time / 4
        n = max(2, round(keep * len(pos)))
        strokes.append(Trajectory(t=t[:n], pos=pos[:n]))
    return Drawing(strokes)


def test_fidelity_oracle_on_drawings_along_the_targets():
    tp = plan_text("nu", PRESETS["faithful"], ligature_gap=0.0)  # two letters, no ligature
    spacing = 0.01 * tp.font.height  # font and ink sampling: the bound on the error
    on = text_fidelity(tp, _held_targets(tp))
    assert on.drawing_to_font < 1e-9 and on.font_to_drawing <= spacing
    shifted = text_fidelity(tp, _held_targets(tp, shift=(0.0, 0.3)))
    assert shifted.font_to_drawing == pytest.approx(0.3, abs=spacing)
    assert 0.0 < shifted.drawing_to_font <= 0.3 + 1e-9
    cut = text_fidelity(tp, _held_targets(tp, keep=0.5))  # half of each letter left out
    assert cut.drawing_to_font < 1e-9 and cut.font_to_drawing > 2.0
    assert cut.symmetric == cut.font_to_drawing


def test_fidelity_summary_gives_both_directions_and_the_larger():
    fidelity = TextFidelity(drawing_to_font=0.114, font_to_drawing=0.447)
    assert fidelity.summary() == (
        "drawing->font 0.11 mm, font->drawing 0.45 mm, symmetric 0.45 mm"
    )


def test_font_deviation_names_every_letter():
    text = "hi you"
    tp, drawing = write_text(text, PRESETS["cursive"])
    assert set(font_deviation(tp, drawing)) == {i for i, c in enumerate(text) if c != " "}


def test_stylised_presets_miss_more_of_the_font_than_they_add():
    # the one-sided figure (drawing -> font) hid what expressive styles leave out of a letter
    for name in ("cursive", "loose", "graffiti"):
        fidelity = write_text("inkarm", PRESETS[name]).fidelity()
        assert isinstance(fidelity, TextFidelity)
        assert fidelity.font_to_drawing > fidelity.drawing_to_font, (name, fidelity)
        assert fidelity.symmetric == fidelity.font_to_drawing
    faithful = write_text("inkarm", PRESETS["faithful"]).fidelity()
    assert faithful.drawing_to_font <= 1.0


def test_written_strokes_follow_each_other_in_time_and_start_on_their_targets():
    tp, drawing = write_text("hi you", PRESETS["cursive"])
    assert len(drawing.strokes) == len(tp.plan.strokes)
    for a, b in zip(drawing.strokes[:-1], drawing.strokes[1:]):
        assert b.t[0] > a.t[-1]
    for plan, traj in zip(tp.plan.strokes, drawing.strokes):
        assert np.allclose(traj.pos[0], plan.means[0])
        letters, on = sample_letters(plan, traj)
        assert letters.shape == on.shape == traj.t.shape
        assert letters[0] == plan.meta["letters"][0] and letters[-1] == plan.meta["letters"][-1]


def test_write_text_takes_a_preset_name_and_names_its_results():
    result = write_text("ab", "loose")
    assert result.text_plan.text == "ab" and len(result.drawing.strokes) == 1
    with pytest.raises(ScenarioError, match="unknown handstyle 'nope'"):
        write_text("ab", "nope")


def test_seed_changes_only_styles_with_rho():
    a = plan_text("ab", PRESETS["hurried"], seed=1).plan.strokes[0].covs
    b = plan_text("ab", PRESETS["hurried"], seed=2).plan.strokes[0].covs
    assert not np.allclose(a, b)
    c = plan_text("ab", PRESETS["cursive"], seed=1).plan.strokes[0].covs
    d = plan_text("ab", PRESETS["cursive"], seed=2).plan.strokes[0].covs
    assert np.array_equal(c, d)
