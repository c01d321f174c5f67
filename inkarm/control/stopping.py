"""The safe stop after a fault, and what a run does when its own law fails.

A fault (a watchdog, the force loop's search, the device, a law that raised) ends a member's
drawing; the executor (:mod:`inkarm.control.executor`) then lifts the pen along the paper normal
with the run's law (:func:`safe_stop`), or with the built-in law for the plant
(:func:`fallback_law`) when the run's own law is what failed, and brakes the arm
(:func:`brake`).
"""

from __future__ import annotations

from collections.abc import Generator

import numpy as np

from inkarm.control.laws import Controller, LawContext, Setpoint
from inkarm.core.plant import Plant
from inkarm.errors import RunFault
from inkarm.models.minjerk import minimum_jerk_profile


def safe_stop(plant, law, context, log, ref_row, row, i, state, logged, ref, config, ticks,
              placement, kin, senses_tip,
              travel_mm: float) -> Generator[None, None, tuple[int, bool]]:
    """After a fault: lift the pen by ``hover_mm`` plus its travel along the paper normal from
    where the arm is, over ``stop_s``, and hold there for half as long again (commands may be
    late); logged as a lift, each period's command the law's (``stopping``; a law that fails
    there is replaced by the built-in one for the plant). ``state``: this period's reading,
    not commanded yet (None: read anew), its row already in the log when ``logged``. A fault of
    the plant during the stop ends it, and so does Ctrl-C. Returns the next log row and whether
    Ctrl-C came."""
    if state is None:
        state = plant.read()
    q0 = np.asarray(state.q, dtype=float)
    lift = -(config.hover_mm + travel_mm) / 1000.0 * ref.normal_q[i]
    zero = np.zeros_like(q0)
    try:
        for k in range(1, ticks + ticks // 2 + 1):
            goal = q0 + float(minimum_jerk_profile(k / ticks)) * lift
            if k > 1:
                state = plant.read()
            setpoint = Setpoint(i, goal, zero, zero, goal, False, 0.0, i, 0.0, True)
            try:
                order = law.command(state, setpoint)
            except Exception:  # noqa: BLE001 (a stop must go on: the built-in law takes over)
                law = fallback_law(plant, context)
                order = law.command(state, setpoint)
            plant.command(order)
            if (k > 1 or not logged) and row < len(log.time):
                log.time[row], log.q[row], log.qd[row] = state.time, state.q, state.qd
                log.torque[row] = state.torque if state.torque is not None else np.nan
                log.tip[row] = (state.tip_mm if senses_tip
                                else placement.to_page(kin.fk(state.q)[0]))
                log.force[row] = state.force if state.force is not None else np.nan
                ref_row[row] = i
                row += 1
            yield
    except RunFault:  # the plant faulted again (diverged, a device fault): end the stop
        pass
    except KeyboardInterrupt:
        return row, True
    return row, False


def law_error(error: Exception, time: float) -> RunFault:
    """The fault of a law (or its command) that raised ``error``."""
    return RunFault(f"law_error: the control law raised {type(error).__name__}: {error} at "
                    f"t = {time:.3f} s", watchdog="law_error", time_s=time)


def fallback_law(plant: Plant, context: LawContext) -> Controller:
    """The built-in law that stops the arm when the run's own law cannot: position goals for a
    plant that takes them, else the host's joint PID."""
    from inkarm.control.laws.joint_pid import JointPIDLaw
    from inkarm.control.laws.position_goals import PositionGoals

    law = PositionGoals() if "position" in plant.commands else JointPIDLaw()
    law.start(context)
    return law


def brake(plant) -> None:
    """Hold the arm where it is: the plant's brakes where it has them."""
    brake = getattr(plant, "brake", None)
    if brake is not None:
        brake()


__all__ = ["brake", "fallback_law", "law_error", "safe_stop"]
