"""The record of a written text's plan (:func:`inkarm.plans.text.plan_text`): the motor plan
and the font glyphs it came from, read by the fidelity measures (:mod:`inkarm.plans.fidelity`)
and the figures.

Coordinates: page frame in [mm], as in :mod:`inkarm.plans.layout`.
"""

from __future__ import annotations

from dataclasses import dataclass

from inkarm.core.plan import MotorPlan
from inkarm.plans.fonts import HersheyFont
from inkarm.plans.layout import PlacedGlyph


@dataclass(frozen=True)
class TextPlan:
    """A written text: the motor plan plus what produced it (for figures and checks).

    Attributes:
        text: The text.
        plan: One stroke per pen-down ligature; stroke meta ``letters`` gives, per target,
            the index in ``text`` of the letter the target came from, and ``connectors``
            whether the path into the target is a ligature rather than the letter's outline.
        glyphs: The placed font glyphs (page [mm]).
        font: The font used.
    """

    text: str
    plan: MotorPlan
    glyphs: tuple[PlacedGlyph, ...]
    font: HersheyFont
