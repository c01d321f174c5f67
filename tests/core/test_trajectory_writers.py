"""Drawing.to_csv and Drawing.to_svg write, byte for byte, what the row-by-row writers they
replaced wrote (kept here as the reference)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from inkarm.core.trajectory import Drawing, Trajectory


def reference_csv(d: Drawing, path: Path, stroke_column: bool = True) -> None:
    """The csv.writer loop, one row per sample, of inkarm before issue 22."""
    names = ["t", "x", "y", "z"][: 1 + d.dim]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(names + (["stroke"] if stroke_column else []))
        for k, s in enumerate(d.strokes):
            for ti, p in zip(s.t, s.pos):
                row = [repr(float(ti))] + [repr(float(v)) for v in p]
                w.writerow(row + ([k] if stroke_column else []))


def reference_points(d: Drawing, k: int) -> str:
    """The points attribute of stroke k, one f-string per point, of inkarm before issue 22."""
    h = d.page_size[1]
    return " ".join(f"{x:.3f},{h - y:.3f}" for x, y in d.strokes[k].pos[:, :2])


# values whose text is delicate: shortest repr switching to exponents, negative zero,
# subnormals, ties at the third decimal, sums that are not what they look like
AWKWARD = np.array([0.0, -0.0, 1e-5, 1e-4, 0.0001234, 1e16, 1e15 + 0.5, 123456789.125,
                    0.1 + 0.2, 5e-324, -2.5e-310, 0.0005, 0.0015, 0.0025, -0.0005, 1 / 3,
                    296.9995, 2.675, -1e6, 1e6])


def drawings(dim: int) -> list[Drawing]:
    rng = np.random.default_rng(dim)
    strokes = []
    for n in (1, 2, len(AWKWARD), 300):
        t = np.sort(rng.uniform(-1e3, 1e4, n)) if n > 1 else np.array([0.01])
        pos = rng.normal(scale=100.0, size=(n, dim)) * 10.0 ** rng.integers(-6, 4, (n, dim))
        if n == len(AWKWARD):
            pos = np.column_stack([np.roll(AWKWARD, j) for j in range(dim)])
            t = np.cumsum(np.full(n, 0.01))
        strokes.append(Trajectory(t=t, pos=pos))
    one = Drawing(strokes, page_size=(210.0, 296.5))
    layered = Drawing(strokes, meta={"layers": np.array([2, 1, 2, 3])})
    return [one, layered, Drawing([])]


@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("stroke_column", [True, False])
def test_to_csv_is_byte_identical_to_the_row_writer(tmp_path, dim, stroke_column):
    for i, d in enumerate(drawings(dim)):
        new, old = tmp_path / f"new{i}.csv", tmp_path / f"old{i}.csv"
        d.to_csv(new, stroke_column=stroke_column)
        reference_csv(d, old, stroke_column=stroke_column)
        assert new.read_bytes() == old.read_bytes()


@pytest.mark.parametrize("dim", [2, 3])
def test_to_svg_points_are_byte_identical_to_the_point_writer(tmp_path, dim):
    for d in drawings(dim)[:2]:
        d.to_svg(tmp_path / "d.svg")
        text = (tmp_path / "d.svg").read_text()
        points = [line.split('"')[1] for line in text.splitlines() if line.startswith("<polyline")]
        order = [k for _, ks in d._svg_layers() for k in ks]
        assert points == [reference_points(d, k) for k in order]


def test_a_written_text_reads_back_and_writes_the_same_bytes(tmp_path):
    from inkarm.plans.text import write_text

    d = write_text("hello", "cursive").drawing
    d.to_csv(tmp_path / "new.csv")
    reference_csv(d, tmp_path / "old.csv")
    assert (tmp_path / "new.csv").read_bytes() == (tmp_path / "old.csv").read_bytes()
    back = Drawing.from_csv(tmp_path / "new.csv")
    for b, s in zip(back.strokes, d.strokes, strict=True):
        assert np.array_equal(b.t, s.t) and np.array_equal(b.pos, s.pos)
