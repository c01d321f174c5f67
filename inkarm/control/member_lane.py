"""The member's period compiled (``inkarm/control/_member.c``): when the executor may use it.

Each control period the executor (:mod:`inkarm.control.executor`) shapes the reference, asks its
law and checks its watchdogs in Python. For the common case, the built-in ``position`` law with
its compiled feed-forward, the built-in force loop without a learnt field or calibrated map, no
probing, and a plant that measures its pen tip, the same steps run in one C call per period
(:class:`Lane`), with the same bits: the log, the commands and every fault are those of the
Python steps (tests/control/test_member_lane.py); a batch's members take theirs in one C call
for all (:mod:`inkarm.control.batch_lanes`). The plane's solve, the watchdogs whenever the
extension's cheap test is not conclusive, and the messages of faults stay in Python, called
from C.

``INKARM_COMPILED=0`` switches it off with the other compiled parts
(:mod:`inkarm.control.compiled`). A reading the C period cannot take (not float64 arrays of the
arm's length, a force that is not a float) hands the member back to Python for the rest of the
run (:meth:`Lane.hand_over`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from inkarm.control.compiled import member_module
from inkarm.control.force import RATE_DEAD_BAND, ForceLoop
from inkarm.control.laws.position_goals import PositionGoals
from inkarm.control.surface import SurfaceEstimate
from inkarm.control.watchdogs import BUILTIN_WATCHDOGS, Watchdogs
from inkarm.core.log import APPROACH, DESCEND, DRAW, HOME, DrawLog
from inkarm.core.plant import PositionCommand


@dataclasses.dataclass(eq=False)
class Lane:
    """A member's compiled period and the columns it writes beside the log.

    Attributes:
        kernel: The extension's ``MemberPeriod``: ``period(state)`` -> the command,
            ``advance()`` -> the next plan row, ``row``, ``logged``, ``i``.
        commanded: (log rows,) the plan row commanded at each log row.
        ref_row: (log rows,) the plan row each log row's reading belongs to.
        ref_blend: (log rows,) the fraction of the way to the next plan row.
        not_for_lane: The exception ``period`` raises for a reading it cannot take.
    """

    kernel: object
    commanded: np.ndarray
    ref_row: np.ndarray
    ref_blend: np.ndarray
    not_for_lane: type[Exception]
    port: object = None

    def run(self, periods: int) -> int:
        """Up to ``periods`` whole periods in C through the plant's port (read, steps 2-4,
        command, the plant's step, the advance), where the member has one
        (:meth:`inkarm.core.plant.Plant`'s ``compiled_port``: a plant stepped alone); how many
        ran (0: none, the plant not ready for it). A fault, the plant's included, or Ctrl-C
        raises as in the executor's own period, the plant's state handed back first."""
        if self.port is None:
            return 0
        capsule = None
        try:
            capsule = self.port.enter()
            return 0 if capsule is None else self.kernel.run(capsule, periods)
        finally:
            if capsule is not None:
                self.port.leave()

    def hand_over(self, force_loop: ForceLoop) -> dict:
        """Put the C period's state into ``force_loop`` (and its plane); return the member's
        ``i``, ``row``, ``waited``, ``settled_for``, ``force_f``, ``t_first`` and the three
        columns as lists, for the Python steps to go on from."""
        state = self.kernel.export()
        force_loop.restore(state)
        return {key: state[key] for key in ("i", "row", "waited", "settled_for", "force_f",
                                            "t_first")} | {
            "commanded": self.commanded.tolist(), "ref_row": self.ref_row.tolist(),
            "ref_blend": self.ref_blend.tolist()}


def port_of(plant):
    """The plant's period in C (``compiled_port()``, :class:`inkarm.core.plant.Plant`), or None
    where it offers none, or where the port is another plant's (a wrapper that forwards its
    attributes, e.g. to shape the commands, must not be bypassed)."""
    offer = getattr(plant, "compiled_port", None)
    port = offer() if callable(offer) else None
    return port if port is not None and getattr(port, "plant", None) is plant else None


def lane_for(*, law, force_loop: ForceLoop, watchdogs: Watchdogs, plan, log: DrawLog,
             plan_columns: dict, hold_at: list[bool], senses_force: bool, senses_tip: bool,
             probes: int, settle_ticks: int, timeout_ticks: int, dt: float,
             t_first: float | None, port=None) -> Lane | None:
    """The compiled period for this member, or None where its steps are not all the C
    period's (module docstring) or the extension is not usable (``INKARM_COMPILED=0``, not
    built). ``plan`` is the member's :class:`inkarm.control.reference.JointReference`;
    ``plan_columns`` the executor's shared columns (``page_x``, ``page_y``, ``lookahead_rows``,
    ``lookahead_step``); ``force_loop`` as made, before its first period; ``port`` the plant's
    compiled period (:meth:`Lane.run`) where the member's plant steps alone, else None."""
    module = member_module()
    if (module is None or type(law) is not PositionGoals or law.compiled is None or probes
            or not senses_tip or force_loop.field is not None or force_loop.prior is not None
            or len(plan) < 1):
        return None
    surface = force_loop.surface
    names = [dog.name for dog in watchdogs.items]
    cheap = watchdogs._envelope is not None and tuple(names) == BUILTIN_WATCHDOGS
    by_name = dict(zip(names, watchdogs.items))
    envelope = [x for joint in watchdogs._envelope for x in joint] if cheap else None
    force_limit = by_name["force_limit"].limit if cheap else math.inf
    tracking_limit = by_name["tracking_limit"].limit_mm if cheap else math.inf
    rows = len(log.time)
    commanded = np.zeros(rows, dtype=np.int64)
    ref_row = np.zeros(rows, dtype=np.int64)
    ref_blend = np.zeros(rows)
    as_float = np.ascontiguousarray
    step = plan_columns["lookahead_step"]
    kernel = module.MemberPeriod(
        (as_float(plan.q, dtype=float), as_float(plan.normal_q, dtype=float),
         None if step is None else as_float(step, dtype=float),
         np.array(plan_columns["page_x"], dtype=float),
         np.array(plan_columns["page_y"], dtype=float),
         np.asarray(plan.phase, dtype=np.int64), np.array(hold_at, dtype=bool),
         as_float(plan.qd, dtype=float), as_float(plan.qdd, dtype=float)),
        (log.time, log.q, log.qd, log.torque, log.tip, log.force, commanded, ref_row, ref_blend),
        law.compiled,
        (force_loop.smoothing, force_loop.threshold, force_loop.k_force, force_loop.f_star,
         force_loop.z_limit, force_loop.search_step, force_loop.settle_tol, force_loop._k_inv,
         force_loop._rate_smoothing, force_loop._inv_dt, force_loop._lead_gain,
         force_loop._sampling, force_loop._depths.maxlen, RATE_DEAD_BAND, surface.prior,
         surface.refit_every, force_loop.search_failed, SurfaceEstimate.plane),
        watchdogs.check, envelope, force_limit, tracking_limit,
        plan_columns["lookahead_rows"], senses_force, settle_ticks, timeout_ticks,
        (APPROACH, DESCEND, DRAW, HOME), dt, t_first is not None,
        0.0 if t_first is None else t_first, (math.hypot, np.empty, PositionCommand))
    return Lane(kernel, commanded, ref_row, ref_blend, module.NotForLane, port)


__all__ = ["Lane", "lane_for", "port_of"]
