"""The run's planning: the IK path and the joint reference, once per run (issue 22 part 2).

Run: ``python benchmarks/bench_planning.py [--quick] [--all]``. The executor plans before the
first control period: :func:`inkarm.control.reference.check_reachable` (static IK at points
about 10 mm apart along each stroke) and
:func:`inkarm.control.reference.plan_within_speed_limits` (the pen's phases on the control grid,
the IK path on knots every ``ik_period_s``, a clamped spline through them, the slowly varying
feed-forward terms). The default scenario is planned once to record the two calls' arguments
and drawn once to record its physics; then the two calls are timed on this thread's CPU clock
(``time.thread_time``) in alternating blocks with MuJoCo alone on the same run (its own physics
replayed, the pen pressed as in the run: :mod:`pressed`), and split
into parts by timers around them in one more pass (about a microsecond a timer, a few calls).

With ``--all``, every shipped scenario (``load_scenario()`` and ``scenarios/*.toml``) is planned
too, its run stopped once planned: planning per run and per control period, and a digest of the
planned reference (q, qd, qdd, normal_q, page_mm, phase, stroke, contact_tau, inertia, bias) to
compare before and after a change to the planner that must not change what it plans.
"""

from __future__ import annotations

import argparse
import hashlib
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from blocks import interleave
from pressed import recorded_physics, replay_s

from inkarm.control import executor, reference
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"
FIELDS = ("q", "qd", "qdd", "normal_q", "page_mm", "phase", "stroke", "contact_tau", "inertia",
          "bias")
# Timed parts of planning: (label, the name in inkarm.control.reference that is timed).
PARTS = (("check_reachable: static IK along the strokes", "check_reachable"),
         ("the pen's phases on the control grid (sequence_pen)", "sequence_pen"),
         ("the first IK solve, from the posture (solve_ik)", "solve_ik"),
         ("IK path on the knots (track_path)", "track_path"),
         ("clamped joint spline through the knots", "cubic_spline"))


class _Planned(Exception):
    """Stops a run once its reference is planned."""


def planning_calls(scenario) -> dict:
    """The arguments of the executor's two planning calls for ``scenario`` (its run ends once
    planned)."""
    calls = {}
    check, plan = executor.check_reachable, executor.plan_within_speed_limits

    def check_(*args, **kwargs):
        calls["check"] = (args, kwargs)
        return check(*args, **kwargs)

    def plan_(*args, **kwargs):
        calls["plan"] = (args, kwargs)
        plan(*args, **kwargs)
        raise _Planned

    executor.check_reachable, executor.plan_within_speed_limits = check_, plan_
    try:
        run(scenario)
    except _Planned:
        pass
    finally:
        executor.check_reachable, executor.plan_within_speed_limits = check, plan
    return calls


def planner(calls):
    """A callable that plans again from the recorded ``calls``: the joint reference."""
    (check_args, check_kwargs), (plan_args, plan_kwargs) = calls["check"], calls["plan"]

    def plan():
        reference.check_reachable(*check_args, **check_kwargs)
        return reference.plan_within_speed_limits(*plan_args, **plan_kwargs)[0]
    return plan


def digest(ref) -> str:
    """The first 12 hex digits of the SHA-256 of the reference's arrays (FIELDS)."""
    h = hashlib.sha256()
    for name in FIELDS:
        h.update(np.ascontiguousarray(getattr(ref, name)).tobytes())
    return h.hexdigest()[:12]


def parts_s(plan, passes: int = 5) -> dict[str, float]:
    """Median seconds per run in each of PARTS (thread CPU), over ``passes`` instrumented
    passes."""
    spent: dict[str, list[float]] = {name: [] for _, name in PARTS}
    saved = {name: getattr(reference, name) for _, name in PARTS}

    def timer(name):
        fn = saved[name]

        def timed(*args, **kwargs):
            start = time.thread_time()
            try:
                return fn(*args, **kwargs)
            finally:
                spent[name][-1] += time.thread_time() - start
        return timed

    for name in saved:
        setattr(reference, name, timer(name))
    try:
        for _ in range(passes):
            for times in spent.values():
                times.append(0.0)
            plan()
    finally:
        for name, fn in saved.items():
            setattr(reference, name, fn)
    return {name: statistics.median(times) for name, times in spent.items()}


def default_section(quick: bool) -> list[str]:
    scenario = load_scenario()
    calls = planning_calls(scenario)
    plan = planner(calls)
    ref = plan()
    periods = len(ref)
    physics = recorded_physics(scenario)
    timing = interleave({"planning": plan, "mujoco": lambda: replay_s(physics)},
                        blocks=3 if quick else 9, repeats={"planning": 5, "mujoco": 1},
                        clock=time.thread_time)
    total, mujoco = timing.median("planning"), timing.median("mujoco")
    parts = parts_s(plan)
    lines = [
        "## Planning: the IK path and the joint reference (bench_planning.py)",
        "",
        (f"The default scenario ({periods} control periods), planned again from the executor's "
         "recorded calls (`check_reachable`, `plan_within_speed_limits`), on this thread's CPU "
         "clock in alternating blocks with MuJoCo alone on the same run (its own physics "
         "replayed, the pen pressed: `pressed.py`); the parts from timers in 5 more passes. "
         f"{timing.load_line()}"),
        "",
        "| part | share | per run [ms] | per control period [us] |",
        "|---|---|---|---|",
    ]
    for label, name in PARTS:
        lines.append(f"| {label} | {parts[name] / total:.0%} | {1e3 * parts[name]:.2f} | "
                     f"{1e6 * parts[name] / periods:.2f} |")
    rest = total - sum(parts.values())
    lines += [
        (f"| the rest (kinematics and dynamics at the feed-forward knots 40 ms apart, "
         "whole-run arrays: gradients, interpolation, contact terms) | "
         f"{rest / total:.0%} | {1e3 * rest:.2f} | {1e6 * rest / periods:.2f} |"),
        (f"| **planning, uninstrumented** | 100% | {1e3 * total:.2f} | "
         f"{1e6 * total / periods:.2f} |"),
        (f"| MuJoCo alone, the run's steps | | {1e3 * mujoco:.2f} | "
         f"{1e6 * mujoco / periods:.2f} |"),
        "",
        (f"Planning / MuJoCo alone: {total / mujoco:.2f}, {total / mujoco / 2:.0%} of issue 22's "
         f"budget for the whole executor (2x MuJoCo alone). Reference digest `{digest(ref)}`."),
    ]
    return lines


def all_section() -> list[str]:
    paths = [None] + sorted(SCENARIOS.glob("*.toml"))
    lines = ["", "| scenario | periods | planning [ms] | per period [us] | reference digest |",
             "|---|---|---|---|---|"]
    for path in paths:
        calls = planning_calls(load_scenario(path))
        plan = planner(calls)
        ref = plan()
        seconds = interleave({"planning": plan}, blocks=3, repeats=3,
                             clock=time.thread_time).median("planning")
        name = "default" if path is None else path.stem
        lines.append(f"| {name} | {len(ref)} | {1e3 * seconds:.2f} | "
                     f"{1e6 * seconds / len(ref):.2f} | `{digest(ref)}` |")
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer blocks")
    parser.add_argument("--all", action="store_true", help="every shipped scenario too")
    args = parser.parse_args()
    lines = default_section(args.quick)
    if args.all:
        lines += all_section()
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
