"""The still layers of a mission view, as plotly trace dicts in local metres: zones and their
buffers, the fence as uploaded, nodes, home and each home a DO_SET_HOME moves it to, rally
points, the legs coloured by commanded speed (transits dashed, apart from the service
cycle), the waypoints with what a pilot asks of each, flown tracks, failsafe paths, a fault
injected in flight and the flight after it.

Each trace carries ``meta.layer`` (``zone``, ``buffer``, ``fence``, ``node``, ``home``,
``set-home``, ``rally``, ``cycle``, ``transit``, ``waypoint``, ``track``, ``failsafe``,
``fault``) so the page, its tests and a reader's script can find a layer without counting
traces.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from validator.audit import zone_leg_clearances
from validator.fence_geometry import local_fence
from validator.flight import Home
from validator.flight.home import set_home_source
from validator.item_numbers import item_label, item_number
from validator.plan_format import Autopilot, Cmd
from validator.replay import slot_map
from validator.view.inputs import ViewInputs

Trace = dict[str, Any]

ZONE_RED = "#d62728"
FAILSAFE_GREEN = "#2ca02c"
FENCE_ORANGE = "#ff7f0e"
INCLUSION_BLUE = "#1f77b4"
# Node colours: a qualitative palette without red, which the zones keep
NODE_COLOURS = ("#1f77b4", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22",
                "#7f7f7f", "#ff7f0e", "#393b79")
TRACK_COLOURS = ("#222222", "#ff00aa", "#00a0a0")
# Viridis at six stops: the legs' speed colours, and the waypoints' colour bar, which plotly
# draws from the same name
_VIRIDIS = ((0.0, (68, 1, 84)), (0.2, (65, 68, 135)), (0.4, (42, 120, 142)),
            (0.6, (34, 168, 132)), (0.8, (122, 209, 81)), (1.0, (253, 231, 37)))
CIRCLE_POINTS = 97
SAME_PLACE_M = 0.5  # waypoints closer than this share one marker


def node_colour(k: int) -> str:
    return NODE_COLOURS[k % len(NODE_COLOURS)]


def speed_colour(speed_mps: float, top_mps: float) -> str:
    """The Viridis colour of ``speed_mps`` on a 0..``top_mps`` scale."""
    f = min(max(speed_mps / top_mps, 0.0), 1.0) if top_mps > 0 else 0.0
    for (f0, c0), (f1, c1) in zip(_VIRIDIS, _VIRIDIS[1:], strict=False):
        if f <= f1:
            w = (f - f0) / (f1 - f0)
            r, g, b = (round(a + w * (z - a)) for a, z in zip(c0, c1, strict=True))
            return f"rgb({r},{g},{b})"
    return "rgb(253,231,37)"


def _xy(points: NDArray[np.float64]) -> dict[str, list[float]]:
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    return {"x": np.round(p[:, 0], 2).tolist(), "y": np.round(p[:, 1], 2).tolist()}


def _ring(centre: NDArray[np.float64], radius_m: float) -> NDArray[np.float64]:
    a = np.linspace(0.0, 2.0 * math.pi, CIRCLE_POINTS)
    return np.column_stack([centre[0] + radius_m * np.cos(a), centre[1] + radius_m * np.sin(a)])


def _closed(ring: NDArray[np.float64]) -> NDArray[np.float64]:
    ring = np.asarray(ring, dtype=float)
    return ring if np.all(ring[0] == ring[-1]) else np.vstack([ring, ring[:1]])


def _outline(layer: str, name: str, ring: NDArray[np.float64], colour: str, *, dash: str,
             legend: str, first: bool, fill: str | None = None, width: float = 1.2) -> Trace:
    t: Trace = {"type": "scatter", "mode": "lines", **_xy(_closed(ring)), "name": legend,
                "legendgroup": legend, "showlegend": first, "meta": {"layer": layer, "of": name},
                "line": {"color": colour, "width": width, "dash": dash},
                "hoverinfo": "text", "hovertext": name, "hoveron": "points"}
    if fill is not None:
        t.update(fill="toself", fillcolor=fill, line={"color": colour, "width": 0.8})
    return t


def zone_traces(inputs: ViewInputs) -> list[Trace]:
    """Each zone as published (filled) and grown by the safety buffer (dashed)."""
    site = inputs.site
    zones: list[tuple[str, NDArray[np.float64], NDArray[np.float64] | None]] = []
    for name, c, r in zip(site.nfz_names, site.nfz_xy_m, site.nfz_radius_m, strict=True):
        zones.append((name, _ring(c, float(r)),
                      _ring(c, float(r) + site.buffer_m) if site.buffer_m > 0 else None))
    for z in site.polygon_zones:
        grown = (np.asarray(z.shape.buffer(site.buffer_m).exterior.coords)
                 if site.buffer_m > 0 else None)
        zones.append((z.name, np.asarray(z.vertices_xy_m, dtype=float), grown))
    out = [_outline("zone", name, ring, ZONE_RED, dash="solid", legend="no-fly zone",
                    first=i == 0, fill="rgba(214,39,40,0.25)")
           for i, (name, ring, _) in enumerate(zones)]
    out += [_outline("buffer", f"{name} + {site.buffer_m:g} m buffer", grown, ZONE_RED,
                     dash="dash", legend="zone + buffer", first=i == 0)
            for i, (name, _, grown) in enumerate(zones) if grown is not None]
    return out


def fence_traces(inputs: ViewInputs) -> list[Trace]:
    """The geofence the plan uploads (``geoFence``), exclusions orange, inclusions blue."""
    fence = local_fence(inputs.plan, inputs.site.frame)
    shapes: list[tuple[str, NDArray[np.float64], bool]] = []
    for i, (c, r, inclusion) in enumerate(fence.circles):
        shapes.append((f"fence circle {i + 1}, radius {r:.1f} m", _ring(c, r), inclusion))
    for i, (poly, inclusion) in enumerate(fence.polygons):
        ring = np.asarray(poly.exterior.coords, dtype=float)
        shapes.append((f"fence polygon {i + 1}, {len(ring) - 1} vertices", ring, inclusion))
    out: list[Trace] = []
    seen: set[bool] = set()
    for name, ring, inclusion in shapes:
        legend = "inclusion fence" if inclusion else "exclusion fence (uploaded)"
        out.append(_outline("fence", name, ring, INCLUSION_BLUE if inclusion else FENCE_ORANGE,
                            dash="dot", legend=legend, first=inclusion not in seen, width=2.0))
        seen.add(inclusion)
    return out


def _legs_text(inputs: ViewInputs, legs: Sequence[int]) -> str:
    """The legs a home is in force on, by their items, a run of consecutive legs at a time:
    "the leg to item 4", "the legs to items 10 ... 15" (a DO_JUMP loop may give several)."""
    runs: list[list[int]] = []
    for k in legs:
        if runs and k == runs[-1][-1] + 1:
            runs[-1].append(k)
        else:
            runs.append([k])
    items = [(item_number(inputs.flight.legs[r[0]].item),
              item_number(inputs.flight.legs[r[-1]].item)) for r in runs]
    return "; ".join(f"the leg to item {a}" if len(r) == 1 else f"the legs to items {a} ... {b}"
                     for r, (a, b) in zip(runs, items, strict=True))


def _set_home_trace(inputs: ViewInputs, homes: Sequence[tuple[int, Home, Sequence[int]]]
                    ) -> Trace:
    plan = inputs.plan
    px4 = plan.firmware_type == Autopilot.PX4
    rally = ", or to a rally point chosen against it" if plan.rally else ""
    hovers = []
    for by, home, legs in homes:
        at_vehicle, _ = set_home_source(plan.items[by], px4)
        how = "where the vehicle is" if at_vehicle else "at its coordinates"
        hovers.append(f"<b>{home.label}</b> (DO_SET_HOME, {how})<br>in force on "
                      f"{_legs_text(inputs, legs)}:<br>a return from them flies here{rally}")
    # open, where the plan's home is filled: a home too, put in force in flight; named, as
    # the tile map draws every marker as a plain dot
    return {"type": "scatter", "mode": "markers+text",
            **_xy(np.asarray([h.xy_m for _, h, _ in homes], dtype=float)),
            "name": "home set by DO_SET_HOME", "text": [h.label for _, h, _ in homes],
            "textposition": "bottom center", "textfont": {"size": 11},
            "meta": {"layer": "set-home", "items": [item_number(by) for by, _, _ in homes]},
            "uid": "set-home",
            "marker": {"symbol": "square-open", "size": 13, "color": "black",
                       "line": {"width": 2.5}},
            "customdata": hovers,
            "hovertemplate": "%{customdata}<br>%{x:.0f} m E, %{y:.0f} m N<extra></extra>"}


def point_traces(inputs: ViewInputs) -> list[Trace]:
    """Nodes (triangles, named), home (square), each home a DO_SET_HOME puts in force (open
    square, named by its item) and the rally points (diamonds)."""
    site, plan = inputs.site, inputs.plan
    home = site.frame.to_local(plan.home_lat_deg, plan.home_lon_deg)
    moved = inputs.flight.homes_set()
    until = (f" (the plan's)<br>returns fly here until the DO_SET_HOME of {item_label(moved[0][0])}"
             if moved else "")
    out: list[Trace] = [{
        "type": "scatter", "mode": "markers+text", **_xy(site.gn_xy_m), "name": "ground nodes",
        "text": list(site.gn_names), "textposition": "top center", "meta": {"layer": "node"},
        "marker": {"symbol": "triangle-up", "size": 13, "line": {"width": 1, "color": "black"},
                   "color": [node_colour(k) for k in range(site.num_gns)]},
        "hovertemplate": "%{text}<br>%{x:.0f} m E, %{y:.0f} m N<extra></extra>",
    }, {
        "type": "scatter", "mode": "markers", **_xy(home), "name": "home",
        "meta": {"layer": "home"},
        "marker": {"symbol": "square", "size": 11, "color": "black"},
        "hovertemplate": f"home{until}<br>%{{x:.0f}} m E, %{{y:.0f}} m N<extra></extra>",
    }]
    if moved:  # two kinds of home on the map: name both
        out[1].update(mode="markers+text", text=["home (the plan's)"],
                      textposition="bottom center", textfont={"size": 11})
        out.append(_set_home_trace(inputs, moved))
    if plan.rally:
        rally = site.frame.to_local([p[0] for p in plan.rally], [p[1] for p in plan.rally])
        out.append({"type": "scatter", "mode": "markers", **_xy(rally), "name": "rally points",
                    "meta": {"layer": "rally"},
                    "marker": {"symbol": "diamond-open", "size": 14, "color": "black",
                               "line": {"width": 2}},
                    "hovertemplate": "rally point<br>%{x:.0f} m E, %{y:.0f} m N<extra></extra>"})
    return out


def cycle_legs(inputs: ViewInputs) -> range:
    """Indices of the legs flown in the service cycles (the rest are transits)."""
    c = inputs.flight.cycle
    if c is None:
        return range(0)
    return range(c.start_leg + 1 if c.start_at_arrival else c.start_leg, c.end_leg + 1)


def _top_speed_mps(inputs: ViewInputs) -> float:
    speeds = [leg.speed_mps for leg in inputs.flight.legs if leg.speed_mps is not None]
    return max([inputs.site.max_speed_mps, *speeds])


def leg_traces(inputs: ViewInputs) -> list[Trace]:
    """One line a leg, coloured by its commanded speed; transits dashed."""
    top = _top_speed_mps(inputs)
    cycle = set(cycle_legs(inputs))
    out: list[Trace] = []
    shown: set[str] = set()
    for k, leg in enumerate(inputs.flight.legs):
        if leg.length_m < 0.01:  # takeoff and landing: vertical
            continue
        layer = "cycle" if k in cycle else "transit"
        legend = "service cycle (colour: commanded speed)" if layer == "cycle" else "transits"
        out.append({
            "type": "scatter", "mode": "lines", **_xy(np.stack([leg.start_xy_m, leg.end_xy_m])),
            "name": legend, "legendgroup": layer, "showlegend": layer not in shown,
            "meta": {"layer": layer, "leg": k},
            "line": {"color": speed_colour(leg.speed_mps or top, top), "width": 3.5,
                     "dash": "solid" if layer == "cycle" else "dash"},
            "hoverinfo": "skip",  # the waypoint at its end tells speed and more
        })
        shown.add(layer)
    return out


def _slot_notes(inputs: ViewInputs) -> dict[int, str]:
    """Per leg: the planned slots it flies and holds, and their times in the cycle."""
    service = inputs.flight.service
    if service is None:
        return {}
    sm = slot_map(inputs.flight, service)
    if isinstance(sm, str):
        return {}
    ends = np.concatenate([[0.0], np.cumsum(service.delta_s)])
    names = inputs.site.gn_names
    out: dict[int, str] = {}
    for k in set(sm.moving) | set(sm.hold):
        parts = []
        for what, rows in (("flies", sm.moving.get(k)), ("holds", sm.hold.get(k))):
            if rows is None or not rows.size:
                continue
            n = rows[:, 0].astype(int)
            gns = sorted({names[g] for g in service.schedule[n] if g >= 0})
            which = f"slot {n[0] + 1}" if n.size == 1 else f"slots {n[0] + 1}-{n[-1] + 1}"
            parts.append(f"{what} {which} (t {ends[n[0]]:.1f}-"
                         f"{ends[n[-1] + 1]:.1f} s of T, serving {', '.join(gns) or 'nobody'})")
        out[k] = "<br>".join(parts)
    return out


def waypoint_trace(inputs: ViewInputs) -> Trace:
    """One marker per mission item the vehicle flies to, coloured by the speed it is flown
    at; its hover: item, command, speed, hold, planned slots and times, clearance."""
    flight, plan, site = inputs.flight, inputs.plan, inputs.site
    clear = zone_leg_clearances(flight, site)
    notes = _slot_notes(inputs)
    reached = inputs.tracks[0].track.leg_reached_s if inputs.tracks else None
    first: dict[int, list[int]] = {}
    for k, leg in enumerate(flight.legs):
        first.setdefault(leg.item, []).append(k)
    # Items at one place (a cycle closing where it began, takeoff and landing at home) share
    # a marker, so hovering it tells all of them
    pts: list[NDArray[np.float64]] = []
    texts: list[list[str]] = []
    items: list[list[int]] = []
    colours: list[float] = []
    top = _top_speed_mps(inputs)
    for item, legs in first.items():
        k = legs[0]
        leg = flight.legs[k]
        try:
            command = Cmd(plan.items[item].command).name
        except (ValueError, IndexError):
            command = str(plan.items[item].command) if item < len(plan.items) else "?"
        lines = [f"<b>{item_label(item)}</b>: {command}",
                 "speed " + ("autopilot default" if leg.speed_mps is None
                             else f"{leg.speed_mps:.2f} m/s") + f", hold {leg.hold_s:g} s"]
        if len(legs) > 1:
            lines.append(f"flown {len(legs)} times (DO_JUMP)")
        if k in notes:
            lines.append(notes[k])
        if clear.shape[1]:
            z = int(np.argmin(clear[k]))
            lines.append(f"clearance {clear[k, z]:.2f} m from {site.zone_names[z]} "
                         f"(buffer {site.buffer_m:g} m)")
        if reached is not None and k < reached.size and np.isfinite(reached[k]):
            lines.append(f"{inputs.tracks[0].name}: reached at t = {reached[k]:.1f} s")
        at = next((i for i, p in enumerate(pts) if np.hypot(*(p - leg.end_xy_m)) < SAME_PLACE_M),
                  None)
        if at is None:
            pts.append(leg.end_xy_m)
            texts.append([])
            items.append([])
            colours.append(leg.speed_mps if leg.speed_mps is not None else top)
            at = len(pts) - 1
        texts[at].append("<br>".join(lines))
        items[at].append(item_number(item))
    return {
        "type": "scatter", "mode": "markers", **_xy(np.asarray(pts).reshape(-1, 2)),
        "name": "waypoints", "meta": {"layer": "waypoint", "items": items},
        "uid": "waypoints", "hovertext": ["<br>—<br>".join(t) for t in texts],
        "hoverinfo": "text",
        "marker": {"size": 10, "color": [round(c, 2) for c in colours], "colorscale": "Viridis",
                   "cmin": 0.0, "cmax": top, "line": {"width": 1.5, "color": "black"},
                   "colorbar": {"title": {"text": "commanded<br>speed (m/s)"}, "x": 0.565,
                                "xanchor": "left", "len": 0.5, "y": 0.72,
                                "thickness": 12}},
    }


def track_traces(inputs: ViewInputs, step: int = 5) -> list[Trace]:
    """Each flight as a thin line (every ``step``-th sample: 4 Hz of a 20 Hz replay)."""
    out = []
    for i, layer in enumerate(inputs.tracks):
        xy = layer.track.xy_m[::step]
        if layer.track.xy_m.shape[0] and (layer.track.xy_m.shape[0] - 1) % step:
            xy = np.vstack([xy, layer.track.xy_m[-1:]])
        out.append({"type": "scatter", "mode": "lines", **_xy(xy), "name": layer.name,
                    "meta": {"layer": "track", "track": i}, "hoverinfo": "skip",
                    "line": {"color": TRACK_COLOURS[i % len(TRACK_COLOURS)], "width": 1.2},
                    "opacity": 0.7})
    return out


def failsafe_traces(inputs: ViewInputs) -> list[Trace]:
    """The failsafe paths an audit checked, green when they held, red when not: a region of
    returns as a light filled outline, one return as a dash-dot line, the mission's path a
    SmartRTL retraces as a halo under the legs."""
    out = []
    shown: set[str] = set()
    for path in inputs.failsafe_paths:
        colour, fill = ((FAILSAFE_GREEN, "rgba(44,160,44,0.08)") if path.ok
                        else (ZONE_RED, "rgba(214,39,40,0.08)"))
        legend = {"region": "failsafe returns", "line": "failsafe return",
                  "retrace": "failsafe retrace"}[path.kind] + (
                      " (clear)" if path.ok else " (into a zone or buffer)")
        t: Trace = {"type": "scatter", "mode": "lines", **_xy(path.xy_m), "name": legend,
                    "legendgroup": legend, "showlegend": legend not in shown,
                    "meta": {"layer": "failsafe", "kind": path.kind, "ok": path.ok},
                    "hoverinfo": "text", "hoveron": "points",
                    "hovertext": f"<b>{path.name}</b>" + (f"<br>{path.note}" if path.note else ""),
                    "line": {"color": colour, "width": 2.0, "dash": "dashdot"}}
        if path.kind == "region":
            t.update(fill="toself", fillcolor=fill, line={"color": colour, "width": 0.8,
                                                          "dash": "dot"})
        elif path.kind == "retrace":
            t.update(line={"color": colour, "width": 10.0}, opacity=0.3)
        out.append(t)
        shown.add(legend)
    return out


def fault_traces(inputs: ViewInputs) -> list[Trace]:
    """A fault injected in flight: the flight after it, green when it kept out of every zone
    and red when not, and a cross where it was injected (what the autopilot did, on hover)."""
    f = inputs.fault
    if f is None:
        return []
    colour = ZONE_RED if f.entered_zone else FAILSAFE_GREEN
    hover = f"<b>{f.kind} fault</b><br>{f.note}"
    return [{"type": "scatter", "mode": "lines", **_xy(f.after_xy_m),
             "name": f"after the {f.kind} fault", "meta": {"layer": "fault", "kind": "after"},
             "hoverinfo": "text", "hoveron": "points", "hovertext": hover,
             "line": {"color": colour, "width": 3.0}, "opacity": 0.8},
            {"type": "scatter", "mode": "markers", **_xy(f.xy_m[None, :]),
             "name": f"{f.kind} injected", "meta": {"layer": "fault", "kind": "injected"},
             "hoverinfo": "text", "hovertext": hover,
             "marker": {"symbol": "x", "size": 14, "color": colour,
                        "line": {"width": 1.5, "color": "black"}}}]


def map_traces(inputs: ViewInputs) -> list[Trace]:
    """Every still layer of the map, bottom to top."""
    return [*zone_traces(inputs), *fence_traces(inputs), *failsafe_traces(inputs),
            *leg_traces(inputs), *track_traces(inputs), *fault_traces(inputs),
            waypoint_trace(inputs), *point_traces(inputs)]
