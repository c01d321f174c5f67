"""Start-up: the CPU that `inkarm --help` costs against a bare `python -c "import numpy"`, and
where the CPU of `inkarm draw` of the default goes (drawing, imports, writing, the rest).

Run: ``python benchmarks/bench_startup.py [--quick] [--blocks N] [--repeats N]``. Every case is
a fresh process whose CPU time (user + system) is read from ``resource.getrusage``: what the
process itself burnt, not the wall time another tenant stretches. The cases run in alternating
blocks (:mod:`blocks`); a case's figure is the median of its block medians, with the load
average beside. The children run with bytecode cached (``PYTHONPYCACHEPREFIX`` in a temporary
folder, after one untimed warm-up call), as an installed inkarm runs; this environment's
``PYTHONDONTWRITEBYTECODE`` would make every process compile inkarm anew.

Cases:

- ``inkarm --help`` and the reference ``python -c "import numpy"``;
- ``inkarm draw --quiet --out TMP`` of the default scenario, whole;
- the same steps in one process with its CPU split by ``time.process_time`` around the phases:
  start-up (the interpreter), imports (every module the command loads, imported up front in
  the order it loads them), drawing (:func:`inkarm.jobs.run.run`: planning, the closed loop,
  physics, canvas, metrics), writing (:func:`inkarm.jobs.outputs.write_run`, report.png
  included), the rest (scenario, checks) and the exit (the interpreter's teardown after
  ``gc.freeze()``, as the console command ends: the process's CPU less ``getrusage`` of the
  child just before it ends); MuJoCo imported without OpenGL, as ``inkarm draw`` imports it;
  per run, then medians per phase;
- the floor: a process that imports what drawing needs and draws, writing nothing; and
  ``python -c "import mujoco"`` with OpenGL off and one BLAS thread, as ``inkarm draw``
  imports it (interpreter, NumPy, MuJoCo: what no drawing process avoids). The split and
  the floor import ``inkarm.cli`` first, as the console command does (its BLAS setting); the
  reference ``import numpy`` runs as a user's would, with OpenBLAS's default threads.

Targets (the performance issue): ``inkarm --help`` at most 3x the reference; the drawing at
least half of the CPU of ``inkarm draw``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from blocks import interleave

BIN = Path(sys.executable).parent
HELP_TARGET = 3.0
SHARE_TARGET = 0.5
DRAW_TO_MUJOCO = 4.0  # (the restatement the session 33 note proposes; printed as info)
HEAVY = ("scipy", "matplotlib", "mujoco", "glfw", "PIL", "pyarrow", "ray", "dynamixel_sdk",
         "skimage")  # the libraries whose loading the start-up test watches (and Pillow)

# A child that draws the default as `inkarm draw` does, its CPU split by phase; argv[1]: the
# output folder, argv[2]: a JSON file of the modules to import up front, argv[3]: "write" to
# write the run's files (else nothing is written: the floor).
SPLIT = r"""
import json, resource, sys, time
start = time.process_time()
out, modules, write = sys.argv[1], sys.argv[2], sys.argv[3] == "write"
import importlib
import inkarm.cli  # (as the console command: its one BLAS thread set before NumPy loads)
from inkarm.sim.gl import import_mujoco_without_gl
import_mujoco_without_gl()  # as `inkarm draw` imports MuJoCo: without OpenGL (no glfw)
for name in json.load(open(modules)):
    try:
        importlib.import_module(name)
    except Exception:
        pass
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario
loaded = set(sys.modules)
t1 = time.process_time()
scenario = load_scenario(None)
t2 = time.process_time()
result = run(scenario)
t3 = time.process_time()
late = sorted(set(sys.modules) - loaded)
if write:
    from inkarm.jobs.outputs import write_run
    write_run(result, out)
t4 = time.process_time()
import gc
gc.freeze()  # as the console command ends (inkarm.cli.main): no collection at the exit
usage = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"start-up": start, "imports": t1 - start, "drawing": t3 - t2,
                  "writing": t4 - t3, "total": usage.ru_utime + usage.ru_stime,
                  "late": late}))
"""

# MuJoCo alone, as a drawing process imports it (OpenGL off: no glfw; one BLAS thread).
MUJOCO = ("import os; os.environ['MUJOCO_GL'] = 'disable'; "
          "os.environ.setdefault('OPENBLAS_NUM_THREADS', '1'); import mujoco")

# The modules `inkarm draw` (argv[3] "draw") or a bare drawing (else) has loaded when it
# ends, in the order it loaded them, into the JSON file argv[2].
MODULES = r"""
import json, sys
if sys.argv[3] == "draw":
    from inkarm.cli import main
    assert main(["draw", "--quiet", "--out", sys.argv[1]]) == 0
else:
    from inkarm.jobs.run import run
    from inkarm.jobs.scenario import load_scenario
    from inkarm.sim.gl import import_mujoco_without_gl
    import_mujoco_without_gl()
    run(load_scenario(None))
json.dump(list(sys.modules), open(sys.argv[2], "w"))
"""


def child_env(cache: str) -> dict[str, str]:
    """The environment of the children: bytecode cached under ``cache``."""
    env = dict(os.environ, PYTHONPYCACHEPREFIX=cache)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def cpu_of(command: list[str], env: dict[str, str]) -> tuple[float, str]:
    """User + system CPU [s] of one run of ``command``, and its stdout."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run(command, capture_output=True, text=True, env=env, check=False)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"{command[:3]} failed ({done.returncode}): {done.stderr[-2000:]}")
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), done.stdout


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="3 blocks of 1 call")
    parser.add_argument("--blocks", type=int, default=7)
    parser.add_argument("--repeats", type=int, default=3,
                        help="calls a block of the short cases (the drawing ones: 1)")
    args = parser.parse_args()
    blocks, repeats = (3, 1) if args.quick else (args.blocks, args.repeats)
    with tempfile.TemporaryDirectory(prefix="bench_startup_") as tmp:
        env = child_env(str(Path(tmp) / "pycache"))
        out, py = str(Path(tmp) / "out"), sys.executable
        modules = {which: str(Path(tmp) / f"{which}.json") for which in ("draw", "floor")}
        for which, path in modules.items():  # the first also compiles the bytecode
            cpu_of([py, "-c", MODULES, out, path, which], env)
        phases: dict[str, dict[str, list[float]]] = {"split": {}, "floor": {}}

        def split(which: str, write: bool):  # which: the module list
            def case() -> float:
                seconds, stdout = cpu_of([py, "-c", SPLIT, out, modules[which],
                                          "write" if write else "-"], env)
                measured = {**json.loads(stdout), "process": seconds}
                measured["rest"] = measured["total"] - sum(  # per run: medians do not add up
                    measured[k] for k in ("start-up", "imports", "drawing", "writing"))
                measured["exit"] = seconds - measured["total"]
                for key, value in measured.items():
                    phases["split" if write else "floor"].setdefault(key, []).append(value)
                return seconds
            return case

        cases = {
            "help": lambda: cpu_of([str(BIN / "inkarm"), "--help"], env)[0],
            "numpy": lambda: cpu_of([py, "-c", "import numpy"], env)[0],
            "draw": lambda: cpu_of([str(BIN / "inkarm"), "draw", "--quiet", "--out", out],
                                   env)[0],
            "split": split("draw", True),
            "floor": split("floor", False),
            "mujoco": lambda: cpu_of([py, "-c", MUJOCO], env)[0],
        }
        short = ("help", "numpy", "mujoco")
        result = interleave(cases, blocks=blocks, clock=None,
                            repeats={name: repeats if name in short else 1 for name in cases})
        loaded = set(json.loads(Path(modules["draw"]).read_text()))
    heavy = [name for name in HEAVY if name in loaded]
    scipy = sorted({name for name in loaded if name.count(".") == 1
                    and name.startswith("scipy.") and not name.startswith("scipy._")})
    print(report(result, phases, blocks, repeats) + "\nHeavy libraries `inkarm draw` of the "
          f"default loads: {', '.join(heavy)}; SciPy's subpackages among them: "
          f"{', '.join(scipy) or 'none'}.")
    return 0


def median_ms(values) -> float:
    return 1000 * statistics.median(values)


def report(result, phases, blocks: int, repeats: int) -> str:
    """The markdown section."""
    ms = {name: 1000 * result.median(name) for name in result.times}
    # each list's first entry is interleave's untimed warm-up call
    split = {k: median_ms(v[1:]) for k, v in phases["split"].items() if k != "late"}
    floor = {k: median_ms(v[1:]) for k, v in phases["floor"].items() if k != "late"}
    rest, exit_ = split["rest"], split["exit"]
    late = sorted({m for run in phases["split"].get("late", []) for m in run})
    help_ratio = result.ratio("help", "numpy")
    share = split["drawing"] / split["process"]
    floor_share = floor["drawing"] / floor["process"]
    ideal = floor["drawing"] / (ms["mujoco"] + floor["drawing"])
    verdict = "meets" if help_ratio <= HELP_TARGET else "misses"
    share_verdict = "meets" if share >= SHARE_TARGET else "misses"
    lines = [
        ("## Start-up: `inkarm --help` and `inkarm draw` against bare interpreters "
         "(bench_startup.py)\n"),
        (f"CPU time (user + system) of fresh processes, bytecode cached, {blocks} alternating "
         f"blocks ({repeats} calls a block for the first three, 1 for the drawing ones); "
         f"median of the block medians. {result.load_line()}\n"),
        "| process | CPU [ms] |",
        "|---|---|",
        f"| `inkarm --help` | {ms['help']:.0f} |",
        f"| `python -c \"import numpy\"` (reference) | {ms['numpy']:.0f} |",
        f"| `python -c \"import mujoco\"` (MUJOCO_GL=disable) | {ms['mujoco']:.0f} |",
        f"| `inkarm draw` of the default, whole | {ms['draw']:.0f} |",
        f"| the same steps, split below | {ms['split']:.0f} |",
        f"| the floor: import what drawing needs, draw, write nothing | {ms['floor']:.0f} |",
        "",
        "| phase of `inkarm draw` (one process) | CPU [ms] | share |",
        "|---|---|---|",
    ]
    for name, value in (("start-up (interpreter)", split["start-up"]),
                        ("imports", split["imports"]), ("drawing", split["drawing"]),
                        ("writing (report.png included)", split["writing"]),
                        ("rest (scenario, checks)", rest),
                        ("exit (the interpreter's teardown)", exit_)):
        lines.append(f"| {name} | {value:.0f} | {value / split['process']:.0%} |")
    lines.append(f"| the process | {split['process']:.0f} | 100% |")
    lines += [
        "",
        (f"Target: `inkarm --help` at most {HELP_TARGET:g}x the reference: {help_ratio:.2f}x, "
         f"{verdict} it."),
        (f"Target: the drawing at least {SHARE_TARGET:.0%} of the CPU of `inkarm draw`: "
         f"{share:.0%}, {share_verdict} it. The floor (a process that imports what drawing "
         f"needs and draws) reaches {floor_share:.0%}; a process paying only the interpreter, "
         f"NumPy and MuJoCo before drawing would reach {ideal:.0%}."),
        (f"Info (the share above cannot reach {SHARE_TARGET:.0%} while the drawing costs less "
         f"than importing NumPy and MuJoCo; proposed instead: `inkarm draw` at most "
         f"{DRAW_TO_MUJOCO:g}x `python -c \"import mujoco\"`): "
         f"{result.ratio('draw', 'mujoco'):.2f}x."),
    ]
    if late:
        lines.append(f"Modules the split run still imported while drawing: {', '.join(late)}.")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
