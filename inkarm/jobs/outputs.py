"""Writing a :class:`inkarm.jobs.run.Run` to a folder, atomically (:mod:`inkarm.io.outputs`)."""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping
from pathlib import Path

from inkarm.io.outputs import staged
from inkarm.jobs.run import Run

STATUS_FILE = "status.json"
RUN_FILES = ("reference.csv", "trace.npz", "canvas.png", "metrics.json", "report.png",
             STATUS_FILE)


def strict_json(value) -> str:
    """``value`` as JSON that strict parsers accept: NaN and infinities become null (an
    undefined metric), never the bare ``NaN`` / ``Infinity`` Python would write. Any mapping
    (e.g. :class:`inkarm.core.run.Metrics`) is written as an object, a dataclass (e.g. a
    :class:`inkarm.core.run.Shortfall`) as the object of its fields."""
    def clean(v):
        if isinstance(v, float) and not math.isfinite(v):
            return None
        if dataclasses.is_dataclass(v) and not isinstance(v, type | Mapping):
            return clean(dataclasses.asdict(v))
        if isinstance(v, Mapping):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, list | tuple):
            return [clean(x) for x in v]
        return v

    return json.dumps(clean(value), indent=2, sort_keys=True, allow_nan=False) + "\n"


def write_run(run: Run, out_dir: str | Path, report: bool = True) -> dict[str, Path]:
    """Write ``run`` into ``out_dir``: ``reference.csv`` (the placed drawing), ``trace.npz``
    (the log, also of a failed or interrupted run), ``canvas.png`` (the ink), ``status.json``
    (status, reason, the shortfalls (bound, measured, limit, sentence) and the bounds not
    judged, notes, robot), and ``metrics.json`` (the metrics, status, reasons and what was
    not judged) and ``report.png`` (ink over plan, tracking error, force, speed) when the run
    finished. The files are staged and moved in together, ``status.json`` last; files of an
    earlier run that this one did not produce are removed. Returns the files written, by
    name."""
    out = Path(out_dir)
    with staged(out, marker=STATUS_FILE, owned=RUN_FILES) as stage:
        run.drawing.to_csv(stage / "reference.csv")
        if run.log is not None:
            run.log.to_npz(stage / "trace.npz")
        run.canvas.to_png(stage / "canvas.png")
        if run.finished:
            verdict = {"status": run.status,
                       "reasons": [str(s) for s in run.shortfalls] if run.shortfalls else
                       [r for r in run.reason.split("; ") if r],
                       "unjudged": list(run.unjudged)}
            (stage / "metrics.json").write_text(strict_json({**run.metrics, **verdict}))
            if report:
                from inkarm.plots.report import write_report

                log = run.log
                write_report(
                    stage / "report.png", canvas=run.canvas, times_s=log.time,
                    reference_mm=log.reference, tip_mm=log.tip, force_n=log.force,
                    drawing=log.drawing, plan_strokes=[s.pos[:, :2] for s in run.drawing.strokes],
                    metrics=run.metrics, title=run.scenario.title if run.ok else
                    f"{run.scenario.title} ({run.status}: {run.reason})")
        status = {"status": run.status, "reason": run.reason,
                  "shortfalls": list(run.shortfalls), "unjudged": list(run.unjudged),
                  "notes": list(run.notes),
                  "scenario": run.scenario.path, "title": run.scenario.title,
                  "robot": run.scenario.robot.name}
        (stage / STATUS_FILE).write_text(strict_json(status))
        names = sorted(p.name for p in stage.iterdir())
    return {name: out / name for name in names}
