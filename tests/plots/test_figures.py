"""Every figure function of inkarm.plots: returns a Figure, draws on the axes / figure it is
given, saves with save_figure, and leaves the session's matplotlib backend (and pyplot)
alone. And nothing outside inkarm/plots imports matplotlib or chooses a backend."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
import tomllib
from functools import cache
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]

PLAN = """
title = "test"
cov = 4.0
samples = 2
[model]
segment_time = 0.2
[[strokes]]
targets = [{ mean = [0.0, 0.0] }, { mean = [10.0, 20.0] }, { mean = [20.0, 0.0] }]
[[strokes]]
kind = "human_line"
points = [[30.0, 0.0], [60.0, 0.0]]
human_line = { duration = 0.5 }
"""


def _ellipse():
    from inkarm.core.trajectory import Trajectory

    t = np.arange(0.0, 3.0, 1.0 / 110.0)
    w = 2 * np.pi / 3.0
    return Trajectory(t, np.column_stack([100 + 60 * np.cos(w * t), 100 + 20 * np.sin(w * t)]))


def _run():
    from inkarm.ink.canvas import Canvas

    times = np.arange(0.0, 2.0, 0.01)
    x = 20.0 + 40.0 * np.clip(times, 0.0, 1.0)
    reference = np.column_stack([x, np.full_like(x, 50.0)])
    drawing = times < 1.0
    canvas = Canvas(size_mm=(100.0, 120.0), px_per_mm=4.0)
    for k in np.flatnonzero(drawing):
        canvas.touch(reference[k], 1.0, times[k])
    canvas.lift()
    return {
        "canvas": canvas,
        "times_s": times,
        "reference_mm": reference,
        "tip_mm": reference + [0.0, 0.1],
        "force_n": np.where(drawing, 1.2, 0.0),
        "drawing": drawing,
    }


@cache
def inputs() -> dict:
    from inkarm.analysis.density import analyse
    from inkarm.core.trajectory import Drawing
    from inkarm.io.planfile import parse_plan
    from inkarm.plans.glyphs import make_tag
    from inkarm.plans.realise import realise_plan
    from inkarm.plans.restyle import RestyleConfig, restyle
    from inkarm.plans.text import write_text

    trace = Drawing([_ellipse()])
    tp, text = write_text("ab", "cursive")
    tag = make_tag("graffiti", seed=0, n_glyphs=2)
    return {
        "run": _run(),
        "plan": realise_plan(parse_plan(tomllib.loads(PLAN))),
        "analysis": analyse(_ellipse(), 0.75),
        "trace": trace,
        "restyled": restyle(trace, RestyleConfig(compression=0.9)),
        "text": (tp, text),
        "tag": (tag, tag.realise()),
    }


def figure_calls():
    """(name, call(target) -> Figure, "ax" or "fig"): every figure function of inkarm.plots,
    called on ``target`` (axes or figure to draw on; None for a new figure)."""
    from inkarm.plots.density import plot_density_curvature, plot_power_law
    from inkarm.plots.drawing import plot_ink
    from inkarm.plots.plans import plan_figure
    from inkarm.plots.report import canvas_figure, plot_canvas
    from inkarm.plots.restyle import plot_restyle
    from inkarm.plots.tag import tag_figure
    from inkarm.plots.text import plot_text

    x = inputs()
    return [
        ("plot_canvas", lambda ax: plot_canvas(x["run"]["canvas"], ax), "ax"),
        ("plan_figure", lambda fig: plan_figure(x["plan"], fig=fig), "fig"),
        ("plot_density_curvature", lambda ax: plot_density_curvature(x["analysis"], ax), "ax"),
        ("plot_power_law", lambda ax: plot_power_law(x["analysis"], ax), "ax"),
        ("plot_restyle", lambda ax: plot_restyle(x["trace"], x["restyled"], ax), "ax"),
        ("plot_text", lambda ax: plot_text(*x["text"], ax, title="ab"), "ax"),
        ("tag_figure", lambda fig: tag_figure(*x["tag"], title="t", fig=fig), "fig"),
        ("plot_ink", lambda ax: plot_ink(x["text"][1], ax), "ax"),
        ("canvas_figure", lambda _: canvas_figure(x["run"]["canvas"]), "new"),
    ]


NAMES = [
    "plot_canvas", "plan_figure", "plot_density_curvature", "plot_power_law",
    "plot_restyle", "plot_text", "tag_figure", "plot_ink", "canvas_figure",
]


def _call(name):
    return next((call, kind) for n, call, kind in figure_calls() if n == name)


@pytest.mark.parametrize("name", NAMES)
def test_a_new_figure_is_returned_and_saves(name, tmp_path):
    from matplotlib.figure import Figure

    from inkarm.plots import save_figure

    call, _ = _call(name)
    fig = call(None)
    assert type(fig) is Figure and fig.axes
    path = save_figure(fig, tmp_path / f"{name}.png", dpi=40)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("name", [n for n in NAMES if n != "canvas_figure"])
def test_the_given_axes_or_figure_is_drawn_on(name):
    from matplotlib.figure import Figure

    call, kind = _call(name)
    fig = Figure(figsize=(8, 6))
    if kind == "ax":
        other, ax = fig.subplots(1, 2)
        assert call(ax) is fig
        assert ax.has_data() and not other.has_data()
    else:
        sub = fig.subfigures(1, 2)[1]
        assert call(sub) is fig
        assert sub.axes and all(a.figure is sub for a in fig.axes)


def test_plots_leave_the_backend_and_pyplot_alone(tmp_path):
    """In a fresh interpreter with the backend set to "pdf" first: importing every
    inkarm.plots module, calling every figure function and saving PNGs keeps "pdf" and never
    imports pyplot."""
    script = f"""
import json, pkgutil, importlib, runpy, sys
import matplotlib
matplotlib.use("pdf")
import inkarm.plots
for m in pkgutil.iter_modules(inkarm.plots.__path__):
    importlib.import_module("inkarm.plots." + m.name)
from inkarm.plots import save_figure
helpers = runpy.run_path({str(Path(__file__))!r})
for name, call, kind in helpers["figure_calls"]():
    save_figure(call(None), {str(tmp_path)!r} + "/" + name + ".png", dpi=30)
print(json.dumps({{"backend": matplotlib.get_backend(),
                  "pyplot": "matplotlib.pyplot" in sys.modules}}))
"""
    done = subprocess.run(
        [sys.executable, "-c", script],
        check=False,
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout.strip().splitlines()[-1]) == {"backend": "pdf", "pyplot": False}
    assert len(list(tmp_path.glob("*.png"))) == len(NAMES)


def test_only_inkarm_plots_imports_matplotlib_and_no_module_chooses_a_backend():
    offenders = []
    for path in sorted((ROOT / "inkarm").rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=rel)
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""] if node.level == 0 else []
            elif isinstance(node, ast.Call):
                f = node.func
                if (
                    isinstance(f, ast.Attribute)
                    and f.attr in ("use", "switch_backend")
                    and isinstance(f.value, ast.Name)
                    and f.value.id in ("matplotlib", "mpl", "plt", "pyplot")
                ):
                    offenders.append(f"{rel}:{node.lineno}: {f.value.id}.{f.attr}()")
                continue
            else:
                continue
            if not rel.startswith("inkarm/plots/") and any(
                n == "matplotlib" or n.startswith("matplotlib.") for n in names
            ):
                offenders.append(f"{rel}:{node.lineno}: imports {', '.join(names)}")
            if any(n == "matplotlib.pyplot" for n in names) or (
                isinstance(node, ast.ImportFrom)
                and node.module == "matplotlib"
                and any(a.name == "pyplot" for a in node.names)
            ):
                offenders.append(f"{rel}:{node.lineno}: imports pyplot")
    assert offenders == []
