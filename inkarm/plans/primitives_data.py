"""Training sets for the motor-primitive fHMM (seed 004 sec. 3) from inkarm's own handwriting
and from users' pen recordings.

:func:`letter_samples`: a letter planned in each handstyle (font glyph -> Gaussian targets,
:mod:`inkarm.plans.text`) and drawn many times by the stochastic LQT (exact draws from its
trajectory distribution, seed 000 eq. 14-15) at 200 Hz, so the samples vary the way the
handstyle's covariances let them, in shape and across styles. A letter with several strokes is
one sequence: the pen travels in a straight line between strokes for ``pen_up_s`` with the
pressure at 0. Pressure: the LQT has none, so inkarm uses the pen-down indicator (1 while
writing).

:func:`recording_samples`: users' CSV recordings (:mod:`inkarm.io.penrecording`), with their
own pressure when they have a column for it, else the pen-down indicator.

Both become normalised first differences of x, y and pressure
(:mod:`inkarm.models.primitives.features`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from inkarm.core.budget import SAMPLES, require
from inkarm.errors import InputError, unknown_name
from inkarm.models.lqt import LQT
from inkarm.models.primitives.features import CHANNELS, RATE_HZ, first_differences, normalise

DEFAULT_STYLES = ("faithful", "cursive", "loose", "italic", "hurried")
DEFAULT_HEIGHT_MM = 10.0


@dataclass(frozen=True, eq=False)
class TrainingSet:
    """Normalised sequences (each (T_n, 3): dx, dy, dp) with what maps them back to the pen.

    Attributes:
        sequences: The fHMM's observations.
        scale: (3,) the RMS each channel was divided by [mm/sample, mm/sample, 1/sample].
        rate_hz: Sample rate [Hz].
        labels: Where each sequence came from (``cursive #3``, a file name).
    """

    sequences: list[np.ndarray]
    scale: np.ndarray
    rate_hz: float
    labels: tuple[str, ...]
    channels: tuple[str, ...] = CHANNELS


def letter_paths(letter: str, n_samples: int = 200, styles: Sequence[str] = DEFAULT_STYLES,
                 seed: int = 0, height_mm: float = DEFAULT_HEIGHT_MM,
                 rate_hz: float = RATE_HZ, pen_up_s: float = 0.1):
    """(list of (t, pos, pressure), labels): ``n_samples`` LQT samples of ``letter``, shared
    out over ``styles`` in turn, at ``rate_hz`` [Hz] (the LQT's time step is 1 / rate_hz)."""
    from inkarm.plans.handstyles import PRESETS, get_handstyle
    from inkarm.plans.text import plan_text

    if not isinstance(letter, str) or len(letter) != 1 or letter.isspace():
        raise InputError(f"expected one letter, got {letter!r}", key="letter", value=letter)
    if isinstance(n_samples, bool) or not isinstance(n_samples, (int, np.integer)) \
            or n_samples < 1:
        raise InputError(f"expected an integer >= 1, got {n_samples!r}", key="n_samples",
                         value=n_samples)
    require(n_samples, SAMPLES, "stochastic LQT samples of a letter", key="n_samples",
            value=n_samples)
    if not styles:
        raise InputError("expected at least one handstyle", key="styles")
    for name in styles:
        if name not in PRESETS:
            raise unknown_name("handstyle", name, PRESETS, key="styles")
    rng = np.random.default_rng(seed)
    counts = [n_samples // len(styles) + (i < n_samples % len(styles))
              for i in range(len(styles))]
    paths, labels = [], []
    dt = 1.0 / rate_hz
    for name, count in zip(styles, counts):
        if count == 0:
            continue
        style = get_handstyle(name)
        plan = plan_text(letter, style, height=height_mm, seed=rng).plan
        cfg = style.lqt_config(dt)
        draws = [LQT(stroke, cfg).sample(count, seed=rng) for stroke in plan.strokes]
        for k in range(count):
            paths.append(_joined([d[k] for d in draws], dt, pen_up_s))
            labels.append(f"{name} #{k}")
    return paths, tuple(labels)


def _joined(strokes: list[np.ndarray], dt: float, pen_up_s: float):
    """One (t, pos, pressure) through the strokes, straight pen-up travel between them."""
    parts, pressure = [strokes[0]], [np.ones(len(strokes[0]))]
    gap = max(round(pen_up_s / dt), 1)
    for stroke in strokes[1:]:
        a, b = parts[-1][-1], stroke[0]
        w = np.arange(1, gap + 1)[:, None] / (gap + 1)
        parts += [a + w * (b - a), stroke]
        pressure += [np.zeros(gap), np.ones(len(stroke))]
    pos = np.vstack(parts)
    return np.arange(len(pos)) * dt, pos, np.concatenate(pressure)


def letter_training_set(letter: str, n_samples: int = 200,
                        styles: Sequence[str] = DEFAULT_STYLES, seed: int = 0,
                        height_mm: float = DEFAULT_HEIGHT_MM,
                        rate_hz: float = RATE_HZ) -> TrainingSet:
    """``n_samples`` LQT samples of ``letter`` as normalised first differences (module doc)."""
    paths, labels = letter_paths(letter, n_samples, styles, seed, height_mm, rate_hz)
    raw = [first_differences(t, pos, p, rate_hz) for t, pos, p in paths]
    sequences, scale = normalise(raw)
    return TrainingSet(sequences, scale, rate_hz, labels)


def recording_training_set(path: str | Path, rate_hz: float = RATE_HZ) -> TrainingSet:
    """A CSV recording or a folder of them (:func:`inkarm.io.penrecording.read_pen_recordings`)
    as normalised first differences at ``rate_hz`` [Hz]."""
    from inkarm.io.penrecording import read_pen_recordings

    recordings = read_pen_recordings(path)
    raw = []
    for rec in recordings:
        try:
            raw.append(first_differences(rec.t, rec.pos, rec.pressure, rate_hz))
        except InputError as e:
            raise e.within(file=str(rec.file)) from None
    sequences, scale = normalise(raw)
    return TrainingSet(sequences, scale, rate_hz, tuple(r.file.name for r in recordings))
