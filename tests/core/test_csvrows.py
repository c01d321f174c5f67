"""The one-go reader of plain CSV traces gives what the row-by-row reader gives, values and
errors, for plain files and odd ones alike (the row reader is the reference)."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.core import csvrows
from inkarm.core.trajectory import Drawing
from inkarm.errors import InputError

PLAIN = {  # files the one-go reader takes
    "lf": b"t,x,y\n0,1,2\n0.01,1.5,2.5\n",
    "crlf": b"t,x,y,stroke\r\n0.0,20.7,276.5,0\r\n0.01,20.71,276.49,0\r\n0.3,1e-05,-0.0,1\r\n",
    "no final newline": b"t,x,y\n0,1,2\n1,2,3",
    "bom, 3-D, capitals": b"\xef\xbb\xbfT, X ,Y,z\n0,1,2,3\n1,+.5,5.,-1E+05\n",
    "blanks in fields": b"t,x,y\n 0 ,\t1,2 \n1,2,3\n",
    "stroke first": b"stroke,t,x,y\n0,0,1,2\n0,1,1,2\n1,2,3,4\n",
    "out of range": b"t,x,y\n0,1,2\n1,2e7,3\n",
    "decreasing": b"t,x,y\n1,1,2\n0,1,2\n",
    "shortest reprs": b"t,x,y\n0.1,0.30000000000000004,5e-324\n1e16,123456789.125,-2.5e-310\n",
}
ODD = {  # files it leaves to the row reader
    "blank line": b"t,x,y\n0,1,2\n\n1,2,3\n",
    "blank row": b"t,x,y\n0,1,2\n , ,\n1,2,3\n",
    "quoted": b't,x,y\n"0",1,2\n',
    "quoted header": b'"t",x,y\n0,1,2\n',
    "underscores": b"t,x,y\n0,1_0,2\n",
    "overflow": b"t,x,y\n0,1e999,2\n",
    "nan": b"t,x,y\n0,nan,2\n",
    "inf": b"t,x,y\n0,1,-Infinity\n",
    "too few fields": b"t,x,y\n0,1\n",
    "trailing comma": b"t,x,y\n0,1,2,\n",
    "not a number": b"t,x,y\n0,1e,2\n",
    "two dots": b"t,x,y\n0,1.2.3,2\n",
    "lone cr": b"t,x,y\r0,1,2\r1,2,3\r",
    "nul": b"t,x,y\n0,1\x00,2\n",
    "latin-1": b"t,x,y\n0,1,2\xe9\n",
    "long line": b"t,x,y\n0,1," + b" " * 4100 + b"2\n",
    "header only": b"t,x,y\n",
    "empty": b"",
    "bad header": b"t,x\n0,1\n",
}


def outcome(path, plain: bool):
    """(strokes as (t, pos) pairs) or the error message of Drawing.from_csv."""
    real = csvrows.read_plain_rows
    try:
        if not plain:
            csvrows.read_plain_rows = lambda path: None
        d = Drawing.from_csv(path)
        return [(s.t.tobytes(), s.pos.tobytes()) for s in d.strokes]
    except InputError as e:
        return str(e)
    finally:
        csvrows.read_plain_rows = real


@pytest.mark.parametrize("name", sorted(PLAIN) + sorted(ODD))
def test_one_go_equals_row_by_row(tmp_path, name):
    path = tmp_path / "trace.csv"
    path.write_bytes({**PLAIN, **ODD}[name])
    assert (csvrows.read_plain_rows(path) is not None) == (name in PLAIN)
    assert outcome(path, plain=True) == outcome(path, plain=False)


def test_the_limits_are_the_row_readers(tmp_path, monkeypatch):
    path = tmp_path / "trace.csv"
    path.write_bytes(b"t,x,y\n0,1,2\n" + b"1,2,3\n" * 5)
    monkeypatch.setenv("INKARM_MAX_STEPS", "4")
    assert csvrows.read_plain_rows(path) is None
    with pytest.raises(InputError, match="INKARM_MAX_STEPS"):
        Drawing.from_csv(path)
    edge = tmp_path / "edge.csv"  # a line of exactly CSV_MAX_LINE characters passes
    edge.write_bytes(b"t,x,y\r\n0,1," + b" " * (csvrows.CSV_MAX_LINE - 6) + b"2\r\n")
    assert csvrows.read_plain_rows(edge) is not None
    assert outcome(edge, plain=True) == outcome(edge, plain=False)


def test_random_files_read_alike(tmp_path):
    rng = np.random.default_rng(7)
    alphabet = list("0123456789") * 3 + list(".+-eE, \t") + ["\n", "\r\n", ",", ",", "1e5"]
    taken = 0
    for k in range(300):
        rows = ["".join(rng.choice(alphabet, rng.integers(3, 12))) for _ in range(3)]
        if k % 2:  # well-formed rows, now and then a blemish
            rows = [",".join(repr(float(v)) for v in rng.normal(size=3) * 10.0 ** rng.integers(-8, 8))
                    for _ in range(3)]
            rows[rng.integers(3)] += rng.choice(["", "", " ", ",", "e", "\n"])
        path = tmp_path / f"r{k}.csv"
        path.write_bytes(("t,x,y\n" + "\n".join(rows) + "\n").encode())
        taken += csvrows.read_plain_rows(path) is not None
        assert outcome(path, plain=True) == outcome(path, plain=False), path.read_bytes()
    assert taken > 50  # the one-go reader did take many of them
