"""Writing a :class:`inkarm.jobs.run.Run` to a folder."""

from __future__ import annotations

import json
from pathlib import Path

from inkarm.jobs.run import Run

STATUS_FILE = "status.json"


def write_run(run: Run, out_dir: str | Path, report: bool = True) -> dict[str, Path]:
    """Write ``run`` into ``out_dir``: ``reference.csv`` (the placed drawing), ``trace.npz``
    (the log), ``canvas.png`` (the ink), ``status.json`` (status, reason, notes, robot),
    ``metrics.json`` and ``report.png`` (ink over plan, tracking error, force, speed) when the
    run finished. Returns the files written, by name."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    files = {name: out / name for name in ("reference.csv", "trace.npz", "canvas.png",
                                           STATUS_FILE)}
    run.drawing.to_csv(files["reference.csv"])
    if run.log is not None:
        run.log.to_npz(files["trace.npz"])
    else:
        del files["trace.npz"]
    run.canvas.to_png(files["canvas.png"])
    status = {"status": run.status, "reason": run.reason, "notes": list(run.notes),
              "scenario": run.scenario.path, "title": run.scenario.title,
              "robot": run.scenario.robot.name}
    files[STATUS_FILE].write_text(json.dumps(status, indent=2) + "\n")
    if not run.ok:  # a failed run must not keep a good run's figures beside it
        for stale in ("metrics.json", "report.png"):
            (out / stale).unlink(missing_ok=True)
        return files
    files["metrics.json"] = out / "metrics.json"
    files["metrics.json"].write_text(json.dumps(run.metrics, indent=2, sort_keys=True) + "\n")
    if report:
        from inkarm.plots.report import write_report

        log = run.log
        files["report.png"] = write_report(
            out / "report.png", canvas=run.canvas, times_s=log.time, reference_mm=log.reference,
            tip_mm=log.tip, force_n=log.force, drawing=log.drawing,
            plan_strokes=[s.pos[:, :2] for s in run.drawing.strokes], metrics=run.metrics,
            title=run.scenario.title)
    return files
