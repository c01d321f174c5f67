"""Ligatures: target sequences of neighbouring letters joined into one stroke (seed 000
sec. 4.1).

Letters whose pen-up gap is small are joined into one stroke (a ligature).

Angle convention: the *turning angle* at vertex p_i is the angle between the incoming
direction p_i - p_{i-1} and the outgoing one p_{i+1} - p_i, in [0, 180] deg: 0 = straight on,
180 = full reversal (a cusp). Seed 000 says a ligature removes a target "if the angle formed
with the previous target and the next is larger than a user-defined threshold" (100 deg in
its Fig. 10); read as the interior angle (180 = straight) that rule would delete the harmless
straight-through targets and keep the hooks, the opposite of a smooth ligature, so we read it
as the turning angle, computed by :func:`inkarm.analysis.density.turning_angles` (in radians,
converted here).

Ligatures keep the letters. Dropping targets until no junction is sharp (seed 000's rule,
still used for asemic tags) cuts off what they outlined: Hershey's script a, c, d, g, o, q
and w start on the far side of their bowl and turn back over it, so the rule ate the top of
the bowl (font -> drawing 3 mm on "inkarm"). Here no junction target turns by more than the
threshold either, but the *connector* gives way: it swings back over the bowl and loops into
the letter's first target (a cursive retrace written as an eyelet), or leaves the exit's last
point, which lies on the next letter, for that letter to draw, or bends
(:func:`join_ligatures`; the shapes in :mod:`inkarm.plans.connectors`). How far the written
text is from the font, both ways, is measured by :mod:`inkarm.plans.fidelity`.

Coordinates: page frame in [mm], as in :mod:`inkarm.plans.layout`.
"""

from __future__ import annotations

import math

import numpy as np

from inkarm.plans.connectors import bends, distance_to_path, swing_connector
from inkarm.plans.targets import SAME_POINT, TargetSequence


def join_ligatures(
    pieces: list[TargetSequence], max_gap: float, max_turn: float, eyelet: float | None = None
) -> list[TargetSequence]:
    """Join consecutive target sequences into ligatures (seed 000 sec. 4.1).

    Two sequences are joined when both are joinable, the pen-up gap between them is at most
    ``max_gap`` [mm], and they belong to the same letter or to neighbouring letters of the
    text (so never across a space). Pieces of the same letter are joined as they are (a
    Hershey letter breaks its strokes at retraced cusps, which belong to the letter's form);
    an end point shared by two pieces (zero gap) counts once.

    Where two *letters* meet, no *junction target* (the last target of the first letter, the
    connector targets, the first target of the second) may turn by more than ``max_turn``
    [deg]. How that is reached depends on ``eyelet``:

    * None: seed 000's rule, for asemic tags. Junction targets that turn more than
      ``max_turn`` are dropped, repeatedly, until none does (:func:`_drop_sharp`); the last
      target a letter has left is never dropped.
    * A size in [mm]: letters keep their targets and the connector bends instead
      (:func:`_join_letters`), seed 000's rule being only the last resort.

    Each junction sees only the two letters it joins, so the time is linear in the number of
    targets.
    """
    out: list[TargetSequence] = []
    ligature: _Ligature | None = None
    for piece in pieces:
        if not len(piece):
            continue
        if ligature is not None and ligature.takes(piece, max_gap):
            ligature.add(piece, max_turn, eyelet)
        else:
            if ligature is not None:
                out.append(ligature.sequence())
            ligature = _Ligature(piece)
    if ligature is not None:
        out.append(ligature.sequence())
    return out


class _Ligature:
    """A ligature being built: the letters already joined (never changed again), the last
    targets before the current letter (the context its turning angles need), and the current
    letter's targets, the only ones the next junction may change."""

    CONTEXT = 2

    def __init__(self, piece: TargetSequence) -> None:
        self.done: list[TargetSequence] = []
        self.context = _slice(piece, 0, 0)
        self.tail = _slice(piece, 0, len(piece))

    def takes(self, piece: TargetSequence, max_gap: float) -> bool:
        last = int(self.tail.letters[-1])
        return bool(
            self.tail.joinable
            and piece.joinable
            and np.linalg.norm(piece.means[0] - self.tail.means[-1]) <= max_gap
            and int(piece.letters[0]) in (last, last + 1)
        )

    def add(self, piece: TargetSequence, max_turn: float, eyelet: float | None) -> None:
        shared = _same(piece.means[0], self.tail.means[-1])
        following = _slice(piece, 1 if shared else 0, len(piece))
        if not len(following):
            return  # a single target on the end of the path: nothing to add
        if not shared:
            following.connectors[0] = True
        if piece.letters[0] == self.tail.letters[-1]:
            self.tail = _concat([self.tail, following])
            return
        first, second = _join_letters(
            self.context, self.tail, following, piece.means, shared, max_turn, eyelet
        )
        self.done.append(first)
        context = _concat([self.context, first])
        self.context = _slice(context, max(0, len(context) - self.CONTEXT), len(context))
        self.tail = second

    def sequence(self) -> TargetSequence:
        return _concat([*self.done, self.tail])


def _join_letters(
    context: TargetSequence,
    first: TargetSequence,
    second: TargetSequence,
    outline: np.ndarray,
    shared: bool,
    max_turn: float,
    eyelet: float | None,
) -> tuple[TargetSequence, TargetSequence]:
    """Join the targets of one letter, ``second`` (without a start point it shares with
    ``first``), to those of the letter before, ``first``, which follows the ``context``
    targets (read for turning angles, never changed). ``outline`` (k, 2) [mm] is the second
    letter's first piece, its start point included even when ``shared`` with ``first``.
    Returns the targets of both letters, connector targets included, so that no junction
    target turns by more than ``max_turn`` [deg].

    With an ``eyelet`` size [mm], the first of these junctions whose targets all turn by at
    most ``max_turn`` is taken, so every letter target is kept while one is:

    1. the straight connector;
    2. the *swing*: where the first letter's exit ends on the second letter's outline (the
       Hershey script's exit strokes end on the side of a following a, c, d, g, o, q or w,
       whose pen starts on the far side of the bowl and turns back over it), the connector
       swings back along that outline, up to ``eyelet`` outside it, and turns into the first
       target through a loop of diameter ``eyelet``: a cursive hand's retrace at the top of
       the bowl, written as an eyelet rather than a cusp (:func:`swing_connector`);
    3. the last target of the first letter left out when it lies on the second letter's
       outline (the exit overshooting into the next letter, whose pen draws that point);
    4. a *bend*: one connector target after the first letter and/or before the second, at
       ``eyelet`` or a third of the gap, that turns the pen part of the way
       (:func:`bends`), with or without 3.

    Otherwise (and without an ``eyelet``, or where the letters share the junction point)
    seed 000's rule: :func:`_drop_sharp`.
    """
    b_letter = int(second.letters[0])

    def attempt(head: TargetSequence, links: list[tuple[np.ndarray, int]]):
        joined = _with_links(context, head, links, second)
        lo = len(context) + len(head) - 1
        hi = lo + len(links) + (0 if shared else 1)
        pts = joined.means.tolist()
        for i in range(lo, hi + 1):
            turn = _turn_at(pts, i)
            if turn is not None and turn > max_turn:
                return None
        return joined

    joined = attempt(first, [])
    if joined is None and eyelet is not None and eyelet > 0 and not shared:
        joined = _shape_keeping_join(context, first, second, outline, max_turn, eyelet, attempt)
    if joined is None:
        joined = _with_links(context, first, [], second)
        joint = len(context) + len(first)
        joined = _drop_sharp(joined, [joint - 1, joint], max_turn)
    return _split(joined, len(context), b_letter)


def _shape_keeping_join(context, first, second, outline, max_turn, eyelet, attempt):
    """Steps 2 to 4 of :func:`_join_letters`: the first smooth join, or None."""
    a_letter, b_letter = int(first.letters[-1]), int(second.letters[0])
    p = first.means[-1]
    on_next = len(outline) > 1 and distance_to_path(p, outline) <= 0.5 * eyelet
    if on_next:
        swing = swing_connector(p, outline, eyelet, max_turn)
        if swing is not None and (joined := attempt(first, [(x, b_letter) for x in swing])):
            return joined
    heads = [first]
    if on_next and len(first) > 1:
        heads.insert(0, _slice(first, 0, len(first) - 1))
        if joined := attempt(heads[0], []):
            return joined
    after = _distinct_after(second.means, 0)
    for head in reversed(heads):  # the whole first letter first
        before = _distinct_before(np.vstack([context.means, head.means]))
        for bend in bends(before, head.means[-1], second.means[0], after, eyelet, max_turn):
            links = [(x, a_letter if own else b_letter) for x, own in bend]
            if joined := attempt(head, links):
                return joined
    return None


def _drop_sharp(seq: TargetSequence, candidates: list[int], max_turn: float) -> TargetSequence:
    """Drop junction targets whose turning angle exceeds ``max_turn`` [deg], repeatedly: when
    a target goes, its kept neighbours form the new junction and are checked in turn, until
    no junction target of the two joined letters turns by more than ``max_turn``. The ends of
    the sequence, and the last target a letter has left in it, are never dropped."""
    keep = np.ones(len(seq), bool)
    connectors = seq.connectors.copy()
    todo = [i for i in candidates if 0 <= i < len(seq)]
    joined = {int(seq.letters[i]) for i in todo}
    while todo:
        i = todo.pop(0)
        same_letter = keep & (seq.letters == seq.letters[i])
        if not keep[i] or int(seq.letters[i]) not in joined or same_letter.sum() == 1:
            continue
        turn = _turn_at(seq.means, i, keep)
        if turn is not None and turn > max_turn:
            keep[i] = False
            a = np.flatnonzero(keep[:i])[-1]
            b = i + 1 + np.flatnonzero(keep[i + 1 :])[0]
            connectors[b] = True
            todo += [a, b]
    return TargetSequence(seq.means[keep], seq.letters[keep], connectors[keep], seq.joinable)


def _turn_at(means, i: int, keep: np.ndarray | None = None) -> float | None:
    """Turning angle in [deg] at target ``i``, between the nearest (kept) targets before and
    after it at another point (a target repeated in place turns where the path turns); None
    at an end of the path. ``means``: (m, 2) array, or its ``tolist()`` (faster when asked
    at several targets)."""
    pts = means.tolist() if isinstance(means, np.ndarray) else means
    a = _distinct_index(pts, i, -1, keep)
    b = _distinct_index(pts, i, +1, keep)
    if a is None or b is None:
        return None
    return _turn_angle(pts[a], pts[i], pts[b])


def _turn_angle(p: list[float], q: list[float], r: list[float]) -> float:
    """Turning angle in [deg] at q of the path p, q, r (three points apart): the value of
    :func:`inkarm.analysis.density.turning_angles` (Kahan's angle between the steps) at q,
    in the same floating-point operations, on Python floats."""
    (p0, p1), (q0, q1), (r0, r1) = p, q, r  # (points in the plane)
    u0, u1, v0, v1 = q0 - p0, q1 - p1, r0 - q0, r1 - q1
    nu = math.sqrt(u0 * u0 + u1 * u1)
    nv = math.sqrt(v0 * v0 + v1 * v1)
    a0, a1, b0, b1 = u0 * nv, u1 * nv, v0 * nu, v1 * nu
    minus = math.sqrt((a0 - b0) * (a0 - b0) + (a1 - b1) * (a1 - b1))
    plus = math.sqrt((a0 + b0) * (a0 + b0) + (a1 + b1) * (a1 + b1))
    return math.degrees(2.0 * math.atan2(minus, plus))


def _distinct_index(means, i: int, step: int, keep=None) -> int | None:
    """The nearest (kept) target from ``i`` in direction ``step`` at another point (more than
    ``SAME_POINT`` away); ``means`` an (m, 2) array or its ``tolist()``."""
    pts = means.tolist() if isinstance(means, np.ndarray) else means
    x, y = pts[i]
    j = i + step
    while 0 <= j < len(pts):
        if keep is None or keep[j]:
            dx, dy = pts[j][0] - x, pts[j][1] - y
            if math.sqrt(dx * dx + dy * dy) > SAME_POINT:
                return j
        j += step
    return None


def _distinct_before(means: np.ndarray) -> np.ndarray | None:
    """The last point of ``means`` before its end point at another point, or None."""
    j = _distinct_index(means, len(means) - 1, -1)
    return None if j is None else means[j]


def _distinct_after(means: np.ndarray, i: int) -> np.ndarray | None:
    j = _distinct_index(means, i, +1)
    return None if j is None else means[j]


def junction_turns(
    means: np.ndarray, letters, connectors
) -> list[tuple[int, int, float]]:
    """(letter before, letter after, largest turning angle [deg]) of every junction between
    two letters along a target path: the targets from the last one of a letter's outline
    through the connector targets to the first one of the next letter (a start point shared
    by both letters alone)."""
    means = np.asarray(means, dtype=float)
    letters, connectors = np.asarray(letters), np.asarray(connectors, dtype=bool)
    out = []
    for j in np.flatnonzero(letters[1:] != letters[:-1]) + 1:
        lo = j - 1
        while lo > 0 and connectors[lo] and letters[lo - 1] == letters[lo]:
            lo -= 1  # connector targets of the first letter
        hi = j - 1
        while hi + 1 < len(means) and connectors[hi + 1] and letters[hi + 1] == letters[j]:
            hi += 1  # connector targets of the second letter, and its first target
        turns = [t for i in range(lo, hi + 1) if (t := _turn_at(means, i)) is not None]
        out.append((int(letters[j - 1]), int(letters[j]), max(turns, default=0.0)))
    return out


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.linalg.norm(a - b) <= SAME_POINT)


def _slice(seq: TargetSequence, lo: int, hi: int) -> TargetSequence:
    return TargetSequence(
        seq.means[lo:hi].copy(), seq.letters[lo:hi].copy(), seq.connectors[lo:hi].copy(),
        seq.joinable,
    )


def _concat(seqs: list[TargetSequence]) -> TargetSequence:
    return TargetSequence(
        np.concatenate([s.means for s in seqs]),
        np.concatenate([s.letters for s in seqs]),
        np.concatenate([s.connectors for s in seqs]),
        seqs[-1].joinable,
    )


def _with_links(
    context: TargetSequence,
    head: TargetSequence,
    links: list[tuple[np.ndarray, int]],
    second: TargetSequence,
) -> TargetSequence:
    """``context`` + ``head`` + connector targets (point, letter) + ``second``."""
    middle = TargetSequence(
        np.array([x for x, _ in links], dtype=float).reshape(-1, 2),
        np.array([letter for _, letter in links], dtype=head.letters.dtype),
        np.ones(len(links), bool),
    )
    return _concat([context, head, middle, second])


def _split(joined: TargetSequence, n_context: int, second: int) -> tuple[TargetSequence, ...]:
    """The joined targets after the context: those before the second letter's, and its own."""
    body = _slice(joined, n_context, len(joined))
    k = int(np.argmax(body.letters == second)) if np.any(body.letters == second) else len(body)
    return _slice(body, 0, k), _slice(body, k, len(body))
