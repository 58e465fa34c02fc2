"""The paper's Fig. 3 for one solution: (a) the map, (b) slot lengths and transmit power.

(a) NFZs as published (filled; circles and polygons), with their safety buffer (dashed) and,
for circles, the largest per-leg expanded radius √((R + buffer)² + (Vδ[n]/2)²) of eq. (6)
(dotted), the trajectory with each leg
coloured by the GN served in its slot (grey: nobody), the transits of an exported mission
(grey dashed), GNs and home. (b) δ[n] (s, left axis) and p[n] (mW, right axis) per slot.

Uses matplotlib's object API on an Agg canvas: no pyplot state, no display needed.
"""

from __future__ import annotations

import io

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Polygon

from mission_planner.mission import Mission
from mission_planner.optimize.solution import Solution
from validator.geometry import expanded_radius


def solution_figure(solution: Solution, mission: Mission | None = None) -> Figure:
    """Fig. 3 (a) and (b) of ``solution``; with ``mission``, its exported path and transits."""
    site = solution.site
    q = mission.trajectory_m if mission is not None else solution.trajectory_m
    fig = Figure(figsize=(13.0, 5.2), layout="constrained")
    FigureCanvasAgg(fig)
    ax, bx = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.1, 1.0]})
    colours = [f"C{k % 10}" for k in range(site.num_gns)]

    exp = expanded_radius(site.planning_radius_m[None, :],
                          (site.max_speed_mps * solution.delta_s)[:, None])
    for m, (c, r) in enumerate(zip(site.nfz_xy_m, site.nfz_radius_m, strict=True)):
        ax.add_patch(Circle(tuple(c), float(r), color="tab:red", alpha=0.25, lw=0))
        ax.add_patch(Circle(tuple(c), float(r + site.buffer_m), fill=False, ec="tab:red",
                            ls="--", lw=0.8, label="NFZ + buffer" if m == 0 else None))
        ax.add_patch(Circle(tuple(c), float(np.max(exp[:, m])), fill=False, ec="tab:red", ls=":",
                            lw=0.8, label="max expanded radius (eq. 6)" if m == 0 else None))
        ax.annotate(site.nfz_names[m], tuple(c), ha="center", va="center", fontsize=8)
    for j, zone in enumerate(site.polygon_zones):
        first = j == 0 and not site.num_nfzs
        ax.add_patch(Polygon(zone.vertices_xy_m, closed=True, color="tab:red", alpha=0.25, lw=0))
        if site.buffer_m > 0:
            ring = np.asarray(zone.shape.buffer(site.buffer_m).exterior.coords)
            ax.add_patch(Polygon(ring, closed=True, fill=False, ec="tab:red", ls="--", lw=0.8,
                                 label="NFZ + buffer" if first else None))
        centre = zone.shape.representative_point()
        ax.annotate(zone.name, (centre.x, centre.y), ha="center", va="center", fontsize=8)

    legs = np.stack([q[:-1], q[1:]], axis=1)
    leg_colours = [colours[k] if k >= 0 else "0.6" for k in solution.schedule]
    ax.add_collection(LineCollection(list(legs), colors=leg_colours, lw=1.8))
    ax.scatter(q[1:, 0], q[1:, 1], s=9, c=leg_colours, zorder=3)
    if mission is not None:
        for path, label in ((mission.outbound_m, "transits"), (mission.return_m, None)):
            ax.plot(path[:, 0], path[:, 1], color="0.45", ls="--", lw=1.0, label=label)
    for k, (name, g) in enumerate(zip(site.gn_names, site.gn_xy_m, strict=True)):
        ax.scatter([g[0]], [g[1]], marker="^", s=70, color=colours[k], edgecolor="k", zorder=4,
                   label=name)
    ax.scatter([site.home_xy_m[0]], [site.home_xy_m[1]], marker="s", s=50, color="k",
               zorder=4, label="home")
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_title(f"(a) trajectory and scheduling: {site.name}, {solution.scheme}")
    # beside the map, never on it (inside, "best" still covered the path to a node)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    ax.grid(alpha=0.3)

    n = np.arange(1, len(solution.delta_s) + 1)
    bx.step(n, solution.delta_s, where="mid", color="C0", label="δ[n]")
    bx.set_xlabel("time slot n")
    bx.set_ylabel("δ[n] (s)", color="C0")
    px = bx.twinx()
    px.step(n, solution.power_w * 1e3, where="mid", color="C3", label="p[n]")
    px.set_ylabel("p[n] (mW)", color="C3")
    bx.set_title("(b) slot lengths and transmit power")
    bx.grid(alpha=0.3)
    return fig


def figure_png(fig: Figure, dpi: int = 120) -> bytes:
    """The figure as PNG bytes (so the caller can write the file atomically)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()
