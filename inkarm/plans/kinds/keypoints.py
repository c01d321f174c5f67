"""The ``keypoints`` stroke kind: sparse key-points, each active at one instant (GI eq. 6-7),
optionally with velocities (GI sec. 4.3), tracked by the LQT like :mod:`.gaussian` strokes. A
key-point without a covariance (none given for the stroke or the plan either) weighs the
identity (GI eq. 7)."""

from __future__ import annotations

from inkarm.plans.kinds.gaussian import Gaussian


class Keypoints(Gaussian):
    """Targets read and realised as :class:`Gaussian`'s; the plan marks them key-points
    (``StrokePlan.keypoints``) because the stroke's kind is ``keypoints``."""
