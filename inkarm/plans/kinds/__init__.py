"""The built-in stroke kinds, one module each, registered in the stroke-kind registry
(``inkarm.plugins.registry("stroke_kind")``, which imports this package at its first lookup).

A stroke kind reads its ``[[strokes]]`` table of a plan file and realises it into trajectories
(:class:`inkarm.io.planfile.StrokeKind`):

* ``gaussian`` (:mod:`.gaussian`): Gaussian targets held in turn, tracked by the LQT (seed 000);
* ``keypoints`` (:mod:`.keypoints`): sparse key-points, each active at one instant (GI eq. 6-7);
* ``human_line`` (:mod:`.human_line`): the Human Line Algorithm through points (seed 002);
* ``minjerk`` (:mod:`.minjerk`): a minimum-jerk path through via-points (Flash & Hogan 1985).

A new kind is one module with such a class, plus one registration: ``STROKE_KINDS.register(
"<name>", MyKind())`` here, or an installed package's entry point ``stroke_kind.<name>`` in the
group ``inkarm.plugins`` (or, without any registration, ``kind = "package.module:MyKind"`` in the
plan).
"""

from __future__ import annotations

from inkarm.io.planfile import STROKE_KINDS
from inkarm.plans.kinds.gaussian import Gaussian
from inkarm.plans.kinds.human_line import HumanLine
from inkarm.plans.kinds.keypoints import Keypoints
from inkarm.plans.kinds.minjerk import MinJerk

STROKE_KINDS.register("gaussian", Gaussian())
STROKE_KINDS.register("keypoints", Keypoints())
STROKE_KINDS.register("human_line", HumanLine())
STROKE_KINDS.register("minjerk", MinJerk())

__all__ = ["Gaussian", "HumanLine", "Keypoints", "MinJerk"]
