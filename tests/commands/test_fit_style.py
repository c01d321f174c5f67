"""`inkarm fit-style`, `inkarm restyle --hand/--timing` and the `human` style refused for text."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.cli import main
from inkarm.core.trajectory import Drawing
from inkarm.plans.handstyles import load_handstyles
from tests.plans.test_pulses import zigzag


@pytest.fixture
def recording(tmp_path):
    path = tmp_path / "zigzags.csv"
    Drawing([zigzag()[0], zigzag(durations=(0.25, 0.3, 0.45))[0]]).to_csv(path)
    return path


@pytest.mark.slow
def test_fit_style_writes_a_style_that_restyle_reads(tmp_path, recording, capsys):
    out = tmp_path / "mine.toml"
    still = tmp_path / "still.csv"  # a resting pen: left out, said
    still.write_text("t,x,y\n" + "".join(f"{0.01 * i},5.0,5.0\n" for i in range(40)))
    assert main(["fit-style", str(recording), str(still), "--out", str(out), "--name", "mine",
                 "--held-out", "0.5"]) == 0
    said = capsys.readouterr()
    assert "mine: order" in said.out and "held out: 1/1 strokes keep their speed peaks" in said.out
    assert "1 of 3 strokes left out (too short or not moving" in said.err
    assert "candidate 85/85" in said.err  # progress on stderr
    style = load_handstyles(out)["mine"]
    assert style.timing == "pulses"
    assert main(["restyle", str(recording), "--hand", "mine", "--styles", str(out),
                 "--out", str(tmp_path / "r")]) == 0
    assert "at the speed minima and peaks" in capsys.readouterr().out
    assert (tmp_path / "r" / "zigzags_restyled.csv").is_file()


def test_restyle_with_the_human_style(tmp_path, recording, capsys):
    assert main(["restyle", str(recording), "--hand", "human", "--out", str(tmp_path / "r")]) == 0
    assert "at the speed minima and peaks" in capsys.readouterr().out


@pytest.mark.parametrize(("args", "message"), [
    (["--held-out", "1.5"], "--held-out: expected a fraction in [0, 1), got 1.5"),
    (["--name", "my style"], "--name: expected a name of ASCII letters, digits and _"),
    (["--name", "stylé"], "--name: expected a name of ASCII letters, digits and _"),
])
def test_fit_style_refuses_bad_options_before_work(tmp_path, recording, capsys, args, message):
    assert main(["fit-style", str(recording), "--out", str(tmp_path / "s.toml"), *args]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "s.toml").exists()


def test_the_human_style_is_refused_for_text(tmp_path, capsys):
    assert main(["write", "hi", "--style", "human", "--out", str(tmp_path / "w")]) == 2
    err = capsys.readouterr().err
    assert "handstyle 'human' re-times recordings (timing 'pulses')" in err
    assert "choose one of cursive, faithful" in err


@pytest.mark.parametrize(("args", "message"), [
    (["--hand", "human", "--order", "6"], ("--order: --hand human sets the order, d and "
                                          "covariances; leave out --order")),
    (["--styles", "x.toml"], "--styles: names styles for --hand"),
])
def test_restyle_refuses_options_a_hand_would_ignore(tmp_path, recording, capsys, args, message):
    assert main(["restyle", str(recording), "--out", str(tmp_path / "r"), *args]) == 2
    assert message in capsys.readouterr().err


def test_fit_style_reads_a_tablet_recording(tmp_path, capsys):
    tablet = tmp_path / "pen.csv"
    trace, _ = zigzag()
    tablet.write_text("t,x,y,pressure\n" + "".join(
        f"{1000 * t:.1f},{100 * x:.2f},{100 * y:.2f},0.5\n" for t, (x, y) in zip(trace.t, trace.pos)))
    from inkarm.commands import load_recordings

    class Options:
        time_unit, scale, speed, rate = "ms", 0.01, 40.0, 200.0
    [drawing] = load_recordings(tablet, Options())
    assert drawing.strokes[0].duration == pytest.approx(trace.duration, abs=1e-3)
    assert np.allclose(drawing.strokes[0].pos, trace.pos, atol=0.01)
