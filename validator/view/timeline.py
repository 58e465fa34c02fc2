"""The mission view in time: where each flight is at each step of the time slider, which node
it serves from there at what rate, and the rate each node has gathered so far in the cycle.

Rates are spectral efficiencies (bps/Hz) as :mod:`validator.replay.throughput` scores them:
instantaneous ones at the planned power, per-node ones averaged over the flown cycle, so the
bars end the cycle at the flown rates the report gives.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from validator.item_numbers import item_label
from validator.replay import Track, planned_rates, served_samples
from validator.view.inputs import ViewInputs
from validator.view.layers import TRACK_COLOURS, node_colour

Trace = dict[str, Any]
MAX_FRAMES = 300  # slider steps: enough to follow a node change, small enough to load fast
RATE_PANEL_HZ = 4.0  # samples a second drawn in the instantaneous-rate panel


@dataclass(frozen=True)
class Served:
    """One flight's service: per sample the node served (-1: none) and its rate (bps/Hz), and
    each node's bits so far over the flown cycle's length (``so_far`` (n, K), bps/Hz)."""

    gn: NDArray[np.int64]
    rate_bps_hz: NDArray[np.float64]
    so_far: NDArray[np.float64]


def served(inputs: ViewInputs, track: Track) -> Served | None:
    """:class:`Served` for ``track``, None when its slots cannot be matched to the plan."""
    flight, site = inputs.flight, inputs.site
    got = served_samples(flight, track, site)
    if isinstance(got, str) or flight.cycle is None:
        return None
    gn, rate = got
    window = flight.cycle.window_s(track.leg_start_s, track.leg_reached_s, track.leg_done_s)
    assert window is not None  # served_samples found it
    # each sample stands for half the gap to each neighbour, as flown_rates weighs them
    t = np.clip(track.t_s, *window)
    mids = np.concatenate([[t[0]], (t[1:] + t[:-1]) / 2.0, [t[-1]]])
    bits = np.zeros((t.size, site.num_gns))
    use = gn >= 0
    bits[np.flatnonzero(use), gn[use]] = rate[use] * np.diff(mids)[use]
    return Served(gn, rate, np.cumsum(bits, axis=0) / (window[1] - window[0]))


def frame_times(inputs: ViewInputs) -> NDArray[np.float64]:
    """The slider's times (s): whole seconds, or coarser on a long flight."""
    end = max((float(layer.track.t_s[-1]) for layer in inputs.tracks if layer.track.t_s.size),
              default=0.0)
    step = max(1.0, float(np.ceil(end / MAX_FRAMES)))
    return np.arange(0.0, end + step, step)


def _at(track: Track, t: float) -> int:
    """The sample of ``track`` nearest to ``t`` (the first or last outside it)."""
    i = int(np.clip(np.searchsorted(track.t_s, t), 0, track.t_s.size - 1))
    if i > 0 and abs(track.t_s[i - 1] - t) < abs(track.t_s[i] - t):
        i -= 1
    return i


class Timeline:
    """The animated traces and the slider's frames of one view."""

    def __init__(self, inputs: ViewInputs) -> None:
        self.inputs = inputs
        self.times = frame_times(inputs)
        self.served = [served(inputs, layer.track) for layer in inputs.tracks]
        self.has_rates = any(s is not None for s in self.served)
        self.rate_top = max([1e-3, *(float(np.max(s.rate_bps_hz)) for s in self.served
                                     if s is not None and s.rate_bps_hz.size)])

    def panel_traces(self) -> list[Trace]:
        """Still traces beside the map: the planned and flown rate per node over the cycle,
        and each flight's instantaneous rate, coloured by the node it serves."""
        site, flight = self.inputs.site, self.inputs.flight
        names = list(site.gn_names)
        out: list[Trace] = []
        if flight.service is not None:
            planned = planned_rates(flight.service, site)
            out.append({"type": "scatter", "mode": "markers", "x": names,
                        "y": np.round(planned, 4).tolist(), "xaxis": "x2", "yaxis": "y2",
                        "name": "planned rate over the cycle", "meta": {"layer": "planned"},
                        "marker": {"symbol": "line-ew-open", "size": 26, "line": {"width": 3},
                                   "color": "black"},
                        "hovertemplate": "%{x} planned: %{y:.4f} bps/Hz<extra></extra>"})
        for i, (layer, s) in enumerate(zip(self.inputs.tracks, self.served, strict=True)):
            if s is None:
                continue
            colour = TRACK_COLOURS[i % len(TRACK_COLOURS)]
            out.append({"type": "scatter", "mode": "markers", "x": names,
                        "y": np.round(s.so_far[-1], 4).tolist(), "xaxis": "x2", "yaxis": "y2",
                        "name": f"{layer.name}: rate over the cycle",
                        "meta": {"layer": "flown-rate", "track": i},
                        "marker": {"symbol": "circle-open", "size": 10, "color": colour},
                        "hovertemplate": "%{x} " + layer.name + ": %{y:.4f} bps/Hz<extra></extra>"})
            track = layer.track
            step = max(1, int(round(1.0 / RATE_PANEL_HZ / max(np.median(np.diff(track.t_s)),
                                                                1e-3))))
            sel = np.arange(0, track.t_s.size, step)
            sel = sel[s.gn[sel] >= 0]
            out.append({"type": "scatter", "mode": "markers", "xaxis": "x3", "yaxis": "y3",
                        "x": np.round(track.t_s[sel], 2).tolist(),
                        "y": np.round(s.rate_bps_hz[sel], 3).tolist(),
                        "text": [names[g] for g in s.gn[sel]], "showlegend": False,
                        "name": f"{layer.name}: instantaneous rate",
                        "meta": {"layer": "rate", "track": i},
                        "marker": {"size": 4 if i == 0 else 3,
                                   "color": [node_colour(int(g)) for g in s.gn[sel]],
                                   "symbol": "circle" if i == 0 else "x"},
                        "hovertemplate": "t = %{x:.1f} s, %{text}: %{y:.3f} bps/Hz<extra>"
                                         + layer.name + "</extra>"})
        return out

    def _state(self, t: float) -> list[Trace]:
        """The animated traces at time ``t``: per flight its vehicle, the link to the node it
        serves and the bars of each node's rate so far; then the rate panel's time cursor."""
        site = self.inputs.site
        out: list[Trace] = []
        for layer, s in zip(self.inputs.tracks, self.served, strict=True):
            track = layer.track
            j = _at(track, t)
            x, y = (round(float(v), 2) for v in track.xy_m[j])
            gn = int(s.gn[j]) if s is not None else -1
            label = (f"{site.gn_names[gn]} {s.rate_bps_hz[j]:.2f} bps/Hz"
                     if s is not None and gn >= 0 else "")
            out.append({"x": [x], "y": [y], "text": [label],
                        "hovertext": [f"{layer.name}, t = {track.t_s[j]:.1f} s, "
                                      f"{track.speed_mps[j]:.1f} m/s, "
                                      f"{item_label(int(track.mission_seq[j]))}"
                                      + (f"<br>serving {label}" if label else "")]})
            if gn >= 0:
                g = site.gn_xy_m[gn]
                out.append({"x": [x, round(float(g[0]), 2)], "y": [y, round(float(g[1]), 2)],
                            "line": {"color": node_colour(gn), "width": 2, "dash": "dot"}})
            else:  # one blank point, not none: plotly hides a trace born empty for good
                out.append({"x": [None], "y": [None]})
            if s is not None:
                out.append({"y": np.round(s.so_far[j], 4).tolist()})
        if self.has_rates:
            out.append({"x": [round(t, 2), round(t, 2)],
                        "y": [0.0, round(self.rate_top * 1.05, 3)]})
        return out

    def animated_traces(self) -> list[Trace]:
        """The animated traces at t = 0, with their looks (frames only move them)."""
        names = list(self.inputs.site.gn_names)
        state = iter(self._state(0.0))
        out: list[Trace] = []
        for i, (layer, s) in enumerate(zip(self.inputs.tracks, self.served, strict=True)):
            colour = TRACK_COLOURS[i % len(TRACK_COLOURS)]
            out.append({"type": "scatter", "mode": "markers+text", **next(state),
                        "name": f"{layer.name}: vehicle", "meta": {"layer": "vehicle", "track": i},
                        "uid": f"vehicle{i}",
                        "textposition": "bottom right", "hoverinfo": "text",
                        "marker": {"size": 15, "color": colour, "symbol": "circle",
                                   "line": {"width": 2, "color": "white"}}})
            out.append({"type": "scatter", "mode": "lines", **next(state), "showlegend": False,
                        "name": f"{layer.name}: serving", "hoverinfo": "skip",
                        "meta": {"layer": "link", "track": i}})
            if s is not None:
                out.append({"type": "bar", "x": names, **next(state), "xaxis": "x2",
                            "yaxis": "y2", "name": f"{layer.name}: rate so far",
                            "meta": {"layer": "so-far", "track": i}, "opacity": 0.8,
                            "marker": {"color": [node_colour(k) for k in range(len(names))],
                                       "line": {"color": colour, "width": 1.5}},
                            "hovertemplate": "%{x} so far: %{y:.4f} bps/Hz<extra></extra>"})
        if not self.has_rates:
            return out
        out.append({"type": "scatter", "mode": "lines", **next(state), "xaxis": "x3",
                    "yaxis": "y3", "showlegend": False, "name": "time", "hoverinfo": "skip",
                    "meta": {"layer": "cursor"}, "line": {"color": "black", "width": 1}})
        return out

    def frames(self, first_trace: int) -> list[dict[str, Any]]:
        """One frame per slider step, moving the animated traces (numbered from
        ``first_trace`` in the figure)."""
        count = len(self.animated_traces())
        traces = list(range(first_trace, first_trace + count))
        return [{"name": f"{t:g}", "data": self._state(float(t)), "traces": traces}
                for t in self.times]
