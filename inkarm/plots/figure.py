"""Figures without pyplot: creating, resolving and saving :class:`matplotlib.figure.Figure`.

Every figure function of :mod:`inkarm.plots` draws on a caller's axes (``ax=``) or figure
(``fig=``) when given one, else on a new :class:`~matplotlib.figure.Figure` made here, and
returns the Figure. No function here or in the plotting modules calls ``matplotlib.use`` or
touches pyplot's global state: a notebook user's backend and open figures are left alone,
and the figures made here are freed by the garbage collector like any other object (there is
nothing to close). Saving picks the writer from the file's suffix (Agg for PNG), whatever
the session's backend.
"""

from __future__ import annotations

from pathlib import Path

from matplotlib.figure import Figure

__all__ = ["Figure", "figure_of", "new_axes", "new_figure", "save_figure"]


def new_figure(figsize: tuple[float, float], layout: str | None = "tight") -> Figure:
    """A new Figure of ``figsize`` inches, laid out (``tight`` by default) when drawn."""
    return Figure(figsize=figsize, layout=layout)


def new_axes(ax, figsize: tuple[float, float]):
    """``ax`` itself when given, else the single axes of a new Figure of ``figsize`` inches."""
    if ax is not None:
        return ax
    return new_figure(figsize).add_subplot()


def figure_of(ax) -> Figure:
    """The top-level Figure holding ``ax`` (through any subfigures)."""
    fig = ax.figure
    while getattr(fig, "figure", fig) is not fig:  # a SubFigure's .figure is its parent
        fig = fig.figure
    return fig


def save_figure(fig: Figure, path: str | Path, dpi: float = 150, **savefig) -> Path:
    """Write ``fig`` to ``path`` (the format from the suffix: .png, .svg, .pdf, ...) at ``dpi``
    dots per inch; returns the path. The figure is left as it is (still usable). Written
    whole under a hidden name and renamed: a link planted at ``path`` is replaced, never
    followed, and a failure leaves ``path`` as it was. Other keywords go to
    :meth:`matplotlib.figure.Figure.savefig` (e.g. ``pil_kwargs={"compress_level": 1}``:
    the same pixels, compressed in half the time)."""
    from inkarm.io.outputs import atomic_file

    path = Path(path)
    with atomic_file(path) as partial:
        fig.savefig(partial, dpi=dpi, format=path.suffix.lstrip(".").lower() or None, **savefig)
    return path
