"""Sweeps: 64 runs on the process pool, interrupted and resumed without re-running a finished
point, table and figures; the same sweep on a local Ray cluster gives the same rows; the
command, failed runs as rows, and its errors."""

from __future__ import annotations

import math
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from inkarm.cli import main
from inkarm.errors import InputError
from inkarm.jobs.scenario import load_scenario
from inkarm.jobs.sweep import TIMING_COLUMNS, run_sweep, write_figures
from inkarm.jobs.sweep.design import grid_design, make_points, parse_axis
from inkarm.jobs.sweep.table import PARTS_DIR, TABLE_FILE, read_results

QUICK = Path(__file__).parents[2] / "scenarios" / "quick_stroke.toml"
KEYS = ("controller.force_n", "controller.force_gain_mm_per_ns")

pytestmark = pytest.mark.sim


def _points():
    axes = [parse_axis(f"{KEYS[0]}=0.6:1.4:8"), parse_axis(f"{KEYS[1]}=20:60:8")]
    return make_points(grid_design(axes), (0,))


def _rows(table) -> list[dict]:
    """Rows without the wall-clock columns, NaN made comparable."""
    rows = []
    for row in sorted(table.to_pylist(), key=lambda r: r["index"]):
        rows.append({k: ("nan" if isinstance(v, float) and math.isnan(v) else v)
                     for k, v in row.items() if k not in TIMING_COLUMNS})
    return rows


class Interrupt:
    """A progress callback that presses Ctrl-C after ``after`` finished runs."""

    def __init__(self, after: int):
        self.after, self.calls = after, 0

    def __call__(self, done: int, total: int, failed: int) -> None:
        self.calls += 1
        if done >= self.after:
            raise KeyboardInterrupt


@pytest.fixture(scope="module")
def pool_sweep(tmp_path_factory):
    """The 64-point sweep on a 2-process pool, interrupted after 20 runs and resumed."""
    out = tmp_path_factory.mktemp("sweep") / "pool"
    scenario, points = load_scenario(QUICK), _points()
    with pytest.raises(KeyboardInterrupt):
        run_sweep(scenario, points, out, workers=2, progress=Interrupt(20))
    first = set(read_results(out).column("point_id").to_pylist())
    resumed = run_sweep(scenario, points, out, workers=2)
    return out, points, first, resumed


@pytest.mark.slow
def test_an_interrupted_sweep_resumes_without_rerunning_finished_points(pool_sweep):
    out, points, first, resumed = pool_sweep
    assert 20 <= len(first) < 64
    assert resumed.skipped == len(first) and resumed.total == 64
    assert not first & set(resumed.ran)
    assert first | set(resumed.ran) == {p.point_id for p in points}
    table = read_results(out)
    assert table.num_rows == 64 and not (out / PARTS_DIR).exists()
    assert table.column("index").to_pylist() == list(range(64))
    columns = set(table.column_names)
    assert {*KEYS, "point_id", "seed", "status", "reason", "tracking_rms_mm", "sim_s",
            "wall_s", "version_mujoco", "version_numpy", "version_inkarm"} <= columns
    rows = table.to_pylist()
    assert all(r["status"] == "ok" for r in rows)
    # the rows are the design's points, in order
    assert [(r[KEYS[0]], r[KEYS[1]]) for r in rows] == [
        (p.params[KEYS[0]], p.params[KEYS[1]]) for p in points]
    # a third run has nothing left to do
    again = run_sweep(load_scenario(QUICK), points, out, workers=2)
    assert again.ran == [] and again.skipped == 64


@pytest.mark.slow
def test_a_sweep_writes_line_figures_a_heat_map_and_the_ink_overlay(pool_sweep):
    out = pool_sweep[0]
    written = {p.name for p in write_figures(out, list(KEYS), ["tracking_rms_mm"])}
    assert written == {f"tracking_rms_mm_vs_{KEYS[0]}.png", f"tracking_rms_mm_vs_{KEYS[1]}.png",
                       "tracking_rms_mm_map.png", "ink_overlay.png"}
    assert all((out / "figures" / name).stat().st_size > 5000 for name in written)


@pytest.mark.slow
def test_the_same_sweep_on_a_local_ray_cluster_gives_identical_rows(pool_sweep, tmp_path):
    ray = pytest.importorskip("ray")
    out, points = pool_sweep[0], pool_sweep[1]
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        summary = run_sweep(load_scenario(QUICK), points, tmp_path / "ray", executor="ray")
    finally:
        ray.shutdown()
    assert len(summary.ran) == 64 and summary.failed == 0
    assert _rows(read_results(tmp_path / "ray")) == _rows(read_results(out))


def test_the_command_runs_a_small_grid_and_keeps_failed_runs_as_rows(tmp_path, capsys):
    out = tmp_path / "sweep"
    args = ["sweep", str(QUICK), "--set", "placement.scale=1,40", "--seeds", "0:2", "--out",
            str(out), "--quiet"]
    assert main([*args, "--workers", "2", "--metric", "tracking_rms_mm"]) == 0
    assert "4 runs: 4 run now (2 failed), 0 finished before" in capsys.readouterr().out
    rows = pq.read_table(out / TABLE_FILE).to_pylist()
    assert [(r["placement.scale"], r["seed"]) for r in rows] == [(1, 0), (1, 1), (40, 0), (40, 1)]
    assert [r["status"] for r in rows] == ["ok", "ok", "failed", "failed"]
    for r in rows[2:]:  # 40 x a 22 mm stroke leaves the sheet: refused by the run, kept as a row
        assert "off the 210 x 297 mm sheet" in r["reason"] and r["tracking_rms_mm"] is None
    assert rows[0]["tracking_rms_mm"] == rows[1]["tracking_rms_mm"] > 0  # no random source
    assert (out / "figures" / "tracking_rms_mm_vs_placement.scale.png").is_file()
    assert (out / "figures" / "ink_overlay.png").is_file()
    # the same command again: everything was finished
    assert main(args) == 0
    assert "0 run now (0 failed), 4 finished before" in capsys.readouterr().out


@pytest.mark.parametrize(("args", "message"), [
    ([], "give at least one axis"),
    (["--set", "controller.forse_n=1"], "did you mean 'force_n'"),
    (["--set", "controller.force_n=1:2:0"], "count n >= 1"),
    (["--set", "seed=1,2"], "--seeds"),
    (["--set", "controller.force_n=1", "--random", "0"], "--random N >= 1"),
    (["--set", "controller.force_n=1", "--workers", "0"], "--workers >= 1"),
    (["--set", "controller.force_n=1", "--seeds", "x"], "--seeds"),
])
def test_command_errors_are_one_line_before_any_run(tmp_path, capsys, args, message):
    out = tmp_path / "sweep"
    assert main(["sweep", str(QUICK), "--out", str(out), *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
    assert not out.exists()


def test_a_folder_of_another_sweep_is_refused(tmp_path):
    scenario = load_scenario(QUICK)
    points = make_points(grid_design([parse_axis("controller.force_n=1.0")]), (0,))
    run_sweep(scenario, points, tmp_path / "s", workers=1)
    other = scenario.with_overrides({"controller.hover_mm": 9.0})
    with pytest.raises(InputError, match="another scenario"):
        run_sweep(other, points, tmp_path / "s", workers=1)


def _plant_table(path: Path, digest: str, ids=("p0", "p1")) -> None:
    import pyarrow as pa
    path.parent.mkdir(parents=True, exist_ok=True)
    rows = [{"point_id": i, "index": k, "seed": 0, "status": "ok", "reason": "",
             "scenario_digest": digest} for k, i in enumerate(ids)]
    pq.write_table(pa.Table.from_pylist(rows), path)


@pytest.mark.parametrize("where", [TABLE_FILE, f"{PARTS_DIR}/p0.parquet"])
def test_a_table_copied_from_a_sweep_of_another_scenario_is_refused_naming_both(
        tmp_path, capsys, where):
    from inkarm.jobs.sweep import scenario_digest
    out = tmp_path / "sweep"
    _plant_table(out / where, "0123456789abcdef")
    before = sorted(p.relative_to(out) for p in out.rglob("*"))
    assert main(["sweep", str(QUICK), "--set", "controller.force_n=1", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "another scenario" in err[0] and "0123456789abcdef" in err[0]
    assert scenario_digest(load_scenario(QUICK)) in err[0] and where.split("/")[-1] in err[0]
    assert sorted(p.relative_to(out) for p in out.rglob("*")) == before  # no sweep.json either


@pytest.mark.parametrize("content", [b"", b"PAR1 garbage", b"not parquet at all\n" * 40])
def test_a_garbage_or_truncated_table_is_refused_naming_it(tmp_path, capsys, content):
    out = tmp_path / "sweep"
    out.mkdir()
    (out / TABLE_FILE).write_bytes(content)
    assert main(["sweep", str(QUICK), "--set", "controller.force_n=1", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and TABLE_FILE in err[0] and "not a table of sweep results" in err[0]


def test_a_truncated_copy_of_a_real_table_is_refused(tmp_path, capsys):
    from inkarm.jobs.sweep import scenario_digest
    out = tmp_path / "sweep"
    _plant_table(out / TABLE_FILE, scenario_digest(load_scenario(QUICK)))
    data = (out / TABLE_FILE).read_bytes()
    (out / TABLE_FILE).write_bytes(data[: len(data) // 2])
    assert main(["sweep", str(QUICK), "--set", "controller.force_n=1", "--out", str(out)]) == 2
    assert "not a table of sweep results" in capsys.readouterr().err


def test_a_table_without_digests_is_refused(tmp_path):
    import pyarrow as pa
    out = tmp_path / "sweep"
    out.mkdir()
    pq.write_table(pa.Table.from_pylist([{"point_id": "p0", "index": 0}]), out / TABLE_FILE)
    points = make_points(grid_design([parse_axis("controller.force_n=1.0")]), (0,))
    with pytest.raises(InputError, match="expected the columns point_id and scenario_digest"):
        run_sweep(load_scenario(QUICK), points, out, workers=1)


def test_a_new_sweep_that_keeps_no_row_leaves_no_trace(tmp_path, monkeypatch):
    """A full disk at the first row (the part file cannot be written): the error propagates
    and the new folder is gone, not left holding a sweep.json that says a sweep is there."""
    import errno

    from inkarm.jobs import sweep

    def full_disk(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(sweep, "write_part", full_disk)
    points = make_points(grid_design([parse_axis("controller.force_n=1.0")]), (0,))
    with pytest.raises(OSError, match="No space left"):
        run_sweep(load_scenario(QUICK), points, tmp_path / "s", workers=1)
    assert not (tmp_path / "s").exists()


def test_the_junit_file_of_a_full_disk_leaves_no_partial(tmp_path, monkeypatch):
    import errno
    import xml.etree.ElementTree as ET

    from inkarm.jobs.regress.report import write_junit

    def full_disk(self, *args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(ET.ElementTree, "write", full_disk)
    (tmp_path / "old.xml").write_text("<old/>")
    with pytest.raises(OSError, match="No space left"):
        write_junit([], tmp_path / "old.xml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.xml"]
    assert (tmp_path / "old.xml").read_text() == "<old/>"
