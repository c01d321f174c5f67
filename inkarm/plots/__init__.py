"""Figures (matplotlib): the only part of inkarm that imports matplotlib, when a figure is
made (importing the package does not: :mod:`inkarm.plots.raster` draws without it).

One concept per module, every figure function returning a
:class:`matplotlib.figure.Figure` drawn on the caller's ``ax`` / ``fig`` or on a new one, and
none choosing a backend or using pyplot's global state:

- :mod:`inkarm.plots.plans`: a realised plan file (targets, mean path, samples, speed);
- :mod:`inkarm.plots.report`: a drawing run (ink over plan, tracking error, force, speed);
- :mod:`inkarm.plots.density`: seed 001 sec. 5, density against curvature and the power law;
- :mod:`inkarm.plots.restyle`: a trace, its DPPLA targets and the LQT's re-drawing;
- :mod:`inkarm.plots.text`, :mod:`inkarm.plots.tag`: the ``write`` and ``tag`` figures;
- :mod:`inkarm.plots.drawing`: a drawing as ink, width falling with speed;
- :mod:`inkarm.plots.figure`: new figures and :func:`save_figure`;
- :mod:`inkarm.plots.raster`: charts drawn into pixels with Pillow (the run's ``report.png``).
"""

from inkarm.core.lazy import lazy_names

__getattr__ = lazy_names(__name__, globals(), {"save_figure": "inkarm.plots.figure"})

__all__ = ["save_figure"]
