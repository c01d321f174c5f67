"""``vpype ... inkarm-style --style cursive ...``: inkarm's human styling as a vpype command.

A vpype plug-in (entry point group ``vpype.plugins``, ``pip install inkarm[vpype]``): a
global processor that re-draws every line of the chosen layers (``--layer``, default all)
through DPPLA targets tracked by the LQT in one of inkarm's handstyles
(:func:`inkarm.plans.restyle.restyle` with :meth:`RestyleConfig.from_handstyle`), and leaves
each layer's metadata (colour, pen width, name), the other layers and the page size as they
were. Each line stays a line of its layer, in its place.

The pipeline's lines are converted once, at this seam (:mod:`inkarm.io.vpype_doc`: CSS px,
y down -> mm, y up), then resampled every ``--spacing`` along their length (finer on a short
line, so that it gets at least :data:`MIN_TARGETS` targets: a single segment is restyled too)
and reduced to DPPLA targets at ``--compression`` (about (1 - compression) x 2/3 targets a
sample, seed 001 sec. 3): with the defaults, 0.25 mm and 0.8, a target every 1.9 mm. The DP
is the banded one (:func:`inkarm.analysis.dppla.dppla`, ``banded=True``): the m-th target
stays within a band of its place in the uniform segmentation. On a straight run every
segmentation has zero error, and the exact DP's first optimum crowds the targets at the start
and leaves one long last segment, which the LQT then overshoots; with the band the targets
stay spread (measured on 500 random straight lines, cursive at compression 0.6: largest
Hausdorff distance 8.3 -> 0.5 mm) and the DP is faster (6.3 -> 1.1 s). The LQT tracks each
target for the handstyle's ``segment_time`` at dt = 0.01 s (6 to 10 steps a target).

vpype's lines carry no time, and the restyled shape does not depend on the pen's speed (the
LQT is linear in the means and its control cost follows the time per target), so there is
no speed option: the shape scales with the spacing of the targets, which ``--spacing`` and
``--compression`` set. A line of zero length (a dot) is kept as it was.

vpype is imported only here (and by :func:`inkarm.io.vpype_doc.drawing_to_document`):
``import inkarm`` never loads it.
"""

from __future__ import annotations

import click
import numpy as np
import vpype
import vpype_cli

from inkarm.analysis.dppla import segments_for_compression
from inkarm.core.budget import BudgetError
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InkarmError, closest
from inkarm.io.trace import resample_arc_length
from inkarm.io.vpype_doc import MM_PER_PX, document_to_drawing, drawing_lines
from inkarm.plans.handstyles import PRESETS, Handstyle, load_handstyles
from inkarm.plans.restyle import MIN_SAMPLES, MIN_TARGETS, RestyleConfig, restyle

DEFAULT_STYLE = "faithful"
DEFAULT_COMPRESSION = 0.8
"""DPPLA compression rate of the plug-in: a target every 7.5 samples (1.9 mm at 0.25 mm), where
the handstyles show (at 0.6 they are hard to tell from the input)."""
DEFAULT_SPACING = "0.25mm"
"""Sample spacing along a line: inkarm's SVG sampling (50 mm/s at 200 Hz)."""


def min_samples(compression: float) -> int:
    """Fewest samples that the DPPLA at ``compression`` reduces to :data:`MIN_TARGETS`
    targets (and at least :data:`~inkarm.plans.restyle.MIN_SAMPLES`)."""
    w = MIN_SAMPLES
    while segments_for_compression(compression, w, 2) + 1 < MIN_TARGETS:
        w += 1
    return w


def resampled(drawing: Drawing, spacing: float, compression: float) -> Drawing:
    """Every stroke of non-zero length resampled uniformly in arc length, samples at most
    ``spacing`` [mm] apart and at least :func:`min_samples` of them, timed by arc length [mm]
    (the unit of time is immaterial, module docstring); a dot is kept as it is."""
    fewest = min_samples(compression)
    strokes = []
    for stroke in drawing.strokes:
        pos = resample_arc_length(stroke.pos, spacing, fewest)
        length = float(np.linalg.norm(np.diff(stroke.pos, axis=0), axis=1).sum())
        t = None if pos is None else np.linspace(0.0, length, len(pos))  # arc length, not chords
        if t is None or not np.all(np.diff(t) > 0):  # a length within rounding of 0: a dot
            strokes.append(stroke)
        else:
            strokes.append(Trajectory(t=t, pos=pos))
    return Drawing(strokes, page_size=drawing.page_size, meta=drawing.meta)


def restyle_lines(drawing: Drawing, cfg: RestyleConfig, spacing: float) -> Drawing:
    """``drawing`` with every stroke restyled (module docstring), one stroke for one, layers
    kept; a stroke the restyle cannot take (a dot) is the input's own."""
    result = restyle(resampled(drawing, spacing, cfg.compression), cfg).drawing
    dropped = set(result.meta.get("restyle_dropped", ()))
    styled = iter(result.strokes)
    strokes = [drawing.strokes[i] if i in dropped else next(styled)
               for i in range(len(drawing.strokes))]
    meta = {k: v for k, v in drawing.meta.items() if k == "layers"}
    return Drawing(strokes, page_size=drawing.page_size, meta=meta)


def handstyle_named(name: str, styles_file: str | None = None) -> Handstyle:
    """The handstyle ``name`` among the presets and ``styles_file``'s styles; a click error
    naming the valid ones (and the closest) otherwise."""
    styles = dict(PRESETS)
    if styles_file is not None:
        try:
            styles.update(load_handstyles(styles_file))
        except InkarmError as e:
            raise click.BadParameter(str(e), param_hint="'--styles'") from None
    if name not in styles:
        near = closest(name, styles)
        hint = f" Did you mean {near!r}?" if near else ""
        raise click.BadParameter(
            f"unknown handstyle {name!r}; expected one of {', '.join(sorted(styles))}.{hint}",
            param_hint="'--style'")
    return styles[name]


@click.command("inkarm-style")
@click.option("-s", "--style", default=DEFAULT_STYLE, show_default=True,
              help="inkarm handstyle: " + ", ".join(PRESETS) + " (or one of --styles)")
@click.option("--styles", "styles_file", type=click.Path(exists=True, dir_okay=False),
              help="TOML file of more handstyles ([styles.NAME] tables, as inkarm's --styles)")
@click.option("-c", "--compression", type=float, default=DEFAULT_COMPRESSION,
              show_default=True, help="DPPLA compression rate in (0, 1): higher, fewer targets "
              "and a smoother, looser line")
@click.option("--spacing", type=vpype_cli.LengthType(), default=DEFAULT_SPACING,
              show_default=True, help="sample spacing along each line before the DPPLA "
              "(a length: 0.25mm, 0.01in; a bare number is px)")
@click.option("--seed", type=int, default=0, show_default=True,
              help="seed of the handstyle's per-target magnitudes (styles with rho > 0)")
@click.option("-l", "--layer", type=vpype_cli.LayerType(accept_multiple=True), default="all",
              help="target layer(s)")
@vpype_cli.global_processor
def inkarm_style(document: vpype.Document, style: str, styles_file: str | None,
                 compression: float, spacing: float, seed: int, layer) -> vpype.Document:
    """Restyle lines in an inkarm handstyle (DPPLA targets tracked by the LQT)."""
    hand = handstyle_named(style, styles_file)
    if not spacing > 0:
        raise click.BadParameter(f"must be a positive length, got {spacing} px",
                                 param_hint="'--spacing'")
    try:
        cfg = RestyleConfig.from_handstyle(hand, compression=compression,
                                           segment_time=hand.segment_time, seed=seed,
                                           banded=True)
    except InkarmError as e:
        raise click.BadParameter(str(e), param_hint=f"'--{e.key or 'compression'}'") from None
    ids = [lid for lid in vpype_cli.multiple_to_layer_ids(layer, document)
           if len(document.layers[lid])]
    if not ids:
        return document
    drawing = document_to_drawing(document, layer_ids=ids)
    try:
        styled = restyle_lines(drawing, cfg, spacing * MM_PER_PX)
    except BudgetError as e:
        raise click.ClickException(
            f"inkarm-style: {e.message}; fewer targets with a higher --compression or a "
            "larger --spacing, or restyle fewer layers (--layer)") from None
    except InkarmError as e:
        raise click.ClickException(f"inkarm-style: {e}") from None
    for lid, lines in drawing_lines(styled).items():
        document.layers[lid] = document.layers[lid].clone(lines)
    return document


inkarm_style.help_group = "Plugins"
