"""The mission view as one self-contained HTML page: the map of :mod:`.layers` with the
flights of :mod:`.timeline` on a time slider, and beside it each node's rate over the cycle
and the instantaneous rate.

plotly's own JavaScript is written into the page, so it opens offline. The map is in local
metres east/north of the site origin; ``map_background`` draws it on OpenStreetMap tiles
instead, which the browser fetches when the page is opened (online only).
"""

from __future__ import annotations

import html
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from validator.fileio import write_atomic
from validator.view.inputs import ViewInputs
from validator.view.layers import map_traces
from validator.view.timeline import Timeline

Trace = dict[str, Any]
DIV_ID = "mission-view"
HEIGHT_PX = 860
MAP_STYLE = "open-street-map"  # plotly's name for OpenStreetMap's tiles
MAP_X = (0.0, 0.55)  # paper fractions: the map, and the panels to its right
PANEL_X = (0.68, 1.0)
MAP_Y = (0.2, 1.0)
WIND_BLUE, WIND_GREY = "#1f77b4", "#666666"
# the wind's place: beside the map, under the speed colour bar (layers.waypoint_trace)
WIND_X, WIND_Y, WIND_ROW = 0.605, 0.42, 0.12
WIND_ARROW_PX = 14  # half the wind arrow's length
# What scattermap traces cannot take from their local-metre twins
_MAP_DROP_LINE = ("dash",)
_MAP_DROP_MARKER = ("symbol", "line")


def _is_map(trace: Trace) -> bool:
    return trace.get("xaxis", "x") == "x"


def _to_map(trace: Trace, inputs: ViewInputs) -> Trace:
    """A local-metre scatter trace (or frame update) as a scattermap one, in degrees."""
    out = dict(trace)
    if "x" in out:
        x, y = out.pop("x"), out.pop("y")
        if len(x):
            lat, lon = inputs.site.frame.to_geodetic(np.column_stack([x, y]))
            out["lat"], out["lon"] = np.round(lat, 7).tolist(), np.round(lon, 7).tolist()
        else:
            out["lat"], out["lon"] = [], []
    if "type" in out:
        out["type"] = "scattermap"
        out["subplot"] = "map"
    out.pop("hoveron", None)
    if "line" in out:
        out["line"] = {k: v for k, v in out["line"].items() if k not in _MAP_DROP_LINE}
    if "marker" in out:
        out["marker"] = {k: v for k, v in out["marker"].items() if k not in _MAP_DROP_MARKER}
    if "hovertemplate" in out:
        out["hovertemplate"] = re.sub(r"%\{x:\.0f\} m E, %\{y:\.0f\} m N",
                                      "%{lat:.6f}°, %{lon:.6f}°", out["hovertemplate"])
    return out


def _map_view(inputs: ViewInputs) -> dict[str, Any]:
    """Centre and zoom of a map holding the site, every flight and every home returns fly to
    (a DO_SET_HOME may move it off the mission's path)."""
    pts = [inputs.site.gn_xy_m, inputs.flight.path_xy_m, inputs.site.home_xy_m.reshape(1, 2),
           *(h.xy_m.reshape(1, 2) for _, h, _ in inputs.flight.homes_set())]
    if inputs.site.num_nfzs:
        pts.append(inputs.site.nfz_xy_m)
    xy = np.vstack(pts)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    lat, lon = inputs.site.frame.to_geodetic((lo + hi) / 2.0)
    span_m = max(float(np.max(hi - lo)), 100.0) * 1.3
    # MapLibre's 512-pixel tiles: at zoom z a pixel is 40075 km cos(lat) / 2^(z+9); the map is
    # about 750 pixels across
    zoom = math.log2(40_075_016.0 * math.cos(math.radians(float(lat))) * 750 / (span_m * 512))
    return {"center": {"lat": float(lat), "lon": float(lon)}, "zoom": round(zoom, 2),
            "style": MAP_STYLE,
            "domain": {"x": list(MAP_X), "y": list(MAP_Y)}}


def _wind_annotation(inputs: ViewInputs) -> list[dict[str, Any]]:
    """Beside the map's lower right corner (under the speed colour bar, where it hides no
    data), per wind: an arrow pointing where it blows and what it is: speed, the direction it
    blows FROM in degrees true, turbulence (at the flight altitude when the forecast has
    layers). The wind flown in, and the one the plan was made for when it is another."""
    rows = []
    if inputs.wind is not None:
        rows.append(("wind" if inputs.planned_wind is None else "flown in", inputs.wind,
                     WIND_BLUE))
    if inputs.planned_wind is not None:
        rows.append(("plan made for", inputs.planned_wind, WIND_GREY))
    out: list[dict[str, Any]] = []
    for i, (what, wind, colour) in enumerate(rows):
        at = wind.at(inputs.site.altitude_m)
        centre = {"x": WIND_X, "y": WIND_Y - WIND_ROW * i, "xref": "paper", "yref": "paper"}
        if not at.calm:
            to = math.radians(at.from_deg + 180.0)
            dx, dy = math.sin(to), -math.cos(to)  # screen y points down
            # centred on its point: the head a half-length ahead, the tail two behind it
            out.append({**centre, "ax": -2 * dx * WIND_ARROW_PX, "ay": -2 * dy * WIND_ARROW_PX,
                        "text": "", "showarrow": True, "arrowhead": 2, "arrowsize": 1.2,
                        "arrowwidth": 3, "arrowcolor": colour, "xshift": dx * WIND_ARROW_PX,
                        "yshift": -dy * WIND_ARROW_PX})
        lines = [f"<b>{what}</b>"]
        if at.calm:
            lines.append("still air")
        else:
            lines.append(f"{at.speed_mps:g} m/s from {at.from_deg:g}°")
            if at.turbulence_mps:
                lines.append(f"turbulence {at.turbulence_mps:g} m/s")
        if wind.layers:
            lines.append(f"at {inputs.site.altitude_m:g} m")
        out.append({**centre, "showarrow": False, "xanchor": "center", "yanchor": "top",
                    "yshift": -WIND_ARROW_PX - 4, "text": "<br>".join(lines),
                    "align": "center", "font": {"size": 10, "color": colour}})
    return out


def _layout(inputs: ViewInputs, timeline: Timeline, map_background: bool) -> dict[str, Any]:
    site = inputs.site
    panel = {"domain": list(PANEL_X), "gridcolor": "#e5e5e5", "zeroline": False}
    layout: dict[str, Any] = {
        "title": {"text": html.escape(inputs.title or f"{site.name}: mission view"),
                  "x": 0.01},
        "height": HEIGHT_PX, "plot_bgcolor": "white",
        "hovermode": "closest", "hoverdistance": 12, "barmode": "group",
        "margin": {"l": 60, "r": 20, "t": 50, "b": 20},
        "legend": {"orientation": "h", "x": 0.0, "y": 0.085, "yanchor": "top",
                   "font": {"size": 11}},
        "xaxis2": {**panel, "anchor": "y2"},
        "yaxis2": {"domain": [0.64, 1.0], "anchor": "x2", "rangemode": "tozero",
                   "title": {"text": "rate over the cycle (bps/Hz)"}, "gridcolor": "#e5e5e5"},
        "xaxis3": {**panel, "anchor": "y3", "title": {"text": "time from takeoff (s)"}},
        "yaxis3": {"domain": [0.26, 0.54], "anchor": "x3", "rangemode": "tozero",
                   "title": {"text": "instantaneous rate (bps/Hz)"}, "gridcolor": "#e5e5e5"},
        "annotations": _wind_annotation(inputs),
    }
    if timeline.times.size > 1:
        layout["xaxis3"]["range"] = [0.0, float(timeline.times[-1])]
    if not timeline.has_rates:
        # nothing to put beside the map: say why instead of empty axes
        why = ("No node rates: the plan carries<br>no planner metadata (nfzMission)"
               if inputs.flight.service is None else
               "No flight given: the planned<br>rates only" if not inputs.tracks else
               "No flown rates: no flight<br>matched to the planned slots")
        for axis in ("xaxis3", "yaxis3") + (() if inputs.flight.service else ("xaxis2",
                                                                              "yaxis2")):
            layout[axis]["visible"] = False
        layout["annotations"].append({"text": why, "showarrow": False, "xref": "paper",
                                      "yref": "paper", "x": sum(PANEL_X) / 2, "y": 0.4,
                                      "font": {"size": 12, "color": "#555"}})
    if map_background:
        layout["map"] = _map_view(inputs)
    else:
        layout["xaxis"] = {"domain": list(MAP_X), "anchor": "y", "title": {"text": "east (m)"},
                           "gridcolor": "#e5e5e5", "zeroline": False, "constrain": "domain"}
        layout["yaxis"] = {"domain": list(MAP_Y), "anchor": "x", "title": {"text": "north (m)"},
                           "scaleanchor": "x", "scaleratio": 1, "gridcolor": "#e5e5e5",
                           "zeroline": False, "constrain": "domain"}
    if timeline.times.size > 1:
        redraw = True  # bars and text labels are only redrawn, not moved, by a frame
        go = {"mode": "immediate", "frame": {"duration": 0, "redraw": redraw},
              "transition": {"duration": 0}}
        layout["sliders"] = [{
            "x": MAP_X[0] + 0.08, "len": MAP_X[1] - MAP_X[0] - 0.08, "y": 0.16,
            "yanchor": "top", "pad": {"t": 0, "b": 0},
            "currentvalue": {"prefix": "t = ", "suffix": " s",
                             "font": {"size": 13, "color": "black"}},
            # a label per second would print over each other: the current value says it
            "font": {"color": "rgba(0,0,0,0)"}, "minorticklen": 0,
            "steps": [{"label": f"{t:g}", "method": "animate", "args": [[f"{t:g}"], go]}
                      for t in timeline.times]}]
        layout["updatemenus"] = [{
            "type": "buttons", "direction": "left", "x": MAP_X[0], "y": 0.16,
            "xanchor": "left", "yanchor": "top", "pad": {"t": 20, "r": 5}, "showactive": False,
            "buttons": [
                {"label": "▶", "method": "animate",
                 "args": [None, {"frame": {"duration": 80, "redraw": redraw},
                                 "fromcurrent": True, "transition": {"duration": 0}}]},
                {"label": "❚❚", "method": "animate", "args": [[None], go]}]}]
    return layout


def view_figure(inputs: ViewInputs, *, map_background: bool = False) -> dict[str, Any]:
    """The plotly figure (data, layout, frames) of ``inputs``, as plain dicts."""
    timeline = Timeline(inputs)
    still = map_traces(inputs) + timeline.panel_traces()
    moving = timeline.animated_traces()
    frames = timeline.frames(len(still)) if timeline.times.size > 1 else []
    data = still + moving
    if map_background:
        on_map = [_is_map(t) for t in data]
        data = [_to_map(t, inputs) if m else t for t, m in zip(data, on_map, strict=True)]
        for f in frames:
            f["data"] = [_to_map(d, inputs) if on_map[i] else d
                         for i, d in zip(f["traces"], f["data"], strict=True)]
    return {"data": data, "layout": _layout(inputs, timeline, map_background),
            "frames": frames}


def view_html(inputs: ViewInputs, *, map_background: bool = False) -> str:
    """The view as one HTML page with plotly's JavaScript inside (no network needed unless
    ``map_background``)."""
    import plotly.io as pio  # only to write a view: plotly is large to import

    fig = view_figure(inputs, map_background=map_background)
    page = pio.to_html(fig, include_plotlyjs=True, full_html=True, div_id=DIV_ID,
                       auto_play=False, validate=False, default_height=f"{HEIGHT_PX}px",
                       default_width="100%",
                       config={"displaylogo": False, "scrollZoom": True, "responsive": True})
    title = html.escape(inputs.title or f"{inputs.site.name}: mission view")
    return page.replace("<head>", f"<head><title>{title}</title>", 1)


def write_view(path: str | Path, inputs: ViewInputs, *, map_background: bool = False) -> None:
    """Write :func:`view_html` to ``path`` atomically."""
    write_atomic(path, view_html(inputs, map_background=map_background))
