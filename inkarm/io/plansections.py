"""The sections of a plan file, read and checked for :mod:`inkarm.io.planfile` (the schema is
documented there): ``[model]``, ``[semi_tied]``, ``[human_line]``/``[minjerk]``, stroke points,
and targets with their covariances. Each reader takes the :class:`TomlReader` of the file, the
raw value and its key, and raises :class:`ScenarioError` naming the file and the key at fault.

Numbers must lie in the ranges where the models' arithmetic is safe, the LQT's
(:mod:`inkarm.models.lqt.config`): coordinates within +-1e6 mm, standard deviations in
[1e-6, 1e6] mm, covariances with variances (eigenvalues) in [1e-12, 1e12] mm^2 and condition
number <= 1e12, dt in [1e-4, 1] s, d in [1e-6, 1e6] mm, r in [1e-40, 1e40], times (segment
and movement durations, via times) up to 3600 s; semi-tied h in [1e-12, 1e12] mm^2, rho up to
1e24 mm^4, H entries within +-1e6; human-line squiggle up to 1e6 px and px_mm in [1e-6, 1] mm.
Each refusal names the key, the range and the value, e.g. ``strokes[0].targets[1].std:
expected numbers in [1e-06, 1e+06] mm, got 1e+300``.
"""

from __future__ import annotations

import math

import numpy as np

from inkarm.core.plan import GaussianTarget, StrokePlan, check_covariance
from inkarm.core.ranges import expected_in, outside
from inkarm.errors import InkarmError, PlanError, ScenarioError
from inkarm.io.toml import TomlReader, describe
from inkarm.models.covariances import MAX_BASIS
from inkarm.models.human_line import MAX_SQUIGGLE_PX, PX_MM_RANGE
from inkarm.models.lqt.config import (
    D_RANGE,
    DT_RANGE,
    MAX_COORDINATE,
    MAX_TIME,
    R_RANGE,
    STD_RANGE,
    VARIANCE_RANGE,
    coordinate_error,
    covariance_error,
)

TARGET_KEYS = ("mean", "cov", "std", "angle")
MODEL_DEFAULTS = {
    "order": 4,
    "dt": 0.01,
    "d": 5.0,
    "r": None,
    "discretisation": "euler",
    "end_at_rest": True,
    "segment_time": 0.5,
    "sampling": "exact",
    "solver": "auto",
}
SEMI_TIED_DEFAULTS = {"H": None, "h": None, "rho": 0.0}
HUMAN_LINE_DEFAULTS = {"squiggle": 5.0, "px_mm": 25.4 / 300.0, "duration": 2.0}
MINJERK_DEFAULTS = {"duration": 1.0, "via_times": None}
MAX_RHO = VARIANCE_RANGE[1] ** 2  # [mm^4]: rho is the variance of h


def in_range(rd: TomlReader, value, key: str, low: float, high: float, unit: str) -> float:
    """A finite number in [low, high], else an error naming the range (``value`` already
    read by ``rd.number`` or ``rd.array`` for its type)."""
    bad = outside(value, low, high)
    if bad is not None:
        what = "numbers" if np.ndim(value) else "a number"
        raise rd.error(key, f"{expected_in(low, high, unit, what)}, got {bad:g}", value=bad)
    return value


def coordinates(rd: TomlReader, arr: np.ndarray, key: str) -> np.ndarray:
    """``arr`` [mm] unless a coordinate is beyond +-MAX_COORDINATE."""
    message = coordinate_error(arr)
    if message:
        raise rd.error(key, message, value=float(outside(arr, -MAX_COORDINATE, MAX_COORDINATE)))
    return arr


def read_model(rd: TomlReader, table: dict, key: str, inherited: dict) -> dict:
    rd.keys(table, tuple(MODEL_DEFAULTS), key)
    out = dict(inherited)
    if "d" in table and "r" in table:
        raise rd.error(key, "give one of d (maximum displacement) and r (control weight), not both")
    if "d" in table:
        d = rd.number(table["d"], f"{key}.d", 0.0, strict=True)
        out["d"], out["r"] = in_range(rd, d, f"{key}.d", *D_RANGE, "mm"), None
    if "r" in table:
        r = rd.number(table["r"], f"{key}.r", 0.0, strict=True)
        out["r"], out["d"] = in_range(rd, r, f"{key}.r", *R_RANGE, "(mm/s^n)^-2"), None
    if "order" in table:
        out["order"] = rd.integer(table["order"], f"{key}.order", 1, 7)
    for name, (low, high) in (("dt", DT_RANGE), ("segment_time", (0.0, MAX_TIME))):
        if name in table:
            value = rd.number(table[name], f"{key}.{name}", 0.0, strict=True)
            out[name] = in_range(rd, value, f"{key}.{name}", low, high, "s")
    if "discretisation" in table:
        out["discretisation"] = rd.choice(
            table["discretisation"], f"{key}.discretisation", ("euler", "zoh")
        )
    if "end_at_rest" in table:
        out["end_at_rest"] = rd.boolean(table["end_at_rest"], f"{key}.end_at_rest")
    if "sampling" in table:
        out["sampling"] = rd.choice(table["sampling"], f"{key}.sampling", ("exact", "eigen"))
    if "solver" in table:
        out["solver"] = rd.choice(
            table["solver"], f"{key}.solver", ("auto", "cholesky", "augmented", "batch")
        )
    if out["segment_time"] < out["dt"]:
        raise rd.error(
            f"{key}.segment_time" if "segment_time" in table else f"{key}.dt",
            f"segment_time ({out['segment_time']:g} s) must be at least dt ({out['dt']:g} s)",
        )
    return out


def read_semi_tied(rd: TomlReader, table: dict, key: str, inherited: dict | None) -> dict:
    rd.keys(table, tuple(SEMI_TIED_DEFAULTS), key)
    out = dict(inherited or SEMI_TIED_DEFAULTS)
    if "H" in table:
        out["H"] = rd.array(table["H"], f"{key}.H", 2)
        h = out["H"]
        if h.ndim != 2 or h.shape[0] != h.shape[1] or h.shape[0] not in (2, 3):
            raise rd.error(f"{key}.H", f"expected a 2 x 2 or 3 x 3 matrix, got shape {h.shape}")
        in_range(rd, h, f"{key}.H", -MAX_BASIS, MAX_BASIS, "")
        if abs(np.linalg.det(h)) <= 1e-12 * max(np.max(np.abs(h)), 1e-300) ** h.shape[0]:
            raise rd.error(f"{key}.H", "the basis is singular (its columns are not independent)")
    if "h" in table:
        h = rd.number(table["h"], f"{key}.h", 0.0, strict=True)
        out["h"] = in_range(rd, h, f"{key}.h", *VARIANCE_RANGE, "mm^2")
    if "rho" in table:
        rho = rd.number(table["rho"], f"{key}.rho", 0.0)
        out["rho"] = in_range(rd, rho, f"{key}.rho", 0.0, MAX_RHO, "mm^4")
    if out["h"] is None:
        raise rd.error(f"{key}.h", "required: the covariance magnitude in mm^2")
    return out


def read_options(rd: TomlReader, kind: str, table: dict, key: str, inherited: dict) -> dict:
    defaults = HUMAN_LINE_DEFAULTS if kind == "human_line" else MINJERK_DEFAULTS
    rd.keys(table, tuple(defaults), key)
    out = dict(inherited)
    if kind == "human_line":
        if "squiggle" in table:
            squiggle = rd.number(table["squiggle"], f"{key}.squiggle", 0.0)
            out["squiggle"] = in_range(rd, squiggle, f"{key}.squiggle", 0.0, MAX_SQUIGGLE_PX, "px")
        if "px_mm" in table:
            px_mm = rd.number(table["px_mm"], f"{key}.px_mm", 0.0, strict=True)
            out["px_mm"] = in_range(rd, px_mm, f"{key}.px_mm", *PX_MM_RANGE, "mm")
    if "duration" in table:
        duration = rd.number(table["duration"], f"{key}.duration", 0.0, strict=True)
        out["duration"] = in_range(rd, duration, f"{key}.duration", 0.0, MAX_TIME, "s")
    if kind == "minjerk" and "via_times" in table:
        via = rd.array(table["via_times"], f"{key}.via_times", 1)
        out["via_times"] = in_range(rd, via, f"{key}.via_times", 0.0, MAX_TIME, "s")
    return out


def _covariance(rd: TomlReader, value, dim: int, key: str) -> np.ndarray:
    if isinstance(value, list) and value and isinstance(value[0], list):
        arr = rd.array(value, key, 2)
    elif isinstance(value, list):
        arr = rd.array(value, key, 1)
    else:
        arr = np.asarray(rd.number(value, key))
    big = outside(arr, -VARIANCE_RANGE[1], VARIANCE_RANGE[1])
    if big is not None:  # before any arithmetic on it
        raise rd.error(key, f"{expected_in(*VARIANCE_RANGE, 'mm^2', 'variances')} (std "
                       f"{STD_RANGE[0]:g} to {STD_RANGE[1]:g} mm), got {big:g}", value=big)
    try:
        cov = check_covariance(arr, dim, f"{rd.source}: {key}")
    except PlanError as e:
        raise ScenarioError(str(e)) from None
    return _in_covariance_range(rd, cov, key)


def _in_covariance_range(rd: TomlReader, cov: np.ndarray, key: str) -> np.ndarray:
    message = covariance_error(cov)
    if message:
        raise rd.error(key, message, value=cov)
    return cov


def _std_covariance(rd: TomlReader, target: dict, dim: int, key: str) -> np.ndarray:
    std_value = target["std"]
    if isinstance(std_value, list):
        std = rd.array(std_value, f"{key}.std", 1)
        if std.shape[0] != dim:
            raise rd.error(f"{key}.std", f"has {std.shape[0]} entries, expected {dim}")
    else:
        std = np.full(dim, rd.number(std_value, f"{key}.std"))
    if np.any(std <= 0):
        raise rd.error(f"{key}.std", f"standard deviations must be positive, got {std.tolist()}")
    in_range(rd, std, f"{key}.std", *STD_RANGE, "mm")
    cov = np.diag(std**2)
    if "angle" in target:
        if dim != 2:
            raise rd.error(f"{key}.angle", "an angle only orients 2-D targets; give cov for 3-D")
        a = math.radians(rd.number(target["angle"], f"{key}.angle"))
        rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        cov = rot @ cov @ rot.T  # seed 000 eq. 8
        cov = 0.5 * (cov + cov.T)
    return _in_covariance_range(rd, cov, f"{key}.std")


def read_points(rd: TomlReader, value, key: str) -> np.ndarray:
    if not isinstance(value, list):
        raise rd.error(key, f"expected an array of points, got {describe(value)}")
    pts = rd.array(value, key, 2)
    if pts.shape[0] < 2:
        raise rd.error(key, f"expected at least 2 points, got {pts.shape[0]}")
    if pts.shape[1] not in (2, 3):
        raise rd.error(key, f"points must have 2 or 3 coordinates, got {pts.shape[1]}")
    return coordinates(rd, pts, key)


def _generated_covariances(
    rd: TomlReader, settings: dict, m: int, dim: int, key: str, seed: np.random.SeedSequence
) -> np.ndarray:
    from inkarm.models.lqt import semi_tied_covariances

    basis = np.eye(dim) if settings["H"] is None else settings["H"]
    if basis.shape[0] != dim:
        raise rd.error(
            f"{key}.H", f"is {basis.shape[0]} x {basis.shape[0]} but the targets are {dim}-D"
        )
    try:
        covs = semi_tied_covariances(
            m, basis, settings["h"], rho=settings["rho"], seed=np.random.default_rng(seed)
        )
    except InkarmError as e:
        raise rd.error(key, str(e)) from None
    for cov in covs:
        _in_covariance_range(rd, cov, key)
    return np.asarray(covs, dtype=float)


def read_targets(
    rd: TomlReader,
    stroke: dict,
    key: str,
    kind: str,
    cov_source: tuple | None,
    seed: np.random.SeedSequence,
    segment_time: float,
) -> StrokePlan:
    """Read ``targets``; cov_source is ("cov", value, key) or ("semi_tied", settings, key) or None."""
    raw = stroke.get("targets")
    if raw is None:
        raise rd.error(f"{key}.targets", f"required for a {kind} stroke")
    if not isinstance(raw, list) or not raw:
        raise rd.error(
            f"{key}.targets", "expected a non-empty array of tables { mean = [...], ... }"
        )
    means, explicit = [], []
    for i, target in enumerate(raw):
        tkey = f"{key}.targets[{i}]"
        target = rd.table(target, tkey)
        rd.keys(target, TARGET_KEYS, tkey)
        if "mean" not in target:
            raise rd.error(f"{tkey}.mean", "required: the target centre in mm")
        mean = rd.array(target["mean"], f"{tkey}.mean", 1)
        if mean.shape[0] not in (2, 3):
            raise rd.error(f"{tkey}.mean", f"expected 2 or 3 coordinates, got {mean.shape[0]}")
        coordinates(rd, mean, f"{tkey}.mean")
        if means and mean.shape[0] != means[0].shape[0]:
            raise rd.error(
                f"{tkey}.mean",
                f"has {mean.shape[0]} coordinates but {key}.targets[0] has {means[0].shape[0]}",
            )
        means.append(mean)
        if "cov" in target and "std" in target:
            raise rd.error(tkey, "give one of cov and std, not both")
        if "angle" in target and "std" not in target:
            raise rd.error(f"{tkey}.angle", "only allowed together with std")
        dim = mean.shape[0]
        if "cov" in target:
            explicit.append(_covariance(rd, target["cov"], dim, f"{tkey}.cov"))
        elif "std" in target:
            explicit.append(_std_covariance(rd, target, dim, tkey))
        else:
            explicit.append(None)
    dim = means[0].shape[0]
    covs = list(explicit)
    missing = [i for i, c in enumerate(covs) if c is None]
    if missing:
        if cov_source is None:
            if kind != "keypoints":
                raise rd.error(
                    f"{key}.targets[{missing[0]}]",
                    "no covariance: give cov or std, or a cov or [semi_tied] for the stroke or the plan",
                )
            fill = [np.eye(dim)] * len(covs)  # GI eq. 7: identity weight at each key-point
        elif cov_source[0] == "cov":
            fill = [_covariance(rd, cov_source[1], dim, cov_source[2])] * len(covs)
        else:
            fill = _generated_covariances(rd, cov_source[1], len(covs), dim, cov_source[2], seed)
        for i in missing:
            covs[i] = fill[i]
    targets = []
    for i, (mean, cov) in enumerate(zip(means, covs)):
        try:
            targets.append(GaussianTarget(mean, cov))
        except PlanError as e:
            raise rd.error(f"{key}.targets[{i}]", str(e)) from None
    return StrokePlan(tuple(targets), segment_time=segment_time, keypoints=kind == "keypoints")
