"""Watchdogs, one at a time: each fires on its threshold (and not below), names itself, the
joint and the numbers."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.control.config import LoopConfig
from inkarm.control.friction import FrictionCompensation
from inkarm.control.surface import SurfaceEstimate
from inkarm.control.watchdogs import (
    BUILTIN_WATCHDOGS,
    WatchContext,
    Watchdogs,
    WatchdogSpec,
    make_watchdog,
)
from inkarm.errors import RunFault

NAMES = ("a", "b")
Z = np.zeros(2)


def context(**config):
    return WatchContext(LoopConfig(**config), 0.01, NAMES, torque_limit=np.array([10.0, 5.0]),
                        speed_limit=np.array([1.0, 2.0]),
                        joint_range=np.array([[-1.0, 1.0], [-2.0, 2.0]]))


def dog(**config):
    return Watchdogs(context(**config))


def fire(watchdog, **reading):
    args = {"time": 1.0, "q": Z, "qd": Z, "torque": Z, "force": 0.0, "error_mm": 0.0}
    args.update(reading)
    watchdog.check(**args)


def test_the_force_limit_fires_above_its_threshold_only():
    w = dog(force_limit_n=5.0)
    fire(w, force=5.0)
    with pytest.raises(RunFault, match=r"^force_limit: pen force 5.01 N above the 5 N limit at "
                                       r"t = 1.000 s$") as info:
        fire(w, force=5.01)
    assert info.value.watchdog == "force_limit" and info.value.time_s == 1.0


def test_tracking_must_stay_off_for_the_whole_window():
    w = dog(tracking_limit_mm=5.0, watchdog_s=0.05)  # 5 periods
    for _ in range(4):
        fire(w, error_mm=6.0)
    fire(w, error_mm=1.0)  # back on track: the count starts again
    for _ in range(4):
        fire(w, error_mm=6.0)
    with pytest.raises(RunFault, match=r"tracking_limit: pen 6.0 mm from its reference for "
                                       r"50 ms \(limit 5 mm\)"):
        fire(w, error_mm=6.0)


def test_a_joint_outside_its_range_is_named():
    with pytest.raises(RunFault, match=r"joint_limit: b at 120.3 deg, outside its range "
                                       r"\[-114.592, 114.592\] deg"):
        fire(dog(), q=np.array([0.0, 2.1]))


def test_joint_speed_over_its_limit_with_tolerance():
    w = dog(watchdog_s=0.02)
    for _ in range(5):
        fire(w, qd=np.array([1.19, 0.0]))  # within 1.2 x the limit
    fire(w, qd=np.array([1.3, 0.0]))
    with pytest.raises(RunFault, match=r"joint_speed: a at 1.30 rad/s, above its 1.00 rad/s"):
        fire(w, qd=np.array([1.3, 0.0]))


def test_torque_at_its_limit_for_the_saturation_time():
    w = dog(saturation_s=0.03)
    fire(w, torque=np.array([0.0, 5.0]))
    fire(w, torque=np.array([0.0, -5.0]))
    with pytest.raises(RunFault, match=r"torque_saturated: b torque at its 5 N m limit for 30 ms"):
        fire(w, torque=np.array([0.0, 4.96]))


def test_the_surface_estimate_recovers_a_plane_exactly():
    rng = np.random.default_rng(0)
    surface = SurfaceEstimate(prior=0.0, refit_every=1)
    a, b, c = 0.003, 0.035, -0.01  # 3 mm offset, 2 deg and -0.6 deg slopes
    for x, y in rng.uniform(0.0, 0.2, (30, 2)):
        surface.add(x, y, a + b * x + c * y)
    for x, y in rng.uniform(0.0, 0.2, (5, 2)):
        assert surface.height(x, y) == pytest.approx(a + b * x + c * y, abs=1e-12)


def test_collinear_samples_do_not_invent_a_slope_across_them():
    surface = SurfaceEstimate(prior=1e-3)
    for x in np.linspace(0.0, 0.05, 20):
        surface.add(x, 0.1, 0.002 + 0.03 * x)
    # along the line the slope is learnt; across it (y) the ridge keeps it flat
    assert surface.height(0.05, 0.1) == pytest.approx(0.002 + 0.03 * 0.05, rel=0.2)
    assert surface.height(0.0, 0.2) == pytest.approx(surface.height(0.0, 0.1), abs=1e-9)


def test_friction_estimate_grows_while_a_joint_lags_in_its_direction_and_stays_bounded():
    comp = FrictionCompensation(np.array([1.0]), dt=0.01, gamma=1e3)
    forwards = comp.direction(np.array([0.5]))
    assert forwards[0] == pytest.approx(np.tanh(50.0))
    first = comp.torque(forwards, np.array([0.0]))
    assert first[0] == pytest.approx(np.tanh(50.0))
    for _ in range(100):
        comp.torque(forwards, np.array([0.001]))  # lagging while moving forwards
    assert comp.estimate[0] == pytest.approx(1.0 + 100 * 1e3 * 0.01 * 0.001 * np.tanh(50.0))
    for _ in range(10000):
        comp.torque(forwards, np.array([1.0]))
    assert comp.estimate[0] == pytest.approx(6.0)  # 4 x model + 2 N m
    fixed = FrictionCompensation(np.array([1.0]), dt=0.01, gamma=0.0)
    fixed.torque(forwards, None)  # (a fixed estimate needs no error)
    assert fixed.estimate[0] == 1.0


def test_the_built_ins_are_checked_in_order_and_a_user_watchdog_after_them():
    w = Watchdogs(context(), (WatchdogSpec("tests.control.test_watchdog:StillPen",
                                           (("after", 3),)),))
    assert [d.name for d in w.items] == [*BUILTIN_WATCHDOGS, "still_pen"]
    for _ in range(2):
        fire(w)
    with pytest.raises(RunFault, match=r"^still_pen: 3 periods without moving at t = 1.000 s$"):
        fire(w)
    # the first built-in that fires wins over the user's
    with pytest.raises(RunFault, match=r"^force_limit: "):
        fire(Watchdogs(context(), (WatchdogSpec("tests.control.test_watchdog:StillPen",
                                                (("after", 1),)),)), force=9.0)


class StillPen:
    """A user's watchdog: the joints have not moved for ``after`` periods."""

    name = "still_pen"

    def __init__(self, after: int = 10):
        self.after = after

    def start(self, context):
        self.still = 0

    def check(self, watched):
        self.still = self.still + 1 if not watched.qd.any() else 0
        return f"{self.still} periods without moving" if self.still >= self.after else None


@pytest.mark.parametrize("name, settings, message", [
    ("force_limt", {}, (r"controller.watchdogs: unknown watchdog 'force_limt' \(did you mean "
                       r"'force_limit'\?\)")),
    ("tests.control.test_watchdog:Nothing", {}, r"has no attribute 'Nothing'"),
    ("tests.control.test_watchdog:NAMES", {}, r"is not a watchdog"),
    ("tests.control.test_watchdog:StillPen", {"afterr": 2},
     (r"controller.tests.control.test_watchdog:StillPen.afterr: watchdog "
     r"'tests.control.test_watchdog:StillPen' has no setting 'afterr' \(did you mean 'after'")),
])
def test_a_bad_watchdog_is_refused_by_name(name, settings, message):
    from inkarm.errors import InputError

    with pytest.raises(InputError, match=message):
        make_watchdog(name, settings)
