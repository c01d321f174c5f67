"""Text to motor plans: Hershey glyphs -> Gaussian targets -> ligatured strokes (seed 000 sec. 4.1).

The pipeline, one module a step: the glyphs of a Hershey font (:mod:`inkarm.plans.fonts`)
are placed on the page (:mod:`inkarm.plans.layout`), their strokes become target sequences
(:mod:`inkarm.plans.targets`), letters whose pen-up gap is small are joined into ligatures
(:mod:`inkarm.plans.ligatures`, :mod:`inkarm.plans.connectors`), and a handstyle
(:mod:`inkarm.plans.handstyles`) gives the targets their covariances and timing
(:func:`plan_text`, a :class:`inkarm.plans.textplan.TextPlan`) and draws them
(:func:`write_text`). How far the written text is from the font, both ways, is measured by
:mod:`inkarm.plans.fidelity`.

Coordinates: page frame in [mm], x right, y up, origin at the page's lower-left corner.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from inkarm.core.trajectory import Drawing
from inkarm.plans.fidelity import TextFidelity, text_fidelity
from inkarm.plans.fonts import DEFAULT_FONT, DEFAULT_HEIGHT, HersheyFont
from inkarm.plans.handstyles import Handstyle, get_handstyle
from inkarm.plans.layout import PageLayout, layout_text
from inkarm.plans.ligatures import join_ligatures
from inkarm.plans.targets import glyph_targets
from inkarm.plans.textplan import TextPlan


def plan_text(
    text: str,
    style: Handstyle | str,
    height: float = DEFAULT_HEIGHT,
    font: str = DEFAULT_FONT,
    layout: PageLayout = PageLayout(),  # noqa: B008 (frozen: one shared default is safe)
    ligature_gap: float | None = None,
    seed: int | np.random.Generator | None = 0,
) -> TextPlan:
    """Text -> ligatured Gaussian targets with the covariances of ``style`` (a Handstyle).

    Args:
        text: What to write (newlines and tabs allowed, no other control character).
        style: The :class:`inkarm.plans.handstyles.Handstyle` (covariances, thinning,
            ligature angle and eyelet, time per target), or a preset's name.
        height: Cap height of the letters in [mm].
        font: Hershey font name (script fonts: ``scripts``, ``scriptc``).
        layout: Page, margins and line height.
        ligature_gap: Largest pen-up gap in [mm] bridged by a ligature; None = 0.45 x height
            (bridges most joins of the ``scripts`` lower case, never a space).
        seed: Seed or Generator for the covariance perturbation (rho > 0).
    """
    style = get_handstyle(style) if isinstance(style, str) else style
    f = HersheyFont(font, height)
    placed = layout_text(text, f, layout)
    gap = 0.45 * f.height if ligature_gap is None else float(ligature_gap)
    spacing = None if style.max_spacing is None else style.max_spacing * f.height
    pieces = glyph_targets(placed, style.thin_angle, spacing, mark_size=0.2 * f.height)
    eyelet = style.eyelet * f.height if style.eyelet > 0 else None
    pieces = join_ligatures(pieces, gap, style.ligature_angle, eyelet)
    rng = np.random.default_rng(seed)
    return TextPlan(text, style.motor_plan(pieces, rng, "letters"), tuple(placed), f)


class WrittenText(NamedTuple):
    """What :func:`write_text` returns (unpacks as ``tp, drawing``)."""

    text_plan: TextPlan
    drawing: Drawing

    def fidelity(self) -> TextFidelity:
        """How far the drawing is from the font, both ways (:func:`text_fidelity`)."""
        return text_fidelity(self.text_plan, self.drawing)


def write_text(text: str, style: Handstyle | str, dt: float = 0.01, **kwargs) -> WrittenText:
    """Plan and realise ``text`` with ``style`` (a Handstyle or a preset's name): the plan and
    the Drawing, strokes timed one after the other. Keyword arguments go to
    :func:`plan_text`."""
    style = get_handstyle(style) if isinstance(style, str) else style
    tp = plan_text(text, style, **kwargs)
    layout = kwargs.get("layout", PageLayout())
    return WrittenText(tp, style.realise(tp.plan, dt=dt, page_size=layout.page_size))
