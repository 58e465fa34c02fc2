"""Polygon zones in the exporter: fence outlines that survive MAVLink's rounding, transits round
polygons, nudges, the report, the .waypoints fence and the figures (hand-made solutions on the
airfield sample, so no optimiser is needed)."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from matplotlib.patches import Polygon

from mission_planner.figure import solution_figure
from mission_planner.mission import MissionOptions, build_mission
from mission_planner.mission.clearance import nudge_clear
from mission_planner.mission.fence import ROUNDING_ALLOWANCE_M, exclusion_outline
from mission_planner.mission.options import leg_margin_m
from mission_planner.mission.summary import mission_summary
from mission_planner.study.plots import plot_fig3_map
from tests.mission_planner.solutions import airfield_solution
from validator.audit import audit
from validator.geodesy import LocalFrame, round_e7
from validator.plan_format import Cmd
from validator.site import Site
from validator.waypoints_format import dumps_fence_waypoints, loads_fence_waypoints
from validator.zones import fence_outline_m, polygon_zone


@pytest.fixture(scope="module")
def solution():
    return airfield_solution()


@pytest.fixture(scope="module")
def site(solution) -> Site:
    return solution.site


@pytest.fixture(scope="module")
def mission(solution):
    return build_mission(solution, MissionOptions())


def _held(frame: LocalFrame, vertices_deg) -> shapely.Polygon:
    lat = np.array([v[0] for v in vertices_deg])
    lon = np.array([v[1] for v in vertices_deg])
    return shapely.Polygon(frame.to_local(lat, lon))


ZONES = {
    "T": [(0, 0), (300, 0), (300, 60), (180, 60), (180, 110), (120, 110), (120, 60), (0, 60)],
    "sliver": [(0, 0), (400, 3), (0, 8)],  # two corners of about 1°
    "hexagon": [(50 * np.cos(a), 50 * np.sin(a)) for a in np.linspace(0, 2 * np.pi, 7)[:-1]],
}


@pytest.mark.parametrize("lat0", [0.0, 37.5585, 69.9])
@pytest.mark.parametrize("margin_m", [0.0, 0.05, 1.5])
@pytest.mark.parametrize("name", list(ZONES))
def test_the_rounded_fence_outline_holds_the_zone_plus_its_margin(lat0, margin_m, name):
    frame = LocalFrame(lat0, 10.0)
    zone = polygon_zone(name, np.asarray(ZONES[name]) + 1000.0, name)
    verts = exclusion_outline(zone, margin_m, frame)
    lat, lon = np.array(verts).T
    assert np.array_equal(lat, round_e7(lat)) and np.array_equal(lon, round_e7(lon))
    held = _held(frame, verts)
    assert held.is_valid and held.contains(zone.shape)
    assert held.exterior.distance(zone.shape) >= margin_m
    # and it is the mitred outline grown by the allowance once, not a looser one
    assert len(verts) == len(fence_outline_m(zone, margin_m + ROUNDING_ALLOWANCE_M))
    assert held.area <= shapely.Polygon(fence_outline_m(zone, margin_m + 0.02)).area


def test_without_the_allowance_rounding_cuts_into_the_margin_somewhere():
    # the reason for ROUNDING_ALLOWANCE_M: some rounded vertex moves inwards
    cut = 0
    for lat0 in (0.0, 37.5585, 69.9):
        frame = LocalFrame(lat0, 10.0)
        for name, v in ZONES.items():
            zone = polygon_zone(name, np.asarray(v) + 1000.0, name)
            lat, lon = frame.to_geodetic(fence_outline_m(zone, 1.5))
            held = shapely.Polygon(frame.to_local(round_e7(lat), round_e7(lon)))
            cut += held.exterior.distance(zone.shape) < 1.5
    assert cut > 0


def test_the_airfield_sample_has_a_non_convex_ctr_a_circle_and_an_airspace_polygon(site):
    assert site.zone_names == ("MAST", "CTR", "PRISON")
    ctr, prison = site.polygon_zones
    assert not ctr.is_convex and prison.is_convex


def test_each_polygon_zone_gets_an_exclusion_fence_and_the_gate_passes(site, mission):
    assert mission.safe, mission.problems
    plan = mission.plan
    excl = [p for p in plan.polygons if not p.inclusion]
    assert [len(p.vertices_deg) for p in excl] == _outline_sizes(site, mission)
    assert [c.inclusion for c in plan.circles] == [False]
    for zone, fence in zip(site.polygon_zones, excl, strict=True):
        held = _held(site.frame, fence.vertices_deg)
        assert held.exterior.distance(zone.shape) >= mission.fence_margin_m
    report = audit(plan, site, require_buffer=True)
    assert report.ok, [f.message for f in report.violations]
    rows = {z.name: z.clearance_m for z in report.nfz}
    assert min(rows.values()) >= site.buffer_m


def test_transits_go_round_the_ctr_with_the_leg_margin(site, mission):
    ctr = site.polygon_zones[0]
    need = site.buffer_m + leg_margin_m(site, mission.options)
    for path in (mission.outbound_m, mission.return_m):
        assert len(path) > 2  # the straight line home crosses the runway
        line = shapely.LineString(path)
        assert line.distance(ctr.shape) >= need - 1e-6
        # and not far round: within 10 % of the shortest way round the grown zone
        grown = ctr.shape.buffer(need)
        assert line.length < 1.1 * (np.hypot(*(path[-1] - path[0])) + grown.length / 2)
    assert np.allclose(mission.outbound_m[0], site.home_xy_m)
    assert np.allclose(mission.return_m[-1], site.home_xy_m)


def test_a_service_leg_just_inside_a_polygon_buffer_is_nudged_out(site):
    prison = site.polygon_zones[1]
    # a leg 1 cm inside PRISON's buffer, along its west edge pushed out by buffer - 1 cm
    a, b = prison.vertices_xy_m[0], prison.vertices_xy_m[-1]
    normal = np.array([-(b - a)[1], (b - a)[0]]) / np.hypot(*(b - a))
    normal = normal if shapely.Point(a + normal).distance(prison.shape) > 0 else -normal
    legs = np.array([a, b]) + (site.buffer_m - 0.01) * normal
    pts, moved = nudge_clear(legs, np.zeros((0, 2)), np.zeros(0), target_margin_m=0.01,
                             max_nudge_m=0.05, closed=False, zones=(prison,),
                             zone_clearance_m=site.buffer_m)
    assert shapely.LineString(pts).distance(prison.shape) >= site.buffer_m + 0.01 - 1e-9
    assert 0.02 <= moved < 0.03
    # a leg 10 cm short is not solver noise: left for the gate
    far = np.array([a, b]) + (site.buffer_m - 0.1) * normal
    assert nudge_clear(far, np.zeros((0, 2)), np.zeros(0), target_margin_m=0.01,
                       max_nudge_m=0.05, closed=False, zones=(prison,),
                       zone_clearance_m=site.buffer_m)[1] == 0.0


def _outline_sizes(site, mission) -> list[int]:
    """Vertices of each polygon zone's fence outline at the mission's margin (the CTR's six
    right-angled corners take four each, in 30° chords, its two inner corners one: 26)."""
    return [len(fence_outline_m(z, mission.fence_margin_m + ROUNDING_ALLOWANCE_M))
            for z in site.polygon_zones]


def test_the_report_lists_each_polygon_fence_and_zone_clearance(site, mission):
    summary = mission_summary(mission)
    fences = summary["fence_polygons"]
    assert list(fences) == ["CTR", "PRISON"]
    assert [f["vertices"] for f in fences.values()] == _outline_sizes(site, mission)
    assert _outline_sizes(site, mission)[0] == 26
    for f in fences.values():
        assert f["area_m2"] >= f["zone_plus_margin_area_m2"]
        # rounded corners stand off at most ~1.1 margins (plus the rounding allowance)
        assert mission.fence_margin_m <= f["standoff_max_m"] <= 1.1 * mission.fence_margin_m \
            + 2 * ROUNDING_ALLOWANCE_M
    assert list(summary["nfz_clearance_by_zone_m"]) == ["MAST", "CTR", "PRISON"]
    assert summary["nfz_clearance_min_m"] == pytest.approx(
        min(summary["nfz_clearance_by_zone_m"].values()))


def test_the_waypoints_fence_holds_exclusion_vertices_with_their_count(site, mission):
    text = dumps_fence_waypoints(mission.plan)
    rows = [line.split("\t") for line in text.splitlines()[1:]]
    vertex = [r for r in rows if int(r[3]) == int(Cmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION)]
    ctr, prison = _outline_sizes(site, mission)
    assert [float(r[4]) for r in vertex] == [float(ctr)] * ctr + [float(prison)] * prison
    circles, polygons, _ = loads_fence_waypoints(text)
    assert [(p.inclusion, p.vertices_deg) for p in polygons] == [
        (p.inclusion, p.vertices_deg) for p in mission.plan.polygons]


def test_the_figures_draw_polygon_zones_and_their_buffers(site, mission):
    fig = solution_figure(mission.solution, mission)
    patches = [p for p in fig.axes[0].patches if isinstance(p, Polygon)]
    filled = [p for p in patches if p.get_fill()]
    assert len(filled) == 2 and len(patches) == 4
    assert np.allclose(filled[0].get_xy()[:-1], site.polygon_zones[0].vertices_xy_m)
    study = plot_fig3_map([mission.solution])
    assert sum(isinstance(p, Polygon) for p in study.axes[0].patches) == 4


def test_fences_too_big_for_ardupilot_take_coarser_corners_and_px4_keeps_the_fine_ones():
    from mission_planner.mission.fence import _exclusion_polygons
    from validator.autopilot.fence_storage import fits_ardupilot
    from validator.site import parse_site

    def star(cx: float, cy: float) -> list[dict[str, float]]:
        a = np.linspace(0.0, 2 * np.pi, 16, endpoint=False)
        r = np.where(np.arange(16) % 2 == 0, 40.0, 18.0)
        return [{"x": float(cx + ri * np.cos(ai)), "y": float(cy + ri * np.sin(ai))}
                for ai, ri in zip(a, r, strict=True)]

    site = parse_site({
        "name": "stars", "origin": {"lat": 37.5585, "lon": 126.999},
        "uav": {"altitude": 30.0, "max_speed": 10.0, "period": 100.0, "slots": 20},
        "radio": {"p_avg_dbm": 20.0, "p_peak_dbm": 26.0, "beta0_db": -30.0, "noise_dbm": -70.0},
        "ground_nodes": [{"name": "GN1", "x": 0.0, "y": 300.0}],
        "no_fly_zones": [{"name": f"S{i}", "polygon": star(100.0 * i, 100.0)} for i in range(2)],
    })
    fine = _exclusion_polygons(site, 1.0, circles=0, ardupilot=False)  # PX4: no such limit
    assert not fits_ardupilot([len(p.vertices_deg) for p in fine], 0, True)
    held = _exclusion_polygons(site, 1.0, circles=0, ardupilot=True)
    assert fits_ardupilot([len(p.vertices_deg) for p in held], 0, True)
    assert sum(len(p.vertices_deg) for p in held) < sum(len(p.vertices_deg) for p in fine)
    for zone, fence in zip(site.polygon_zones, held, strict=True):  # coarser, still holding
        assert _held(site.frame, fence.vertices_deg).exterior.distance(zone.shape) >= 1.0


def test_fig3_marks_legs_cutting_a_polygon_zone_and_zooms_on_it(site):
    from matplotlib.colors import to_rgba

    from mission_planner.study.plots import VIOLATION_COLOR
    from tests.mission_planner.solutions import solution_for, subdivided

    # along y = 180 the tour runs through the CTR's runway (y 150-210)
    sol = solution_for(site, subdivided([(100, 180), (500, 180), (500, 470), (100, 470)], 6),
                       scheme="conventional")
    fig = plot_fig3_map([sol])
    ax = fig.axes[0]
    red = [ln for ln in ax.lines if ln.get_color() == VIOLATION_COLOR
           or to_rgba(ln.get_color()) == to_rgba(VIOLATION_COLOR)]
    inside = [n for n, c in enumerate(sol.polygon_clearance_m[:, 0]) if c < 0]  # CTR's column
    assert len(inside) >= 3 and len(red) >= len(inside)
    titles = [a.get_title() for a in fig.axes[0].child_axes]
    assert any(t.startswith("CTR, conventional slot ") for t in titles), titles


def test_fences_too_big_even_mitred_are_coarsened_outward_until_they_fit():
    """Published airspace brings many detailed zones: when mitred corners still overflow
    ArduCopter's 70 fence items, the largest outlines lose vertices outward only."""
    from mission_planner.mission.fence import _exclusion_polygons
    from validator.autopilot.fence_storage import fits_ardupilot
    from validator.site import parse_site

    def wavy(cx: float, cy: float) -> list[dict[str, float]]:
        a = np.linspace(0.0, 2 * np.pi, 30, endpoint=False)
        r = np.where(np.arange(30) % 2 == 0, 30.0, 24.0)
        return [{"x": float(cx + ri * np.cos(ai)), "y": float(cy + ri * np.sin(ai))}
                for ai, ri in zip(a, r, strict=True)]

    site = parse_site({
        "name": "waves", "origin": {"lat": 46.95, "lon": 7.45},
        "uav": {"altitude": 30.0, "max_speed": 10.0, "period": 100.0, "slots": 20},
        "radio": {"p_avg_dbm": 20.0, "p_peak_dbm": 26.0, "beta0_db": -30.0, "noise_dbm": -70.0},
        "ground_nodes": [{"name": "GN1", "x": 0.0, "y": 300.0}],
        "no_fly_zones": [{"name": f"W{i}", "polygon": wavy(80.0 * i, 100.0)} for i in range(4)],
    })
    held = _exclusion_polygons(site, 1.0, circles=1, ardupilot=True)
    assert fits_ardupilot([len(p.vertices_deg) for p in held], 1, True)
    for zone, fence in zip(site.polygon_zones, held, strict=True):  # outward: still holding
        outline = _held(site.frame, fence.vertices_deg)
        assert outline.contains(zone.shape) and outline.exterior.distance(zone.shape) >= 1.0
