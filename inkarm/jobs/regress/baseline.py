"""Baselines: what a scenario drew when it was last accepted, kept beside the scenario.

A scenario ``scenarios/<name>.toml`` has its baseline in ``scenarios/baselines/<name>/``:

- ``metrics.json``: the run's metrics (:mod:`inkarm.analysis.metrics`), strict JSON;
- ``canvas.png``: the ink, 8-bit grey, as ``inkarm draw`` writes it;
- ``path.npz``: the drawn path, compact: ``tip_mm`` (K, 2) float32, the pen tip in page [mm]
  at every control period, and ``pen_down`` (K,) the rows where a stroke was tracked;
- ``baseline.json``: the status, raster resolution [px/mm] and page size [mm], and the library
  versions (inkarm, numpy, scipy, mujoco, python) it was made with;
- ``tolerances.toml`` (optional, written by hand, kept by ``--update``): tolerances of this
  scenario that replace the defaults of :data:`inkarm.jobs.regress.RULES`, one number per metric
  in the metric's unit, e.g. ``tracking_max_mm = 0.3``.
"""

from __future__ import annotations

import json
import math
import platform
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from inkarm.core.npz import read_npz
from inkarm.errors import InputError
from inkarm.ink.canvas import png_pixels
from inkarm.io.outputs import staged
from inkarm.io.toml import TomlReader, load_toml
from inkarm.jobs.outputs import strict_json
from inkarm.jobs.run import Run

BASELINES_DIR = "baselines"
MARKER = "baseline.json"
BASELINE_FILES = ("metrics.json", "canvas.png", "path.npz", MARKER)
TOLERANCES_FILE = "tolerances.toml"


def library_versions() -> dict[str, str]:
    """Versions of what decides a run's numbers: inkarm, NumPy, SciPy, MuJoCo and Python."""
    import mujoco
    import scipy

    import inkarm

    return {"inkarm": inkarm.__version__, "numpy": np.__version__, "scipy": scipy.__version__,
            "mujoco": mujoco.__version__, "python": platform.python_version()}


def baseline_dir(scenario_path: str | Path, baselines: str | Path | None = None) -> Path:
    """Where the baseline of the scenario file ``scenario_path`` lives: ``<baselines>/<stem>``,
    ``baselines`` defaulting to the ``baselines`` folder beside the scenario."""
    path = Path(scenario_path)
    root = Path(baselines) if baselines is not None else path.parent / BASELINES_DIR
    return root / path.stem


@dataclass(eq=False)
class Baseline:
    """A baseline as read back (see the module docstring)."""

    folder: Path
    status: str
    metrics: dict[str, float | None]
    grey: np.ndarray
    px_per_mm: float
    tip_mm: np.ndarray
    pen_down: np.ndarray
    versions: dict[str, str]
    tolerances: dict[str, float] = field(default_factory=dict)


def page_grey(run: Run) -> np.ndarray:
    """The run's page as the 8-bit grey levels ``canvas.png`` holds (255 white)."""
    return png_pixels(run.canvas.image)


def write_baseline(run: Run, folder: str | Path) -> Path:
    """Write ``run`` (which must have finished ok) as the baseline in ``folder``, atomically;
    a ``tolerances.toml`` there is kept. Returns the folder."""
    if not run.ok:
        raise InputError(f"{run.scenario.path}: the run {run.status}: {run.reason}; a baseline "
                         "is made only from a run that finished ok")
    folder = Path(folder)
    with staged(folder, marker=MARKER, owned=BASELINE_FILES) as stage:
        (stage / "metrics.json").write_text(strict_json(run.metrics))
        run.canvas.to_png(stage / "canvas.png")
        np.savez_compressed(stage / "path.npz", tip_mm=run.log.tip[:, :2].astype(np.float32),
                            pen_down=np.asarray(run.log.drawing, dtype=bool))
        info = {"status": run.status, "title": run.scenario.title,
                "scenario": Path(run.scenario.path).name,
                "px_per_mm": run.canvas.px_per_mm, "page_size_mm": list(run.canvas.size_mm),
                "versions": library_versions()}
        (stage / MARKER).write_text(strict_json(info))
    return folder


def read_baseline(folder: str | Path, known_metrics=()) -> Baseline:
    """Read the baseline in ``folder``; a missing or damaged file is an :class:`InputError`
    naming it. ``known_metrics``: the names ``tolerances.toml`` may set."""
    from PIL import Image

    folder = Path(folder)
    marker = folder / MARKER
    if not marker.is_file():
        raise InputError(f"no baseline in {folder} ({MARKER} missing); make one with "
                         "inkarm regress SCENARIO --update", file=str(folder))
    try:
        info = json.loads(marker.read_text())
        metrics = json.loads((folder / "metrics.json").read_text())
        with Image.open(folder / "canvas.png") as image:
            grey = np.asarray(image.convert("L"))
        path = read_npz(folder / "path.npz", "a baseline's path")
        tip, pen_down = path["tip_mm"].astype(float), path["pen_down"].astype(bool)
        px_per_mm = float(info["px_per_mm"])
    except InputError as e:
        raise InputError(f"damaged baseline in {folder}: {e}; remake it with --update",
                         file=str(folder)) from None
    # what Pillow and json raise on a truncated or garbled file, beside the usual ones
    except (OSError, ValueError, KeyError, TypeError, SyntaxError, EOFError, zlib.error,
            struct.error) as e:
        raise InputError(f"damaged baseline in {folder}: {type(e).__name__}: {e}; remake it "
                         "with --update", file=str(folder)) from None
    _check_metrics(metrics, folder / "metrics.json")
    if not (math.isfinite(px_per_mm) and px_per_mm > 0):
        raise InputError(f"damaged baseline in {folder}: px_per_mm {px_per_mm} in {MARKER} is "
                         f"not a positive number; remake it with --update", file=str(folder))
    versions = info.get("versions", {})
    status = info.get("status", "ok")
    if not (isinstance(versions, dict) and all(isinstance(v, str) for v in versions.values())) \
            or not isinstance(status, str):
        raise InputError(f"damaged baseline in {folder}: {MARKER} must hold a status (text) and "
                         "versions (a table of texts); remake it with --update",
                         file=str(folder))
    return Baseline(folder, status, metrics, grey, px_per_mm, tip, pen_down, dict(versions),
                    read_tolerances(folder / TOLERANCES_FILE, known_metrics))


# Every finished run measures these: a baseline without them compares nothing.
REQUIRED_METRICS = ("tracking_rms_mm", "tracking_max_mm", "ink_chamfer_mm", "gap_mm",
                    "contact_force_mean_n", "contact_force_std_n", "joint_limit_margin_rad")
"""Every baseline records these (null where its backend could not sense one): one that lacks
a key was edited or damaged, and a metric it lacks would pass unchecked. (The force band's
ends, ``force_p1_n`` and ``force_p99_n``, came later: a baseline made before may lack them.)"""


def _check_metrics(metrics, path: Path) -> None:
    """Refuse a baseline's metrics that cannot be trusted to compare with: not a table of
    names to numbers, a number that is not finite (an undefined metric is written as null),
    or a metric every finished run measures missing; each refusal names the file and the
    metric."""
    fix = "; remake it with inkarm regress SCENARIO --update"
    if not isinstance(metrics, dict):
        raise InputError(f"expected a table of metric names to numbers, got "
                         f"{type(metrics).__name__}{fix}", file=str(path))
    for name, value in metrics.items():
        if value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, int | float) or \
                not math.isfinite(value):
            raise InputError(f"metric {name!r} is {value!r}: expected a finite number (or null "
                             f"for an undefined one){fix}", file=str(path), key=name,
                             value=value)
    missing = [name for name in REQUIRED_METRICS if name not in metrics]
    if missing:
        raise InputError(f"no {', '.join(missing)}: every baseline records "
                         f"{'them' if len(missing) > 1 else 'it'} (null where not sensed), so "
                         f"{'they' if len(missing) > 1 else 'it'} would pass unchecked{fix}",
                         file=str(path))


def read_tolerances(path: Path, known_metrics=()) -> dict[str, float]:
    """The per-scenario tolerances in ``path`` (metric name -> number >= 0 in the metric's
    unit); {} when there is no such file."""
    if not path.is_file():
        return {}
    data = load_toml(path, "tolerances file")
    rd = TomlReader(str(path))
    if known_metrics:
        rd.keys(data, tuple(known_metrics), "")
    return {name: rd.number(value, name, 0.0) for name, value in data.items()}
