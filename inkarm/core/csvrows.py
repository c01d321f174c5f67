"""The rows of a CSV trace (``t,x,y[,z][,stroke]``), read for :meth:`Drawing.from_csv
<inkarm.core.trajectory.Drawing.from_csv>`.

A plain file (ASCII, one header line, then rows of numbers with CRLF or LF ends, no blank,
quoted or over-long line) is parsed in one call of :func:`numpy.loadtxt`
(:func:`read_plain_rows`), which converts each field with the function Python's ``float``
uses; anything else goes to the row-by-row reader (:func:`read_csv_rows`), which names the
line at fault. Both give the same values, and the same errors, for every file.
"""

from __future__ import annotations

import csv
from array import array
from pathlib import Path

import numpy as np

from inkarm.errors import InputError

CSV_ROW_BYTES = 256
"""Bytes per CSV row assumed when bounding the rows of a file from its size."""
CSV_MAX_LINE = 4096
"""Longest line of a CSV trace, in characters."""
HEADERS = (["t", "x", "y"], ["t", "x", "y", "z"])
"""The columns of a trace, a ``stroke`` column aside."""

_PLAIN = b"0123456789.+-eE, \t\r\n" + b"txyzstrokeTXYZSTROKE"
"""The bytes of a plain file: those of decimal numbers, commas, blanks, line ends and the
header's names (a field no number can be spelt from these is refused by numpy.loadtxt, as by
float: none of "inf", "nan")."""
_BLOCK = 1 << 22
"""Bytes searched for newlines at once."""

Rows = tuple[list[str], np.ndarray, "list[int] | range"]
"""(header, (rows, columns) values, line number of each row)."""


def read_rows(path: Path, size: int) -> Rows:
    """The rows of the CSV trace ``path`` of ``size`` bytes: the plain file's in one go, any
    other's row by row; rows are counted against ``INKARM_MAX_STEPS``."""
    try:
        plain = read_plain_rows(path)
        if plain is not None:
            return plain
        with open(path, newline="", encoding="utf-8-sig") as f:
            return read_csv_rows(f, path, size)
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a UTF-8 text file; expected CSV t,x,y[,z][,stroke]") from None


def read_plain_rows(path: Path) -> Rows | None:
    """The rows of a plain CSV trace (see the module), or None for any other file: no row, a
    byte (a BOM aside) not in :data:`_PLAIN`, a lone CR, a line over :data:`CSV_MAX_LINE`
    characters, a header other than :data:`HEADERS` (with or without ``stroke``), more rows
    than ``INKARM_MAX_STEPS``, a blank line, a field :func:`numpy.loadtxt` refuses or a
    non-finite value. Row k is on line k + 2."""
    from inkarm.core.budget import STEPS

    data = path.read_bytes().removeprefix(b"\xef\xbb\xbf")
    codes = np.frombuffer(data, dtype=np.uint8)
    ends = np.concatenate([np.flatnonzero(codes[i:i + _BLOCK] == 10) + i
                           for i in range(0, len(codes), _BLOCK)] + [[len(data)]])
    rows = len(ends) - (2 if data.endswith(b"\n") else 1)  # lines, the header aside
    if (rows < 1 or data.translate(None, _PLAIN) or data.count(b"\r") != data.count(b"\r\n")
            or np.diff(ends, prepend=-1).max() - 1 > CSV_MAX_LINE or rows > STEPS.value):
        return None
    header = [h.strip().lower() for h in data[:ends[0]].decode().removesuffix("\r").split(",")]
    del data, codes, ends
    if [h for h in header if h != "stroke"] not in HEADERS:
        return None
    try:
        with open(path, encoding="utf-8-sig") as f:
            arr = np.loadtxt(f, delimiter=",", comments=None, skiprows=1, ndmin=2)
    except ValueError:
        return None
    if arr.shape != (rows, len(header)) or not np.all(np.isfinite(arr)):
        return None  # a line skipped (blank), or a value whose line the row reader names
    return header, arr, range(2, rows + 2)


def csv_lines(f, path: Path, counter: list[int]):
    """The lines of ``f``, each at most :data:`CSV_MAX_LINE` characters; ``counter[0]`` sums
    the characters read."""
    lineno = 0
    while True:
        line = f.readline(CSV_MAX_LINE + 1)
        if not line:
            return
        lineno += 1
        if len(line) > CSV_MAX_LINE and not line.endswith("\n"):
            raise InputError(f"{path}:{lineno}: line longer than {CSV_MAX_LINE} characters; "
                             "expected CSV rows t,x,y[,z][,stroke]")
        counter[0] += len(line)
        yield line


def read_csv_rows(f, path: Path, size: int) -> Rows:
    """The rows of a CSV trace read row by row with the csv module, counting the rows against
    ``INKARM_MAX_STEPS`` as they are read; errors name the line."""
    from inkarm.core.budget import STEPS, require

    counter = [0]
    reader = csv.reader(csv_lines(f, path, counter))
    limit = STEPS.value
    try:
        first = next(reader, None)
        if first is None:
            raise InputError(f"{path}: empty file; expected a header t,x,y[,z][,stroke]")
        header = [h.strip().lower() for h in first]
        if [h for h in header if h != "stroke"] not in HEADERS:
            raise InputError(
                f"{path}: header {','.join(first)[:80]!r}; expected t,x,y or t,x,y,z "
                "(optionally with a stroke column)"
            )
        values, linenos = array("d"), []
        for row in reader:
            lineno = reader.line_num
            if not row or all(not c.strip() for c in row):
                continue
            if len(row) != len(header):
                raise InputError(f"{path}:{lineno}: expected {len(header)} fields, got {len(row)}")
            try:
                values.extend(float(c) for c in row)
            except ValueError:
                raise InputError(f"{path}:{lineno}: non-numeric field in {row}") from None
            linenos.append(lineno)
            if len(linenos) > limit:
                rows = len(linenos) * size / max(counter[0], 1)
                require(rows, STEPS, f"{path}: rows of samples (line {lineno} and more to read)",
                        value=size)
    except csv.Error as e:
        raise InputError(f"{path}:{reader.line_num}: not CSV ({e})") from None
    if not linenos:
        raise InputError(f"{path}: no data rows")
    arr = np.frombuffer(values, dtype=float).reshape(len(linenos), len(header))
    if not np.all(np.isfinite(arr)):
        lineno = linenos[int(np.argwhere(~np.isfinite(arr))[0][0])]
        raise InputError(f"{path}:{lineno}: NaN or inf value")
    return header, arr, linenos
