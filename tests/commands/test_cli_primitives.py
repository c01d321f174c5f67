"""``inkarm primitives learn|scribble``: files, progress, reproducibility, errors; the robot draws
a scribble (sim)."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.cli import main
from inkarm.core.trajectory import Drawing
from inkarm.models.primitives import PrimitiveModel

SMALL = ["--chains", "3", "--states", "5", "--iterations", "3", "--samples", "6"]


@pytest.fixture(scope="module")
def small_model(tmp_path_factory):
    path = tmp_path_factory.mktemp("model") / "a.npz"
    assert main(["primitives", "learn", "letter:a", "--out", str(path), *SMALL,
                 "--quiet"]) == 0
    return path


def test_learn_from_letters_writes_a_model_and_shows_progress(tmp_path, capsys):
    out = tmp_path / "m.npz"
    assert main(["primitives", "learn", "letter:e", "--out", str(out), *SMALL,
                 "--styles", "cursive,loose"]) == 0
    captured = capsys.readouterr()
    lines = [ln for ln in captured.err.splitlines() if "iteration" in ln]
    assert 1 <= len(lines) <= 3 and lines[0].startswith("restart 1/1 iteration   1: bound")
    assert "6 sequences" in captured.err
    assert "reconstruction error" in captured.out and str(out) in captured.out
    model = PrimitiveModel.load(out)
    assert (model.n_chains, model.n_states, model.channels) == (3, 5, ("dx", "dy", "dp"))
    assert not list(tmp_path.glob(".m.npz*"))  # no staging file left


def test_learn_from_recordings(tmp_path, capsys):
    folder = tmp_path / "recordings"
    folder.mkdir()
    rng = np.random.default_rng(0)
    for k in range(3):
        t = np.arange(60) * 0.004
        xy = np.cumsum(rng.normal(size=(60, 2)) * 0.1, axis=0)
        rows = "\n".join(f"{a},{b},{c},1" for a, (b, c) in zip(t, xy))
        (folder / f"s{k}.csv").write_text("t,x,y,pressure\n" + rows + "\n")
    out = tmp_path / "r.npz"
    assert main(["primitives", "learn", str(folder), "--out", str(out), "--chains", "2",
                 "--states", "4", "--iterations", "2", "--quiet"]) == 0
    assert "3 sequences" in capsys.readouterr().err
    assert PrimitiveModel.load(out).rate_hz == 200.0


def test_scribble_writes_drawing_and_figures_and_is_seeded(small_model, tmp_path, capsys):
    a, b = tmp_path / "a", tmp_path / "b"
    for out in (a, b):
        assert main(["primitives", "scribble", str(small_model), "--seed", "3", "--out",
                     str(out), "--duration", "2"]) == 0
    for name in ("drawing.csv", "drawing.svg", "scribble.png", "primitives.png"):
        assert (a / name).stat().st_size > 0
    assert (a / "drawing.csv").read_text() == (b / "drawing.csv").read_text()
    drawing = Drawing.from_csv(a / "drawing.csv")
    assert len(drawing.strokes) == 1 and drawing.strokes[0].duration == pytest.approx(2.0)
    assert drawing.bounds()[0] == pytest.approx([20.0, 20.0])
    assert "scribble of 2.00 s" in capsys.readouterr().out


@pytest.mark.parametrize(("args", "message"), [
    (["learn", "letter:ab", "--out", "{tmp}/m.npz"], "DATA: expected one letter"),
    (["learn", "{tmp}/none", "--out", "{tmp}/m.npz"], "DATA: no such file or folder"),
    (["learn", "letter:a", "--out", "{tmp}/m.txt"], r"m.txt: expected a model file name \(\.npz\)"),
    (["learn", "letter:a", "--out", "{tmp}"], "is a folder: expected a model file name"),
    (["learn", "letter:a", "--out", "{tmp}/no/m.npz"], "is not a writable folder"),
    (["learn", "letter:a", "--chains", "0", "--out", "{tmp}/m.npz"], "--chains: expected an"),
    (["learn", "letter:a", "--states", "1", "--out", "{tmp}/m.npz"], "--states: expected an"),
    (["learn", "letter:a", "--restarts", "0", "--out", "{tmp}/m.npz"], "--restarts: expected"),
    (["learn", "letter:a", "--samples", "0", "--out", "{tmp}/m.npz"], "--samples: expected"),
    (["learn", "letter:a", "--samples", "100000", "--out", "{tmp}/m.npz"],
     "--samples: stochastic LQT samples of a letter: about 1e\\+05"),
    (["learn", "letter:a", "--styles", "cursiv", "--out", "{tmp}/m.npz"],
     "--styles: unknown handstyle 'cursiv' \\(did you mean 'cursive'\\?\\)"),
    (["learn", "letter:a", "--seed", "-1", "--out", "{tmp}/m.npz"], "--seed: expected"),
    (["scribble", "{tmp}/none.npz", "--out", "{tmp}/s"], "none.npz: no such primitives model file"),
    (["scribble", "{tmp}/bad.npz", "--out", "{tmp}/s"], "bad.npz: not a primitives model"),
    (["scribble", "{model}", "--duration", "-1", "--out", "{tmp}/s"],
     "--duration: expected a positive duration"),
])
def test_errors_are_one_line_and_name_the_input(tmp_path, capsys, small_model, args, message):
    (tmp_path / "bad.npz").write_text("nope")
    argv = ["primitives"] + [a.format(tmp=tmp_path, model=small_model) for a in args]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert __import__("re").search(message, err[0]), err[0]
    assert not (tmp_path / "m.npz").exists() and not (tmp_path / "s").exists()


@pytest.mark.sim
def test_the_simulated_arm_draws_a_scribble(small_model, tmp_path, capsys):
    import json

    job = tmp_path / "scribble.toml"
    job.write_text(f"""seed = 4
[source]
kind = "primitives"
model = "{small_model}"
duration_s = 1.5
[placement]
centre_mm = [105.0, 148.5]
height_mm = 15.0  # (a model learned in seconds jerks near the joint speed limits)
[controller]
go_home = false
[ink]
px_per_mm = 4.0
[judge]  # a model learned in seconds scribbles in jerks: the bounds this test asserts
tracking_rms_mm = 1.0
tracking_max_mm = 3.0
ink_chamfer_mm = 1.0
force_band_n = 0.3
""")
    out = tmp_path / "run"
    assert main(["draw", str(job), "--quiet", "--out", str(out)]) == 0, capsys.readouterr()
    status = json.loads((out / "status.json").read_text())
    metrics = json.loads((out / "metrics.json").read_text())
    assert status["status"] == "ok"
    assert metrics["ink_chamfer_mm"] < 1.0 and metrics["tracking_rms_mm"] < 1.0


def test_scribble_source_errors(tmp_path):
    from inkarm.errors import InputError
    from inkarm.jobs.scenario import load_scenario, source_drawing

    job = tmp_path / "s.toml"
    job.write_text('[source]\nkind = "primitives"\nmodel = "none.npz"\n')
    with pytest.raises(InputError, match="source.model: no such file"):
        load_scenario(job)
    job.write_text('[source]\nkind = "primitives"\nduration_s = 0\n')
    with pytest.raises(InputError, match="source.duration_s"):
        load_scenario(job)
    (tmp_path / "bad.npz").write_text("x")
    job.write_text('[source]\nkind = "primitives"\nmodel = "bad.npz"\n')
    with pytest.raises(InputError, match="bad.npz: source.model: not a primitives model"):
        source_drawing(load_scenario(job))
