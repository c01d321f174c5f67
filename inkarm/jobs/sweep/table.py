"""A sweep's results as one Parquet table, written as runs finish and resumable.

Every finished run (ok or not) is written at once as a one-row part file
``parts/<point id>.parquet`` (written beside and renamed into place, so a part is whole or
absent); at the end, or after an interruption, :func:`compact` merges the parts into
``results.parquet`` (one row per run, in design order) and removes them. The finished points
are the ids in ``results.parquet`` and ``parts/``: a resumed sweep skips them. Columns:
``point_id``, ``index``, ``seed``, one column per swept key (its dotted name), ``status``,
``reason``, the metrics, ``sim_s`` and ``wall_s`` [s], and the library versions
(``version_inkarm``, ``version_numpy``, ...).
"""

from __future__ import annotations

from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from inkarm.io.outputs import atomic_file

TABLE_FILE = "results.parquet"
PARTS_DIR = "parts"


def write_part(out_dir: Path, row: dict) -> Path:
    """Write one finished run's ``row`` as ``parts/<point_id>.parquet``, atomically."""
    parts = Path(out_dir) / PARTS_DIR
    parts.mkdir(parents=True, exist_ok=True)
    final = parts / f"{row['point_id']}.parquet"
    with atomic_file(final) as partial:
        pq.write_table(pa.Table.from_pylist([row]), partial)
    return final


def finished_ids(out_dir: Path) -> set[str]:
    """Ids of the points with a row in ``results.parquet`` or a part file."""
    out = Path(out_dir)
    ids = {p.stem for p in (out / PARTS_DIR).glob("*.parquet")}
    table = out / TABLE_FILE
    if table.is_file():
        ids |= set(pq.read_table(table, columns=["point_id"]).column("point_id").to_pylist())
    return ids


def compact(out_dir: Path) -> pa.Table | None:
    """Merge ``results.parquet`` and the part files into ``results.parquet`` (one row per point
    id, the newest kept, sorted by ``index``), then remove the parts. Returns the table, None
    when there is no row."""
    out = Path(out_dir)
    tables = []
    if (out / TABLE_FILE).is_file():
        tables.append(pq.read_table(out / TABLE_FILE))
    parts = sorted((out / PARTS_DIR).glob("*.parquet"))
    tables += [pq.read_table(p) for p in parts]
    if not tables:
        return None
    table = pa.concat_tables(tables, promote_options="permissive")
    rows = {row["point_id"]: row for row in table.to_pylist()}  # later rows win
    ordered = sorted(rows.values(), key=lambda r: r["index"])
    merged = pa.Table.from_pylist(ordered, schema=table.schema)
    with atomic_file(out / TABLE_FILE) as partial:
        pq.write_table(merged, partial)
    for p in parts:
        p.unlink(missing_ok=True)
    if (out / PARTS_DIR).is_dir() and not any((out / PARTS_DIR).iterdir()):
        (out / PARTS_DIR).rmdir()
    return merged


def read_results(out_dir: Path) -> pa.Table:
    """The compacted table of a sweep folder."""
    return pq.read_table(Path(out_dir) / TABLE_FILE)
