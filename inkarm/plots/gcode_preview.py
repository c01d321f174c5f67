"""A G-code job as the emulator's planner runs it (``inkarm preview``): the pen-down moves
coloured by their planned speed, the travel thin and dashed, the machine's travel rectangle,
and the speed against time with the total time in the title."""

from __future__ import annotations

import numpy as np

from inkarm.plots.figure import Figure, new_figure

SPEED_MAP = "viridis"


def preview_figure(t: np.ndarray, xyz: np.ndarray, speed: np.ndarray, drawing: np.ndarray,
                   travel_mm: tuple[float, float], seconds: float, title: str = "",
                   ax=None) -> Figure:
    """Plan view and speed profile of a planned job.

    Args:
        t: Sample times [s]; xyz: positions [mm] (n, 3); speed: [mm/s] (n,); drawing: pen
            down at each sample (n,).
        travel_mm: The machine's X and Y travel [mm], drawn as a rectangle from 0.
        seconds: The job's total time [s] (the planner's).
        title: Put before the total time (e.g. the file's name).
        ax: Two axes (plan, speed) to draw on; else a new figure.
    """
    from matplotlib.collections import LineCollection
    from matplotlib.colors import Normalize
    from matplotlib.patches import Rectangle

    if ax is None:
        fig = new_figure((13.0, 6.0))
        plan, profile = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.1, 1.0]})
    else:
        plan, profile = ax
        fig = plan.figure
    t, xyz, speed = np.asarray(t), np.asarray(xyz), np.asarray(speed)
    drawing = np.asarray(drawing, dtype=bool)
    top = float(speed[drawing].max()) if drawing.any() else float(speed.max(initial=1.0))
    norm = Normalize(0.0, max(top, 1e-6))
    segments = np.stack([xyz[:-1, :2], xyz[1:, :2]], axis=1)
    pen = drawing[1:] & drawing[:-1]
    moving = np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1) > 0
    down = LineCollection(segments[pen & moving], cmap=SPEED_MAP, norm=norm, linewidths=1.2)
    down.set_array(speed[1:][pen & moving])
    plan.add_collection(down)
    plan.add_collection(LineCollection(segments[~pen & moving], colors="0.55",
                                       linewidths=0.5, linestyles="--"))
    plan.add_patch(Rectangle((0, 0), travel_mm[0], travel_mm[1], fill=False, edgecolor="k",
                             linewidth=1.0, label=f"travel {travel_mm[0]:g} x "
                             f"{travel_mm[1]:g} mm"))
    lo = np.minimum(xyz[:, :2].min(axis=0), 0.0)
    hi = np.maximum(xyz[:, :2].max(axis=0), travel_mm)
    pad = 0.03 * float(np.max(hi - lo))
    plan.set_xlim(lo[0] - pad, hi[0] + pad)
    plan.set_ylim(lo[1] - pad, hi[1] + pad)
    plan.set_aspect("equal")
    plan.set_xlabel("X [mm]")
    plan.set_ylabel("Y [mm]")
    plan.plot([], [], color="0.55", linestyle="--", linewidth=0.5, label="travel (G0)")
    plan.legend(loc="upper right", fontsize="small")
    fig.colorbar(down, ax=plan, label="planned pen-down speed [mm/s]", shrink=0.8)
    profile.plot(t, np.where(drawing, np.nan, speed), color="0.6", linewidth=0.6,
                 label="travel (G0)")
    profile.scatter(t[drawing], speed[drawing], c=speed[drawing], cmap=SPEED_MAP, norm=norm,
                    s=1.5, label="pen down (G1-G3)")
    profile.set_xlabel("time [s]")
    profile.set_ylabel("speed [mm/s]")
    profile.set_xlim(0.0, max(seconds, 1e-6))
    profile.legend(loc="upper right", fontsize="small", markerscale=4)
    minutes, secs = divmod(seconds, 60.0)
    fig.suptitle(f"{title}{': ' if title else ''}{seconds:.1f} s ({int(minutes)}:{secs:04.1f}) "
                 "on GRBL's planner")
    return fig


__all__ = ["preview_figure"]
