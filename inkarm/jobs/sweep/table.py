"""A sweep's results as one Parquet table, written as runs finish and resumable.

Every finished run (ok or not) is written at once as a one-row part file
``parts/<point id>.parquet`` (written beside and renamed into place, so a part is whole or
absent); at the end, or after an interruption, :func:`compact` merges the parts into
``results.parquet`` (one row per run, in design order) and removes them. The finished points
are the ids in ``results.parquet`` and ``parts/``: a resumed sweep skips them. Columns:
``point_id``, ``index``, ``seed``, one column per swept key (its dotted name), ``status``,
``reason``, the metrics, ``sim_s`` and ``wall_s`` [s], the library versions
(``version_inkarm``, ``version_numpy``, ...) and ``scenario_digest``, the digest of the scenario
the row ran (:func:`inkarm.jobs.sweep.scenario_digest`).

A table is trusted only after it is checked: a file that is not a Parquet table of sweep rows,
or a row of another scenario (a ``results.parquet`` copied from another sweep), is refused
naming the file and both digests; its rows are never taken as this sweep's finished points.
"""

from __future__ import annotations

from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from inkarm.errors import InputError
from inkarm.io.outputs import atomic_file

TABLE_FILE = "results.parquet"
PARTS_DIR = "parts"
DIGEST_COLUMN = "scenario_digest"


def _read(path: Path) -> pa.Table:
    """``path`` as a Parquet table, or an InputError naming it (a truncated, garbage or
    foreign file is never a traceback from inside pyarrow)."""
    try:
        return pq.read_table(path)
    except (pa.ArrowException, OSError, ValueError) as e:
        raise InputError(f"{path}: not a table of sweep results ({type(e).__name__}: "
                         f"{str(e).splitlines()[0] if str(e) else 'unreadable'}); remove it "
                         f"or choose another --out", key="--out", value=str(path)) from None


def _check_rows(path: Path, table: pa.Table, digest: str) -> None:
    """Refuse ``table`` (read from ``path``) unless every row ran the scenario of ``digest``."""
    if "point_id" not in table.column_names or DIGEST_COLUMN not in table.column_names:
        raise InputError(f"{path}: not a table of sweep results (expected the columns "
                         f"point_id and {DIGEST_COLUMN}, got {table.column_names[:8]}); remove "
                         f"it or choose another --out", key="--out", value=str(path))
    others = set(table.column(DIGEST_COLUMN).to_pylist()) - {digest}
    if others:
        raise InputError(f"{path} holds rows of another scenario (digest "
                         f"{', '.join(sorted(map(str, others)))}; this scenario's is {digest}): "
                         f"they are not this sweep's results; choose another --out",
                         key="--out", value=str(path))


def write_part(out_dir: Path, row: dict) -> Path:
    """Write one finished run's ``row`` as ``parts/<point_id>.parquet``, atomically."""
    parts = Path(out_dir) / PARTS_DIR
    parts.mkdir(parents=True, exist_ok=True)
    final = parts / f"{row['point_id']}.parquet"
    with atomic_file(final) as partial:
        pq.write_table(pa.Table.from_pylist([row]), partial)
    return final


def finished_ids(out_dir: Path, digest: str) -> set[str]:
    """Ids of the points with a row in ``results.parquet`` or a part file, every one of them
    checked to have run the scenario of ``digest``."""
    out = Path(out_dir)
    ids: set[str] = set()
    for path in [out / TABLE_FILE, *sorted((out / PARTS_DIR).glob("*.parquet"))]:
        if path.is_file():
            table = _read(path)
            _check_rows(path, table, digest)
            ids |= set(table.column("point_id").to_pylist())
    return ids


def compact(out_dir: Path) -> pa.Table | None:
    """Merge ``results.parquet`` and the part files into ``results.parquet`` (one row per point
    id, the newest kept, sorted by ``index``), then remove the parts. Returns the table, None
    when there is no row."""
    out = Path(out_dir)
    tables = []
    if (out / TABLE_FILE).is_file():
        tables.append(_read(out / TABLE_FILE))
    parts = sorted((out / PARTS_DIR).glob("*.parquet"))
    tables += [_read(p) for p in parts]
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
    return _read(Path(out_dir) / TABLE_FILE)
