"""Drawing-cell benchmarks: the real-time factor of the default scenario on one core, and the
per-tick cost of the planner's inverse kinematics against mink's differential IK.

Run: ``python benchmarks/bench_draw.py [--quick] [--cpu N]``. Prints a markdown section with
two tables:

1. The embedded default scenario (60 mm letter N, marker, A4) drawn by
   :func:`inkarm.control.executor.run_drawing` on :class:`inkarm.sim.plant.MujocoPlant` with the ink
   canvas, pinned to one core (``os.sched_setaffinity``, like ``taskset -c N``). The real-time
   factor is simulated time over the wall time of the whole run, planning included (the
   ``realtime_factor`` of ``metrics.json``): in fresh processes, the first run as ``inkarm
   draw`` prints it, and repeated in one process. Its reference, measured in the same run, is
   MuJoCo alone on the run's own physics (its controls at every physics step replayed from its
   start state, the pen pressed as in the run: :mod:`pressed`), so the ratio is the share of
   the bare simulator's speed the whole run keeps.
   The verdict is on the fastest repeat (on a shared machine other processes only add time),
   with the medians beside it. The quality bounds of the same runs (tracking, ink chamfer,
   force spread) are checked too.
2. Inverse kinematics on the same path and MjModel: the pen-tip reference of the default
   scenario (descents, stroke, lift) at the planner's IK knots (``ik_period_s`` apart), solved
   tick by tick from the same start, both integrating one joint update per tick.
   *inkarm*: :class:`inkarm.control.ik.PathTracker` (damped least squares on the 5-D pen task,
   null-space posture and limit avoidance, iterated to 1 um). *mink*: ``solve_ik`` with the daqp
   QP solver on a ``FrameTask`` at the ``pen_tip`` site (position cost 1, orientation cost
   (1, 1, 0) in the site frame: the spin about the pen axis is free, as in the 5-D task; the
   target orientation is the perpendicular pen of the start pose), a ``PostureTask`` towards the
   same home posture (cost 1e-4, the best of 1e-2 ... 1e-4 for mink's tracking), a
   ``ConfigurationLimit`` and the pen slide frozen by a ``DofFreezingTask`` constraint, then
   ``Configuration.integrate_inplace``. Tracking is compared in tip position and pen-axis tilt
   only (mink's frame task also holds the spin, which the pen task leaves free).
"""

from __future__ import annotations

import argparse
import importlib.metadata
import importlib.util
import os
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass

import mujoco
import numpy as np
from blocks import interleave
from pressed import recorded_physics, replay_s

from inkarm.control.config import LoopConfig
from inkarm.control.ik import IKConfig, PathTracker, solve_ik
from inkarm.control.kinematics import ArmKinematics
from inkarm.control.reference import plan_within_speed_limits
from inkarm.core.log import APPROACH, HOME
from inkarm.core.trajectory import Drawing
from inkarm.jobs.run import run
from inkarm.jobs.scenario import Scenario, load_scenario, place, source_drawing
from inkarm.sim.cell import PEN_SLIDE, PEN_TIP, Cell, build_model, kinematic_model
from inkarm.sim.plant import MujocoPlant

RTF_TARGET = 30.0
IK_RATIO_TARGET = 0.5
QUALITY_BOUNDS = (  # metric key, bound, label
    ("tracking_rms_mm", 0.3, "tracking RMS [mm]"),
    ("tracking_max_mm", 1.0, "tracking max [mm]"),
    ("ink_chamfer_mm", 0.3, "ink chamfer [mm]"),
    ("contact_force_std_n", 0.1, "contact force std [N]"),
)
MINK_POSTURE_COST = 1e-4


@dataclass
class Job:
    """The default scenario, ready to draw."""

    scenario: Scenario
    cell: Cell
    drawing: Drawing
    px_per_mm: float


def pin_one_core(cpu: int | None) -> int | None:
    """Pin this process to ``cpu`` (default: the first core it may run on); the core or None."""
    if not hasattr(os, "sched_setaffinity"):
        return None
    cpu = min(os.sched_getaffinity(0)) if cpu is None else cpu
    os.sched_setaffinity(0, {cpu})
    return cpu


def default_job() -> Job:
    scenario = load_scenario()
    cell = Cell(scenario.cell, scenario.robot)
    drawing = place(source_drawing(scenario), scenario.placement, cell.paper_size_mm)
    return Job(scenario, cell, drawing, scenario.ink.px_per_mm)


def draw_once(job: Job) -> tuple[dict, np.ndarray]:
    """One run of the scenario (:func:`inkarm.jobs.run.run`, as ``inkarm draw`` runs it): its
    metrics (with ``wall_s``, the whole run's wall time) and the logged torques (periods, n)."""
    cpu0, wall0 = time.process_time(), time.perf_counter()
    result = run(job.scenario)
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    log, metrics = result.log, dict(result.metrics)
    metrics["wall_s"] = wall
    metrics["sim_s"] = float(log.time[-1] - log.time[0])
    metrics["cpu_realtime_factor"] = metrics["sim_s"] / cpu
    return metrics, log.torque


def bare_mujoco_s(cell, torques: np.ndarray, substeps: int = 3,
                  clock=time.perf_counter) -> float:
    """Time [s] of MuJoCo alone on ``clock`` (default the wall): the run's torques replayed open
    loop (the pen pressed where the run pressed it), ``substeps`` physics steps per period, on a
    fresh model of ``cell``."""
    model = build_model(cell)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    start = clock()
    for tau in torques:
        data.ctrl[:] = tau
        mujoco.mj_step(model, data, substeps)
    return clock() - start


def fresh_process_rtfs(count: int, cpu: int | None) -> list[float]:
    """The real-time factor of the default in ``count`` fresh processes on core ``cpu``: the
    first run of a process, the number ``inkarm draw`` prints (imports are done before it)."""
    code = ("import os, sys; cpu = int(sys.argv[1]); "
            "cpu >= 0 and os.sched_setaffinity(0, {cpu}); "
            "from inkarm.jobs.run import run; from inkarm.jobs.scenario import load_scenario; "
            "print(run(load_scenario()).metrics['realtime_factor'])")
    return [float(subprocess.run([sys.executable, "-c", code, str(-1 if cpu is None else cpu)],
                                 check=True, capture_output=True, text=True).stdout)
            for _ in range(count)]


def drawing_rows(job: Job, blocks: int, cpu: int | None) -> tuple[list[tuple[str, ...]], str]:
    """The real-time factor rows (and the load sentence): in alternating blocks of the whole run,
    and of MuJoCo alone on the run's own physics; ratios of block medians."""
    fresh = fresh_process_rtfs(3, cpu)
    metrics, _ = draw_once(job)
    sim = metrics["sim_s"]
    runs: list[dict] = []

    def whole_run() -> float:
        runs.append(draw_once(job)[0])
        return runs[-1]["wall_s"]

    physics = recorded_physics(job.scenario)
    timing = interleave({"run": whole_run,
                         "mujoco": lambda: replay_s(physics, clock=time.perf_counter)},
                        blocks=blocks, repeats=3, clock=None)
    bare = sim / timing.median("mujoco")
    rtf_run = sim / timing.median("run")
    rows = [
        (f"`inkarm draw`: first run of a fresh process (median of {len(fresh)})",
         f"{statistics.median(fresh):.1f}", "", "", "info", ""),
        ((f"whole run() in one process (sim {sim:.2f} s / wall {1e3 * timing.median('run'):.0f} "
         f"ms: planning, loop, canvas, metrics)"), f"{rtf_run:.1f}", f"MuJoCo alone {bare:.0f}",
         f"{rtf_run / bare:.2f}", f">= {RTF_TARGET:.0f}", _ok(rtf_run >= RTF_TARGET)),
        ("real-time factor on CPU time of the whole run()",
         f"{statistics.median(m['cpu_realtime_factor'] for m in runs):.1f}", "", "", "info", ""),
    ]
    for key, bound, label in QUALITY_BOUNDS:
        worst = max(m[key] for m in runs)
        rows.append(
            (f"{label}, worst run", f"{worst:.3f}", "", "", f"<= {bound}", _ok(worst <= bound))
        )
    spread = max(timing.spread(name) for name in timing.times)
    return rows, f"{timing.load_line()} Slowest block / fastest block of a case: {spread:.2f}."


def ik_path(
    job: Job,
) -> tuple[ArmKinematics, np.ndarray, np.ndarray, np.ndarray, np.ndarray, float, IKConfig]:
    """The planner's IK problem for the default scenario: kinematics, goals (T, 3) [m] at the
    IK knots, pen axis, start joints, posture, knot spacing [s] and the planner's IK settings."""
    believed = kinematic_model(job.cell)
    kin = ArmKinematics.of(believed)
    placement = believed.placement
    cfg = LoopConfig()
    dt = MujocoPlant(build_model(job.cell), cell=job.cell).dt
    posture = believed.home_q
    ref, _ = plan_within_speed_limits(job.drawing, believed, cfg, posture, dt, kin)
    page = ref.page_mm[(ref.phase != APPROACH) & (ref.phase != HOME)]
    stride = max(1, round(cfg.ik_period_s / dt))
    knots = np.unique(np.append(np.arange(0, len(page), stride), len(page) - 1))
    goals = placement.to_robot(page[knots])
    axis = placement.pen_axis
    q0 = solve_ik(kin, goals[0], axis, posture, posture).q
    h = stride * dt
    ik_cfg = IKConfig(posture_gain=cfg.posture_rate * h, limit_gain=0.5)
    return kin, goals, axis, q0, posture, h, ik_cfg


def tracking(kin: ArmKinematics, path: np.ndarray, goals: np.ndarray, axis: np.ndarray):
    """(RMS [mm], max [mm]) of the tip error and the largest pen tilt [deg] along ``path``."""
    errors, tilts = [], []
    for q, goal in zip(path, goals):
        p, R = kin.fk(q)
        errors.append(1000.0 * np.linalg.norm(p - goal))
        tilts.append(np.degrees(np.arcsin(min(1.0, np.linalg.norm(np.cross(R[:, 2], axis))))))
    errors = np.array(errors)
    return float(np.sqrt(np.mean(errors**2))), float(errors.max()), float(max(tilts))


def run_ours(kin, goals, axis, q0, posture, h, ik_cfg) -> tuple[list[float], np.ndarray]:
    tracker = PathTracker(kin, axis, q0, posture, ik_cfg)
    times, path = [], []
    for goal in goals:
        start = time.perf_counter()
        tracker.step(goal)
        times.append(time.perf_counter() - start)
        path.append(tracker.q.copy())
    return times, np.array(path)


def run_mink(kin, goals, axis, q0, posture, h) -> tuple[list[float], np.ndarray]:
    import mink

    model = kin.model
    slide = model.jnt_dofadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, PEN_SLIDE)]
    q_full = model.qpos0.copy()
    q_full[kin.qpos_adr] = q0
    configuration = mink.Configuration(model)
    configuration.update(q_full)
    frame = mink.FrameTask(PEN_TIP, "site", position_cost=1.0, orientation_cost=[1.0, 1.0, 0.0])
    posture_task = mink.PostureTask(model, cost=MINK_POSTURE_COST)
    target = model.qpos0.copy()
    target[kin.qpos_adr] = posture
    posture_task.set_target(target)
    site = configuration.data.site(PEN_TIP)
    rotation = mink.SO3.from_matrix(site.xmat.reshape(3, 3).copy())
    limits = [mink.ConfigurationLimit(model)]
    frozen = [mink.DofFreezingTask(model, dof_indices=[int(slide)])]
    times, path = [], []
    for goal in goals:
        start = time.perf_counter()
        frame.set_target(mink.SE3.from_rotation_and_translation(rotation, goal))
        velocity = mink.solve_ik(
            configuration, [frame, posture_task], h, "daqp", limits=limits, constraints=frozen
        )
        configuration.integrate_inplace(velocity, h)
        times.append(time.perf_counter() - start)
        path.append(configuration.q[kin.qpos_adr].copy())
    return times, np.array(path)


def ik_rows(job: Job, repeat: int) -> tuple[list[tuple[str, ...]], str]:
    kin, goals, axis, q0, posture, h, ik_cfg = ik_path(job)
    note = f"{len(goals)} ticks {1e3 * h:.0f} ms apart"
    ours = [run_ours(kin, goals, axis, q0, posture, h, ik_cfg) for _ in range(repeat + 1)][1:]
    t_ours = statistics.median(t for times, _ in ours for t in times)
    rms, worst, tilt = tracking(kin, ours[0][1], goals, axis)
    rows = [
        (
            "inkarm PathTracker (DLS, 5-D pen task)",
            f"{1e6 * t_ours:.1f}",
            f"{rms:.4f}",
            f"{worst:.4f}",
            f"{tilt:.4f}",
        )
    ]
    if importlib.util.find_spec("mink") is None:
        rows.append(("mink: not installed (pip install inkarm[compare]), skipped", "", "", "", ""))
        return rows, note
    theirs = [run_mink(kin, goals, axis, q0, posture, h) for _ in range(repeat + 1)][1:]
    t_mink = statistics.median(t for times, _ in theirs for t in times)
    m_rms, m_worst, m_tilt = tracking(kin, theirs[0][1], goals, axis)
    rows.append(
        (
            f"mink {importlib.metadata.version('mink')} solve_ik (daqp)",
            f"{1e6 * t_mink:.1f}",
            f"{m_rms:.4f}",
            f"{m_worst:.4f}",
            f"{m_tilt:.4f}",
        )
    )
    ratio = t_ours / t_mink
    no_worse = rms <= m_rms and worst <= m_worst and tilt <= m_tilt
    rows.append(
        (
            f"ratio inkarm / mink (target <= {IK_RATIO_TARGET}, errors no larger)",
            f"{ratio:.2f} {_ok(ratio <= IK_RATIO_TARGET)}",
            _ok(rms <= m_rms),
            _ok(worst <= m_worst),
            _ok(tilt <= m_tilt),
        )
    )
    return rows, note + ("" if no_worse else "; inkarm's error is larger")


def _ok(passed: bool) -> str:
    return "ok" if passed else "MISSED"


def section(quick: bool, cpu: int | None) -> str:
    core = pin_one_core(cpu)
    job = default_job()
    where = f"one core (cpu {core})" if core is not None else "unpinned"
    lines = [
        "## draw: the drawing cell (real-time factor, inverse kinematics)",
        "",
        (
            f"Default scenario (60 mm letter N, marker, A4 at {job.px_per_mm:g} px/mm), "
            f"{where}. MuJoCo alone replays the run's own physics (its controls at every "
            "physics step from its start state: the pen pressed as in the run, the same final "
            "state bit for bit; `pressed.py`); the ratio is the share of its "
            "speed inkarm keeps (the executor's own share: bench_period.py). The two cases run in "
            "alternating blocks (3 calls a block); real-time factors are simulated time over the "
            "median of the blocks' medians."
        ),
        "",
        "| measure | real-time factor | reference | ratio | target | |",
        "|---|---|---|---|---|---|",
    ]
    rows, load = drawing_rows(job, 3 if quick else 7, core)
    lines += ["| " + " | ".join(r) + " |" for r in rows] + ["", load]
    rows, note = ik_rows(job, 1 if quick else 3)
    lines += [
        "",
        (
            f"Inverse kinematics on the default scenario's path ({note}), same MjModel and "
            "start; tip error against the reference after each tick's joint update."
        ),
        "",
        "| solver | median per tick [us] | tip RMS [mm] | tip max [mm] | max tilt [deg] |",
        "|---|---|---|---|---|",
    ]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repetitions")
    parser.add_argument("--cpu", type=int, default=None, help="core to pin to (default: first)")
    args = parser.parse_args()
    print(section(args.quick, args.cpu))
    return 0


if __name__ == "__main__":
    sys.exit(main())
