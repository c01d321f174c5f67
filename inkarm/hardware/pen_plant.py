"""What a pen plotter's plant is to the controller, whichever firmware plans its moves (the
GRBL plotter's :class:`~inkarm.hardware.plotter.plant.GrblPlant`, the AxiDraw's
:class:`~inkarm.hardware.axidraw.plant.AxiDrawPlant`): a plant of the
:class:`inkarm.core.plant.Plant` protocol that senses the pen tip only (no force, current or
torque) and takes position and pen commands (the page frame's x, y in [m]; the pen down or up),
one per control period ``dt`` [s]."""

from __future__ import annotations


class PenPlotterPlant:
    """The Plant protocol's fixed part for a pen plotter (module docstring); a plant sets
    ``_dt`` [s]."""

    _dt: float

    @property
    def dt(self) -> float:
        return self._dt

    @property
    def senses(self) -> frozenset[str]:
        return frozenset({"tip"})

    @property
    def commands(self) -> frozenset[str]:
        return frozenset({"position", "pen"})


__all__ = ["PenPlotterPlant"]
