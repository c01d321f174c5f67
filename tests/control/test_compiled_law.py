"""The built-in position law's compiled feed-forward (inkarm/control/_law.c via
inkarm.control.compiled) against its Python arithmetic: the same bits in the feed-forward and in
the friction estimate over many set points, the errors that name what was expected, and the
Python path whenever the extension cannot or may not be used."""

from __future__ import annotations

import logging
import sys
from types import SimpleNamespace

import numpy as np
import pytest

import inkarm.control
from inkarm.control import compiled
from inkarm.control.laws import Setpoint, position_goals
from inkarm.control.laws.position_goals import PositionGoals
from tests.compiled import compiled_or_skip

ROWS, N = 40, 3


@pytest.fixture
def built():
    """The extension's PositionLaw, or a skip that says why (a failure with
    INKARM_REQUIRE_COMPILED=1)."""
    compiled._load.cache_clear()
    return compiled_or_skip(compiled.position_law(), "the compiled position law")


class _Plan(SimpleNamespace):
    def __len__(self) -> int:
        return len(self.q)


def _context(rng, gamma: float):
    """A law context of ROWS random plan rows for N joints (what PositionGoals.start reads)."""
    plan = _Plan(q=rng.normal(size=(ROWS, N)), qd=rng.normal(scale=0.02, size=(ROWS, N)),
                 bias=rng.normal(size=(ROWS, N)), inertia=rng.normal(size=(ROWS, N)),
                 contact_tau=rng.normal(size=(ROWS, N)), normal_q=rng.normal(size=(ROWS, N)))
    plan.qd[0] = [0.0, -0.0, 0.0]  # (signed zeros of the smooth sign)
    model = SimpleNamespace(dof_frictionloss=np.array([0.3, 0.0, 1.2, 9.0]))
    kin = SimpleNamespace(model=model, dof_adr=np.array([0, 1, 2]),
                          bias=lambda q, qd: np.cos(q))
    return SimpleNamespace(plan=plan, kinematics=kin, dt=0.01,
                           config=SimpleNamespace(friction_adaptation=gamma))


def _pair(monkeypatch, rng, gamma: float) -> tuple[PositionGoals, PositionGoals]:
    """The same law started twice on one context: compiled, then in Python."""
    context = _context(rng, gamma)
    fast = PositionGoals()
    fast.start(context)
    assert fast.compiled is not None
    monkeypatch.setattr(position_goals, "position_law", lambda: None)
    slow = PositionGoals()
    slow.start(context)
    assert slow.compiled is None
    return fast, slow


def _setpoint(rng, law: PositionGoals, stopping: bool = False) -> Setpoint:
    c = int(rng.integers(ROWS))
    seen = c if rng.random() < 0.3 else int(rng.integers(ROWS))
    depth = float(rng.choice([0.0, -0.0, rng.normal(scale=1e-3)]))
    q_row = law.q_ref[c] + depth * law.normal_q[c]
    blend = float(rng.choice([0.0, rng.random()]))
    return Setpoint(c, q_row + 1e-3, law.direction[c], law.q_ref[c], q_row,
                    bool(rng.random() < 0.5), depth, seen, blend, stopping)


@pytest.mark.parametrize("gamma", [0.0, 30.0, 3e4])  # (fixed, adapting, clipping at 0 and F_max)
def test_the_same_bits_as_the_python_law(built, monkeypatch, gamma):
    rng = np.random.default_rng(int(gamma))
    fast, slow = _pair(monkeypatch, rng, gamma)
    floor = ceiling = False
    for k in range(400):
        setpoint = _setpoint(rng, fast, stopping=k % 97 == 96)
        q = setpoint.q_row + rng.normal(scale=[1e-4, 1e-2, 1.0][k % 3], size=N)
        if k == 300:
            q[1] = np.nan  # (NaN stays NaN through the clip, as in numpy)
        state = SimpleNamespace(q=q)
        a, b = fast.command(state, setpoint), slow.command(state, setpoint)
        assert all(np.asarray(x).tobytes() == np.asarray(y).tobytes() for x, y in zip(a, b))
        assert fast.friction.estimate.tobytes() == slow.friction.estimate.tobytes(), k
        floor |= bool(np.any(fast.friction.estimate == 0.0))
        ceiling |= bool(np.any(fast.friction.estimate == fast.friction.ceiling))
    assert floor and ceiling or gamma != 3e4  # (both bounds were reached)


@pytest.mark.parametrize("kind", [list, np.float32])
def test_what_is_not_float64_arrays_turns_the_law_to_python(built, monkeypatch, kind):
    rng = np.random.default_rng(1)
    fast, slow = _pair(monkeypatch, rng, 30.0)
    for k in range(6):  # (float64, then another kind once, then float64 again)
        setpoint = _setpoint(rng, fast)
        q = setpoint.q_row + 1e-3
        q = (list(q) if kind is list else q.astype(kind)) if k == 2 else q
        a = fast.command(SimpleNamespace(q=q), setpoint)
        b = slow.command(SimpleNamespace(q=q), setpoint)
        assert a.torque.tobytes() == b.torque.tobytes()
        assert fast.friction.estimate.tobytes() == slow.friction.estimate.tobytes()
        assert (fast.compiled is None) == (k >= 2)


def test_wrong_sizes_and_rows_are_refused_with_what_was_expected(built):
    plan, row = np.zeros((4, 2)), np.zeros(2)
    with pytest.raises(ValueError, match=r"contact_tau must be float64 of shape \(rows, n\) "
                                         r"\(the plan's 4 rows x 2 joints\)"):
        built(plan, plan, np.zeros((3, 2)), plan, plan, row, row, 1.0)
    with pytest.raises(ValueError, match=r"estimate must be float64 of shape \(n,\)"):
        built(plan, plan, plan, plan, plan, np.zeros(3, dtype=np.float32), row, 1.0)
    law = built(plan, plan, plan, plan, plan, row, row, 1.0)
    with pytest.raises(ValueError, match="q must be 2 float64"):
        law.command(np.empty(2), row, np.zeros(3), 0, 0, 0.0, 0.0, False)
    with pytest.raises(IndexError, match=r"rows c = 4, seen = 0 not in the plan's 0..3"):
        law.command(np.empty(2), row, row, 4, 0, 0.0, 0.0, False)
    with pytest.raises(TypeError, match=r"command\(out, q_row, q, c, seen"):
        law.command(np.empty(2), row)
    with pytest.raises(RuntimeError, match="not initialised"):
        built.__new__(built).command(np.empty(2), row, row, 0, 0, 0.0, 0.0, False)


def test_the_switch_and_a_missing_or_stale_extension_fall_back(built, monkeypatch, caplog):
    monkeypatch.setenv(compiled.SWITCH, "0")
    assert compiled.position_law() is None
    monkeypatch.delenv(compiled.SWITCH)
    caplog.set_level(logging.DEBUG, logger="inkarm.control.compiled")
    for stale, why in ((None, "not built"), (SimpleNamespace(API=compiled.API + 1),
                                             "of another inkarm")):
        compiled._load.cache_clear()
        monkeypatch.delattr(inkarm.control, "_law", raising=False)
        monkeypatch.setitem(sys.modules, "inkarm.control._law", stale)
        assert compiled.position_law() is None
        assert why in caplog.text
    compiled._load.cache_clear()
