"""Training sets for the primitive fHMM: LQT letter samples, pen-recording CSVs, and figures."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.errors import InputError
from inkarm.io.penrecording import read_pen_csv, read_pen_recordings
from inkarm.models.primitives import PrimitivesConfig, fit
from inkarm.models.primitives.features import first_differences
from inkarm.plans.primitives_data import (
    letter_paths,
    letter_training_set,
    recording_training_set,
)


def test_letter_samples_vary_across_styles_and_draws():
    paths, labels = letter_paths("a", 6, styles=("faithful", "loose"), seed=1)
    assert labels == ("faithful #0", "faithful #1", "faithful #2", "loose #0", "loose #1",
                      "loose #2")
    for t, pos, pressure in paths:
        np.testing.assert_allclose(np.diff(t), 1 / 200)
        assert pos.shape == (len(t), 2) and np.all(pressure == 1.0)  # 'a' is one stroke
    assert not np.allclose(paths[0][1], paths[1][1])  # stochastic LQT draws differ
    extent = np.ptp(paths[0][1], axis=0)
    assert 3.0 < extent[1] < 10.0  # x-height of a 10 mm letter


def test_multi_stroke_letters_travel_pen_up():
    (_t, pos, pressure), = letter_paths("i", 1, styles=("faithful",))[0]
    assert pressure[0] == 1.0 and pressure[-1] == 1.0 and 0.0 in pressure
    assert np.max(np.linalg.norm(np.diff(pos, axis=0), axis=1)) < 2.0  # no jumps


def test_letter_training_set_is_normalised_and_seeded():
    a = letter_training_set("e", 8, styles=("cursive", "hurried"), seed=3)
    b = letter_training_set("e", 8, styles=("cursive", "hurried"), seed=3)
    assert len(a.sequences) == 8 and a.channels == ("dx", "dy", "dp")
    np.testing.assert_array_equal(a.sequences[5], b.sequences[5])
    stacked = np.vstack(a.sequences)
    np.testing.assert_allclose(np.sqrt(np.mean(stacked**2, axis=0)), 1.0)
    assert a.scale[0] < 0.2  # mm per 5 ms sample: writing speed below 40 mm/s on average


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"letter": "ab"}, "letter: expected one letter"),
    ({"letter": " "}, "letter: expected one letter"),
    ({"letter": "a", "n_samples": 0}, "n_samples: expected an integer >= 1"),
    ({"letter": "a", "styles": ()}, "styles: expected at least one"),
    ({"letter": "a", "styles": ("cursiv",)}, "did you mean 'cursive'"),
])
def test_letter_errors(kwargs, message):
    with pytest.raises(InputError, match=message):
        letter_paths(**kwargs)


def _csv(path, text):
    path.write_text(text)
    return path


def test_pen_recordings_with_and_without_pressure(tmp_path):
    rows = "\n".join(f"{i * 0.01},{np.sin(i / 5):.4f},{i * 0.1:.2f},{min(i, 5) / 5}"
                     for i in range(30))
    a = _csv(tmp_path / "a.csv", "t,x,y,pressure\n" + rows + "\n")
    b = _csv(tmp_path / "b.csv", "y,t,x\n" + "\n".join(
        f"{i * 0.2},{i * 0.005},{i}" for i in range(40)) + "\n")
    rec = read_pen_csv(a)
    assert rec.pressure is not None and rec.pos.shape == (30, 2)
    rec_b = read_pen_csv(b)
    assert rec_b.pressure is None and rec_b.pos[3].tolist() == [3.0, 0.6000000000000001]
    data = recording_training_set(tmp_path)
    assert [len(s) for s in data.sequences] == [60, 41]  # 0.29 s and 0.195 s at 200 Hz, + 1
    raw = first_differences(rec.t, rec.pos, rec.pressure)
    np.testing.assert_allclose(data.sequences[0] * data.scale, raw)
    assert raw[0, 2] == 0.0 and raw[-1, 2] == -1.0  # the recording starts at pressure 0
    model = fit(data.sequences, PrimitivesConfig(n_chains=2, n_states=4, max_outer=2))
    assert np.all(np.isfinite(model.model.W))


@pytest.mark.parametrize(("text", "message"), [
    ("", "empty file"),
    ("x,y\n1,2\n", "line 1: no column 't'"),
    ("t,x,y,z\n0,0,0,0\n", "line 1: unknown column 'z'"),
    ("t,x,y,x\n0,0,0,0\n", "line 1: a column is repeated"),
    ("t,x,y\n", "no samples after the header"),
    ("t,x,y\n0,0,0\n0.1,1\n", "line 3: 2 values, expected 3"),
    ("t,x,y\n0,0,0\n0.1,abc,1\n", "line 3, column x: not a number: 'abc'"),
    ("t,x,y\n0,0,nan\n", "line 2, column y: nan is outside"),
    ("t,x,y,pressure\n0,0,0,1.5\n", "line 2, column pressure: 1.5 is outside"),
    ("t,x,y\n0,0,0\n0.1,1,1\n0.1,2,2\n", "line 4, column t: 0.1 does not come after 0.1"),
    ("t,x,y\n0,2e6,0\n", "line 2, column x: 2000000.0 is outside"),
])
def test_bad_recordings_name_file_line_and_column(tmp_path, text, message):
    path = _csv(tmp_path / "rec.csv", text)
    with pytest.raises(InputError, match=message) as info:
        read_pen_csv(path)
    assert info.value.file == str(path)


def test_a_recording_too_long_to_resample_is_refused_before_work(tmp_path):
    path = _csv(tmp_path / "long_t.csv", "t,x,y\n0,0,0\n1e9,1,1\n")
    with pytest.raises(InputError, match="long_t.csv: t: samples of a 1e\\+09 s path"):
        recording_training_set(path)


def test_recording_files_and_folders(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        read_pen_csv(tmp_path / "none.csv")
    with pytest.raises(InputError, match="no \\*.csv files in this folder"):
        read_pen_recordings(tmp_path)
    (tmp_path / "bin.csv").write_bytes(b"\xff\xfe\x00t,x")
    with pytest.raises(InputError, match="not a UTF-8 text file"):
        read_pen_csv(tmp_path / "bin.csv")
    long = _csv(tmp_path / "long.csv", "t,x,y\n" + "0" * 5000 + "\n")
    with pytest.raises(InputError, match="line 2: longer than"):
        read_pen_csv(long)


def test_figures():
    from inkarm.models.primitives.generate import scribble
    from inkarm.plots.primitives import plot_primitives, plot_scribble, plot_timing

    data = letter_training_set("a", 4, styles=("cursive",))
    result = fit(data.sequences, PrimitivesConfig(n_chains=3, n_states=6, max_outer=3),
                 scale=data.scale, channels=data.channels)
    S = result.posterior.expectations
    fig = plot_primitives(result.model, S, result.batch.mask)
    assert len(fig.axes) == 9
    n = result.batch.lengths[0]
    fig = plot_timing(result.model, data.sequences[0], S[:, :n, 0])
    assert len(fig.axes) == 2
    path, _ = scribble(result.model, 1.0, seed=1)
    fig = plot_scribble(path)
    assert fig.axes[0].get_xlabel() == "x [mm]"
