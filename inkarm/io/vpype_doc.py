"""vpype documents <-> inkarm drawings, converted once at this seam.

vpype (https://vpype.readthedocs.io) holds a :class:`vpype.Document`: layers keyed by integer
ids >= 1, each a :class:`vpype.LineCollection` of polylines stored as complex arrays
``x + 1j y`` in CSS pixels (96 px per inch), x to the right and y *down* from the page's
top-left corner, and an optional page size ``(width, height)`` in px. inkarm draws in [mm] with
y *up* from the page's lower-left corner (:mod:`inkarm.core.trajectory`), so a vpype point
(x_px, y_px) on a page of height H [mm] is

    x = x_px * 25.4 / 96,    y = H - y_px * 25.4 / 96    [mm].

Layers follow the convention of :mod:`inkarm.io.trace`: ``meta["layers"]`` holds one vpype
layer id (>= 1) per stroke, in stroke order, int64; absent means every stroke is layer 1 (so
it is written only when some stroke is not). Layers are read in increasing id, lines in
their order within a layer. Without a page size the page is the box from (0, 0) to the
drawing's largest x and y (at least 1 px), and ``meta["page_from_content"]`` is True, so that
the document written back has no page size either.

A vpype line has no times: a stroke is timed at a constant ``speed`` [mm/s] along its
arc length, a point that adds no time (a repeated point, a pause of the pen, which a
Trajectory cannot hold, or a step lost to rounding) dropped. Drawing -> Document -> Drawing gives back the positions (to float rounding:
x * 96 / 25.4 * 25.4 / 96), the layers and the page size; the times are those at ``speed``.
vpype is imported only by :func:`drawing_to_document`, inside the function.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError
from inkarm.io.trace import timed_by_length

MM_PER_PX = 25.4 / 96.0
"""Millimetres per CSS pixel, vpype's unit of length (96 px per inch)."""
DEFAULT_SPEED = 50.0
"""Pen speed along a vpype line in [mm/s] (as :data:`inkarm.io.trace.DEFAULT_SPEED`)."""
MIN_PAGE_PX = 1.0
"""Smallest side [px] of a page made from the content of a document without a page size."""


def lines_to_drawing(
    layers: Mapping[int, Iterable[np.ndarray]],
    page_size_px: Sequence[float] | None,
    speed: float = DEFAULT_SPEED,
) -> Drawing:
    """A drawing of vpype lines: ``layers`` maps a layer id to its complex lines [px].

    Args:
        layers: Layer id (>= 1) -> lines, each a 1-D complex array ``x + 1j y`` [px].
        page_size_px: vpype's ``(width, height)`` [px], or None (module docstring).
        speed: Pen speed along every line in [mm/s], which times the strokes.
    """
    if not (isinstance(speed, (int, float)) and not isinstance(speed, bool)
            and np.isfinite(speed) and speed > 0):
        raise InputError(f"vpype lines: speed must be a positive number of mm/s, got {speed!r}",
                         key="speed", value=speed)
    ids, lines = [], []
    for lid in sorted(layers):
        if isinstance(lid, bool) or not isinstance(lid, (int, np.integer)) or lid < 1:
            raise InputError(f"vpype layer id must be an integer >= 1, got {lid!r}",
                             key="layers", value=lid)
        for j, line in enumerate(layers[lid]):
            line = np.asarray(line, dtype=complex).ravel()
            if not np.all(np.isfinite(line)):
                raise InputError(f"vpype layer {lid} line {j}: coordinates must be finite",
                                 key="layers", value=lid)
            if len(line):
                ids.append(int(lid))
                lines.append(line)
    meta: dict = {}
    if page_size_px is None:
        top = max((float(np.max(line.real)) for line in lines), default=MIN_PAGE_PX)
        bottom = max((float(np.max(line.imag)) for line in lines), default=MIN_PAGE_PX)
        page_px = (max(top, MIN_PAGE_PX), max(bottom, MIN_PAGE_PX))
        meta["page_from_content"] = True
    else:
        page_px = (float(page_size_px[0]), float(page_size_px[1]))
    height = page_px[1] * MM_PER_PX
    strokes = [_stroke(line, height, speed) for line in lines]
    if any(lid != 1 for lid in ids):
        meta["layers"] = np.array(ids, dtype=np.int64)
    return Drawing(strokes, page_size=(page_px[0] * MM_PER_PX, height), meta=meta)


def document_to_drawing(document, speed: float = DEFAULT_SPEED,
                        layer_ids: Iterable[int] | None = None) -> Drawing:
    """The lines of a :class:`vpype.Document` (of layers ``layer_ids``, default all) as a
    drawing in [mm], timed at ``speed`` [mm/s] (module docstring)."""
    chosen = document.layers if layer_ids is None else {
        lid: document.layers[lid] for lid in layer_ids
    }
    return lines_to_drawing({lid: lc.lines for lid, lc in chosen.items()},
                            document.page_size, speed)


def _stroke(line: np.ndarray, height: float, speed: float) -> Trajectory:
    """One vpype line [px] as a stroke [mm] timed at ``speed`` [mm/s]."""
    pos = np.column_stack([line.real * MM_PER_PX, height - line.imag * MM_PER_PX])
    t = timed_by_length(pos, speed)
    keep = np.concatenate([[True], np.diff(t) > 0])  # a point that adds no time is a pause
    return Trajectory(t=t[keep], pos=pos[keep])


def drawing_lines(drawing: Drawing) -> dict[int, list[np.ndarray]]:
    """The strokes of ``drawing`` as vpype lines: layer id -> complex arrays [px], layers in
    increasing id, strokes in drawing order within a layer (z of a 3-D drawing dropped); a
    stroke of one sample (a dot) is the line from that point to itself, which vpype keeps."""
    layers = drawing.layer_ids()
    height = drawing.page_size[1]
    out: dict[int, list[np.ndarray]] = {}
    for lid in sorted(set(layers.tolist())):
        out[lid] = []
    for lid, stroke in zip(layers.tolist(), drawing.strokes):
        xy = stroke.pos if stroke.n > 1 else stroke.pos[[0, 0]]  # vpype drops 1-point lines
        out[lid].append(xy[:, 0] / MM_PER_PX + 1j * ((height - xy[:, 1]) / MM_PER_PX))
    return out


def drawing_to_document(drawing: Drawing):
    """A :class:`vpype.Document` of ``drawing``: its layers and, unless the drawing came from
    a document without one (``meta["page_from_content"]``), its page size [px]."""
    import vpype

    document = vpype.Document()
    for lid, lines in drawing_lines(drawing).items():
        document.add(vpype.LineCollection(lines), lid)
    if not drawing.meta.get("page_from_content", False):
        w, h = drawing.page_size
        document.page_size = (w / MM_PER_PX, h / MM_PER_PX)
    return document
