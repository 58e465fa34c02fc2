"""Matplotlib drawings of the studies: Fig. 3 (map, slots) and Fig. 4 (sweeps).

Each ``plot_*`` function turns results into a :class:`matplotlib.figure.Figure` and does no I/O;
:func:`save_png` writes one atomically. Figures are built with the object API (no pyplot state),
so they are safe in worker processes and notebooks alike.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, TypedDict

import numpy as np
import shapely
from matplotlib import colormaps
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Polygon
from matplotlib.typing import ColorType, LineStyleType, MarkerType
from numpy.typing import NDArray

from mission_planner.study.trials import Row, cell_float
from validator.fileio import write_atomic
from validator.geometry import segment_point_closest_fraction
from validator.zones import leg_closest_m

if TYPE_CHECKING:
    from mission_planner.optimize.solution import Solution
    from mission_planner.study.config import Fig4Config

class _Style(TypedDict):
    linestyle: LineStyleType
    marker: MarkerType
    color: ColorType


SCHEME_STYLE: dict[str, _Style] = {
    "proposed": {"linestyle": "-", "marker": "o", "color": "tab:blue"},
    "conventional": {"linestyle": "--", "marker": "s", "color": "tab:orange"},
}
VIOLATION_COLOR = "red"
MAX_INSETS = 4


def save_png(fig: Figure, path: str | Path, dpi: int = 150) -> Path:
    """Render ``fig`` to PNG and write it atomically; returns the path."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    path = Path(path)
    write_atomic(path, buf.getvalue())
    return path


def _gn_colors(num_gns: int) -> list[ColorType]:
    """A colour per GN; never red, which marks violations."""
    tab10 = colormaps["tab10"]
    base: list[ColorType] = [tab10(i) for i in (0, 1, 2, 4, 5, 6, 7, 8, 9)]
    if num_gns <= len(base):
        return base[:num_gns]
    return [colormaps["viridis"](k / (num_gns - 1)) for k in range(num_gns)]


def _draw_site(ax: Axes, sol: Solution, gn_colors: Sequence[ColorType], labels: bool) -> None:
    site = sol.site
    for name, c, r in zip(site.nfz_names, site.nfz_xy_m, site.nfz_radius_m, strict=True):
        ax.add_patch(Circle(tuple(c), r, facecolor="0.85", edgecolor="0.3", lw=1.0, zorder=1))
        if site.buffer_m > 0:
            ax.add_patch(Circle(tuple(c), r + site.buffer_m, fill=False, edgecolor="0.3",
                                lw=0.6, linestyle=":", zorder=1))
        if labels:
            ax.annotate(name, tuple(c), ha="center", va="center", fontsize=8, color="0.2")
    for zone in site.polygon_zones:
        ax.add_patch(Polygon(zone.vertices_xy_m, closed=True, facecolor="0.85", edgecolor="0.3",
                             lw=1.0, zorder=1))
        if site.buffer_m > 0:
            ring = np.asarray(zone.shape.buffer(site.buffer_m).exterior.coords)
            ax.add_patch(Polygon(ring, closed=True, fill=False, edgecolor="0.3", lw=0.6,
                                 linestyle=":", zorder=1))
        if labels:
            at = zone.shape.representative_point()
            ax.annotate(zone.name, (at.x, at.y), ha="center", va="center", fontsize=8,
                        color="0.2")
    for k, (name, g) in enumerate(zip(site.gn_names, site.gn_xy_m, strict=True)):
        ax.plot(*g, marker="^", markersize=10, color=gn_colors[k], markeredgecolor="k", zorder=5)
        if labels:
            ax.annotate(name, tuple(g), textcoords="offset points", xytext=(6, 6), fontsize=9)


def _draw_trajectory(ax: Axes, sol: Solution, gn_colors: Sequence[ColorType], marker_size: float
                     ) -> None:
    style = SCHEME_STYLE.get(sol.scheme, SCHEME_STYLE["proposed"])
    q = sol.trajectory_m
    ax.plot(q[:, 0], q[:, 1], linestyle=style["linestyle"], color="0.25", lw=1.0, zorder=2)
    colors = [gn_colors[k] if k >= 0 else "white" for k in sol.schedule]
    ax.scatter(q[1:, 0], q[1:, 1], c=colors, marker=style["marker"], s=marker_size,
               edgecolors="k", linewidths=0.5, zorder=3)
    c = sol.zone_clearance_m
    inside = np.any(c < 0.0, axis=1) if c.size else []
    for n in np.flatnonzero(inside):
        ax.plot(q[n:n + 2, 0], q[n:n + 2, 1], color=VIOLATION_COLOR, lw=2.5, zorder=4)


def _intrusions(sol: Solution) -> list[tuple[int, int, float]]:
    """(leg n, zone m, clearance m) of every leg that enters a zone, deepest first (m indexes
    ``site.zone_names``)."""
    c = sol.zone_clearance_m
    if not c.size:
        return []
    legs, zones = np.nonzero(c < 0.0)
    return sorted(((int(n), int(m), float(c[n, m])) for n, m in zip(legs, zones, strict=True)),
                  key=lambda t: t[2])


def _zoom_window(sol: Solution, leg: int, zone: int) -> tuple[NDArray[np.float64], float]:
    """Centre and half-size (m) of a window showing where leg ``leg`` cuts zone ``zone``."""
    a, b = sol.trajectory_m[leg], sol.trajectory_m[leg + 1]
    if zone >= sol.site.num_nfzs:
        poly = sol.site.polygon_zones[zone - sol.site.num_nfzs]
        t, clearance = leg_closest_m(poly, a, b)
        inside = float(shapely.LineString([a, b]).intersection(poly.shape).length)
        return a + t * (b - a), max(0.65 * inside, -4.0 * clearance, 5.0)
    c = sol.site.nfz_xy_m[zone]
    r = float(sol.site.nfz_radius_m[zone])
    t = float(segment_point_closest_fraction(a, b, c))
    p = a + t * (b - a)
    depth = r - float(np.linalg.norm(p - c))
    half_chord = math.sqrt(max(r * r - (r - depth) ** 2, 0.0))
    return p, max(1.3 * half_chord, 4.0 * depth, 5.0)


def plot_fig3_map(solutions: Sequence[Solution]) -> Figure:
    """Fig. 3a: NFZs, GNs, each scheme's trajectory with slots coloured by the GN served.

    Legs entering an NFZ are red; each zone that is entered gets a zoomed inset (up to
    :data:`MAX_INSETS`) to the right of the map.
    """
    site = solutions[0].site
    gn_colors = _gn_colors(site.num_gns)
    fig = Figure(figsize=(7.5, 6.5))
    ax = fig.add_subplot()
    _draw_site(ax, solutions[0], gn_colors, labels=True)
    for sol in solutions:
        _draw_trajectory(ax, sol, gn_colors, marker_size=22)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m, east)")
    ax.set_ylabel("y (m, north)")
    ax.grid(True, lw=0.3)
    handles = [
        Line2D([], [], color="0.25", linestyle=SCHEME_STYLE[s.scheme]["linestyle"],
               marker=SCHEME_STYLE[s.scheme]["marker"], markerfacecolor="white",
               markeredgecolor="k", label=s.scheme)
        for s in solutions if s.scheme in SCHEME_STYLE
    ]
    handles.append(Line2D([], [], color=VIOLATION_COLOR, lw=2.5, label="leg inside an NFZ"))
    handles += [Line2D([], [], color=gn_colors[k], marker="o", linestyle="none",
                       markeredgecolor="k", label=f"served: {name}")
                for k, name in enumerate(site.gn_names)]
    # below the map, off the data (the insets take its right-hand side)
    ax.legend(handles=handles, fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.1),
              ncols=3)

    seen: set[int] = set()
    insets: list[tuple[Solution, int, int]] = []
    for sol in solutions:
        for leg, zone, _ in _intrusions(sol):
            if zone in seen or len(insets) >= MAX_INSETS:
                continue
            seen.add(zone)
            insets.append((sol, leg, zone))
    size = 0.2  # of the map's height; the gap leaves room for each inset's title
    for i, (sol, leg, zone) in enumerate(insets):
        centre, half = _zoom_window(sol, leg, zone)
        inset = ax.inset_axes((1.06, 1.0 - size - i * (size + 0.06), size, size))
        _draw_site(inset, sol, gn_colors, labels=False)
        for s in solutions:
            _draw_trajectory(inset, s, gn_colors, marker_size=14)
        inset.set_xlim(centre[0] - half, centre[0] + half)
        inset.set_ylim(centre[1] - half, centre[1] + half)
        inset.set_aspect("equal")
        inset.tick_params(labelsize=6)
        inset.set_title(f"{sol.site.zone_names[zone]}, {sol.scheme} slot {leg + 1}", fontsize=7)
        ax.indicate_inset_zoom(inset, edgecolor=VIOLATION_COLOR, alpha=0.5)
    return fig


def plot_fig3_slots(solutions: Sequence[Solution]) -> Figure:
    """Fig. 3b: slot lengths δ[n] (s) and transmit power p[n] (W) per slot n for each scheme.

    Slots whose leg enters an NFZ are marked in red.
    """
    fig = Figure(figsize=(8.0, 5.5))
    ax_d, ax_p = fig.subplots(2, 1, sharex=True)
    for sol in solutions:
        style = SCHEME_STYLE.get(sol.scheme, SCHEME_STYLE["proposed"])
        n = np.arange(1, len(sol.delta_s) + 1)
        ax_d.plot(n, sol.delta_s, label=sol.scheme, markersize=3, **style)
        ax_p.plot(n, sol.power_w, label=sol.scheme, markersize=3, **style)
        inside = np.flatnonzero(np.any(sol.nfz_clearance_m < 0.0, axis=1)) if sol.site.num_nfzs \
            else np.zeros(0, dtype=int)
        if inside.size:
            ax_d.plot(n[inside], sol.delta_s[inside], linestyle="none", marker="x", markersize=8,
                      color=VIOLATION_COLOR, label=f"{sol.scheme}: leg inside an NFZ")
    ax_d.set_ylabel("δ[n] (s)")
    ax_p.set_ylabel("p[n] (W)")
    ax_p.set_xlabel("time slot n")
    for ax in (ax_d, ax_p):
        ax.grid(True, lw=0.3)
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))  # off the data
    return fig


def _mark_failures(ax: Axes, pts: Sequence[Row], x: NDArray[np.float64],
                   y: NDArray[np.float64], scheme: str, row: int) -> bool:
    """Mark the points of ``scheme`` that lost trials: hollow, labelled with the trials kept
    of those run (``98/100``) when some are left, ``scheme: no result`` at the foot of the axes
    when none is (``row`` of the schemes, so two do not overlap). True when any is hollow."""
    style = SCHEME_STYLE.get(scheme, SCHEME_STYLE["proposed"])
    trials = np.array([cell_float(r["trials"]) for r in pts])
    failed = np.array([cell_float(r["failed"]) for r in pts])
    lost = (failed > 0) & (failed < trials)
    if lost.any():
        ax.plot(x[lost], y[lost], linestyle="none", marker=style["marker"], markersize=8,
                markerfacecolor="white", markeredgecolor=style["color"], markeredgewidth=1.5,
                zorder=4)
    for xi, yi, n, f in zip(x[lost], y[lost], trials[lost], failed[lost], strict=True):
        ax.annotate(f"{n - f:g}/{n:g}", (xi, yi), textcoords="offset points", xytext=(5, 5),
                    fontsize=7, color=style["color"])
    for xi in x[(trials > 0) & (failed >= trials)]:
        ax.annotate(f"{scheme}: no result", (xi, 0.02 + 0.06 * row),
                    xycoords=("data", "axes fraction"),
                    ha="center", fontsize=7, color=style["color"])
    return bool(lost.any())


def _plot_sweeps(summary: Sequence[Row], config: Fig4Config, column: str,
                 low: str, high: str, ylabel: str) -> Figure:
    fig = Figure(figsize=(9.0, 4.0))
    ax_r, ax_m = fig.subplots(1, 2, sharey=True)
    hollow = False
    for ax, sweep, xcol, xlabel in (
        (ax_r, "radius", "radius_m", f"NFZ radius R (m), M = {config.num_nfzs}"),
        (ax_m, "count", "num_nfzs", f"number of NFZs M, R = {config.radius_m:g} m"),
    ):
        for i, scheme in enumerate(config.schemes):
            pts = sorted((r for r in summary if r["sweep"] == sweep and r["scheme"] == scheme),
                         key=lambda r: cell_float(r[xcol]))
            x = np.array([cell_float(r[xcol]) for r in pts])
            y = np.array([cell_float(r[column]) for r in pts])
            lo = np.array([cell_float(r[low]) for r in pts])
            hi = np.array([cell_float(r[high]) for r in pts])
            yerr = np.vstack([np.nan_to_num(y - lo), np.nan_to_num(hi - y)])
            style = SCHEME_STYLE.get(scheme, SCHEME_STYLE["proposed"])
            ax.errorbar(x, y, yerr=yerr, capsize=3, label=scheme, **style)
            hollow = _mark_failures(ax, pts, x, y, scheme, i) or hollow
        ax.set_xlabel(xlabel)
        ax.grid(True, lw=0.3)
    ax_r.set_ylabel(ylabel)
    handles, labels = ax_m.get_legend_handles_labels()
    if hollow:
        handles.append(Line2D([], [], linestyle="none", marker="o", markerfacecolor="white",
                              markeredgecolor="0.3", markeredgewidth=1.5))
        labels.append("some trials failed:\nsites kept / run")
    ax_m.legend(handles, labels, fontsize=8, loc="upper left",
                bbox_to_anchor=(1.02, 1.0))  # off the data
    trials = max((int(cell_float(r["trials"])) for r in summary), default=0)
    fig.suptitle(f"{trials} random sites per point, error bars: 95 % confidence", fontsize=9)
    return fig


def plot_fig4(summary: Sequence[Row], config: Fig4Config) -> tuple[Figure, Figure]:
    """Fig. 4a (average spectral efficiency, zero on outage) and 4b (outage probability)."""
    fig_a = _plot_sweeps(summary, config, "spectral_efficiency_bps_hz",
                         "spectral_efficiency_ci_low", "spectral_efficiency_ci_high",
                         "average spectral efficiency (bps/Hz)")
    fig_b = _plot_sweeps(summary, config, "outage_probability", "outage_ci_low",
                         "outage_ci_high", "outage probability")
    return fig_a, fig_b


def plot_wind(rows: Sequence[Row], site_name: str,
              directions_deg: Sequence[float], buffer_m: float | None = None) -> Figure:
    """The wind study (:mod:`mission_planner.study.wind`): against wind speed, one colour per
    direction, the min rate per flown second, the flown cycle over T and the least flown
    clearance (the safety buffer ``buffer_m`` marked); the plan made for the wind solid, the
    still-air plan flown in it dashed."""
    fig = Figure(figsize=(13.5, 4.0))
    axes = fig.subplots(1, 3)
    panels = (("flown_min_rate_bps_hz", "blind_flown_min_rate_bps_hz",
               "min rate per flown second (bps/Hz)"),
              ("cycle_ratio", "blind_cycle_ratio", "flown cycle / T"),
              ("clearance_min_m", "blind_clearance_min_m", "least flown clearance (m)"))
    ok = [r for r in rows if not r.get("error")]
    still = [r for r in ok if cell_float(r["speed_mps"]) == 0.0]
    tab10 = colormaps["tab10"]
    for i, d in enumerate(directions_deg):
        pts = sorted([r for r in ok if cell_float(r["speed_mps"]) > 0
                      and math.isclose(cell_float(r["from_deg"]), float(d) % 360.0)] + still,
                     key=lambda r: cell_float(r["speed_mps"]))
        if not pts:
            continue
        speed = [cell_float(r["speed_mps"]) for r in pts]
        for ax, (aware, blind, _) in zip(axes, panels, strict=True):
            ax.plot(speed, [cell_float(r[aware]) for r in pts], "-o", color=tab10(i % 10),
                    markersize=4, label=f"from {float(d):g}°")
            ax.plot(speed, [cell_float(r[blind]) for r in pts], "--", color=tab10(i % 10),
                    alpha=0.7)
    for ax, (_, _, label) in zip(axes, panels, strict=True):
        ax.set_xlabel("wind speed (m/s)")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[1].axhline(1.0, color="black", linewidth=0.8)
    if buffer_m is not None:
        axes[2].axhline(buffer_m, color=VIOLATION_COLOR, linewidth=0.8, label="buffer")
    handles, labels = axes[0].get_legend_handles_labels()
    handles += [Line2D([], [], color="grey", linestyle="-"),
                Line2D([], [], color="grey", linestyle="--")]
    labels += ["planned for the wind", "still-air plan in the wind"]
    axes[0].legend(handles, labels, fontsize=8)
    fig.suptitle(f"{site_name}: planned for and flown in wind (validator model)")
    return fig

