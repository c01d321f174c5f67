"""The built-in position law's compiled feed-forward (``inkarm/control/_law.c``) and the member's
compiled period (``inkarm/control/_member.c``, :mod:`inkarm.control.member_lane`): whether this
process may use them.

The extension is built by pip beside the plant's period (``setup.py``; optional, x86-64 only:
its clip breaks ties as NumPy's maximum/minimum do there). It needs no MuJoCo, so it lives in
``control/`` with the law, for any plant. It is used only when both hold, else
:func:`position_law` returns None and :class:`inkarm.control.laws.position_goals.PositionGoals`
runs its Python arithmetic, which gives the same bits (tests/control/test_compiled_law.py):

* the environment variable ``INKARM_COMPILED`` is not ``0`` (the switch for comparisons, the
  same as the plant's period's);
* the extension imports, and is of this source (``API``).

Why a fallback is taken is logged once at debug level on ``inkarm.control.compiled``.
"""

from __future__ import annotations

import logging

from inkarm.core.compiled import SWITCH, loader, switched_on

_LOG = logging.getLogger(__name__)
API = 3  # (inkarm/control/_law.c's INKARM_LAW_API)


# the module, or None (why logged once)
_load = loader("inkarm.control._law", API, "compiled position law", _LOG)


def position_law():
    """``PositionLaw(planned_torque, direction, contact_tau, q_ref, normal_q, estimate, ceiling,
    rate)`` of the extension, or None: switched off with ``INKARM_COMPILED=0``, or not usable
    here (logged once, debug)."""
    module = _load() if switched_on() else None
    return None if module is None else module.PositionLaw


def member_module():
    """The extension module (``MemberPeriod``, ``NotForLane``), or None as :func:`position_law`."""
    return _load() if switched_on() else None


__all__ = ["SWITCH", "member_module", "position_law", "switched_on"]
