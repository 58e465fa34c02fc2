"""The site file: origin, ground nodes, no-fly zones, UAV and radio parameters.

A site file is YAML of this shape (see ``samples/paper-default.yaml``)::

    name: paper-default
    origin: {lat: 37.5585, lon: 126.999, alt: 40.0}   # WGS84; alt = ground AMSL, m
    home: {x: 0.0, y: 0.0}                            # optional, default: the origin
    uav: {altitude: 30.0, max_speed: 30.0, period: 50.0, slots: 50}
                              # optional: max_accel, max_jerk, endurance (s, take-off to
                              # landing with the reserve)
    radio: {p_avg_dbm: 20.0, p_peak_dbm: 26.0206, beta0_db: -30.0, noise_dbm: -70.0}
    ground_nodes:
      - {name: GN1, x: 60.0, y: 340.0}            # metres east/north of origin ...
      - {name: GN2, lat: 37.5590, lon: 127.0001}  # ... or WGS84 degrees
    no_fly_zones:
      - {name: NFZ1, x: 150.0, y: 200.0, radius: 30.0}   # a circle ...
      - name: CTR                                      # ... or a polygon (x/y or lat/lon)
        polygon: [{x: 0, y: 0}, {x: 120, y: 0}, {x: 120, y: 40}, {x: 0, y: 40}]
    airspace: zones.geojson   # optional: more zones, relative to this file: GeoJSON, ED-269
                              # or ED-318 (validator.site_airspace), one file or a list
    safety: {buffer_m: 2.0}
    wind: {speed_mps: 6.0, from_deg: 270.0, turbulence_mps: 1.5}   # optional: validator.wind

:func:`load_site` validates it with pydantic and resolves it into a :class:`Site` in SI units
and local metres. Every mistake raises :class:`~validator.errors.InputError` naming the field:
numbers must be finite (no ``.nan`` / ``.inf``), the file at most 4 MiB, and a site at most
``MAX_NODES`` ground nodes and zones and ``MAX_SLOTS`` slots (see
:mod:`validator.input_files` for the limits every reader shares).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import shapely
from numpy.typing import NDArray
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, ValidationError, model_validator

from validator.autopilot.ardupilot import PARAMS as ARDUPILOT_PARAMS
from validator.autopilot.spec import MIN_ACCEL_MPS2, MIN_JERK_MPS3
from validator.channel import db_to_linear, dbm_to_w
from validator.errors import InputError
from validator.geodesy import LocalFrame, check_latitude
from validator.input_files import MAX_SITE_BYTES, check_tree, parse_yaml, read_text
from validator.model_errors import first_error
from validator.site_airspace import SiteAirspace, airspace_paths, site_airspace
from validator.uas_zones.applicability import AirspaceOptions, Band
from validator.wind import Wind, WindModel
from validator.zones import (
    MAX_VERTICES,
    PolygonZone,
    buffer_intrusion,
    point_clearance_m,
    polygon_zone,
)

DEFAULT_BUFFER_M = 2.0
# A site without uav limits gets ArduCopter's defaults, read from its one parameter table.
_ACCEL, _JERK = ARDUPILOT_PARAMS["WPNAV_ACCEL"], ARDUPILOT_PARAMS["WPNAV_JERK"]
DEFAULT_MAX_ACCEL_MPS2 = _ACCEL.default * _ACCEL.to_si  # 2.5
DEFAULT_MAX_JERK_MPS3 = _JERK.default * _JERK.to_si  # 1.0
# Size limits, far above any site the planner can solve, so a typo cannot exhaust memory:
MAX_SLOTS = 10_000  # a mission holds at most 65535 items (MAVLink's uint16 count)
MAX_NODES = 1_000  # ground nodes, and no-fly zones
# Bounds on every number, far beyond any UAV site, so that every derived value stays finite:
MAX_DISTANCE_M = 1e6  # local x/y, radii and buffer: 1000 km
MAX_ALT_M = 1e5
MAX_SPEED_MPS = 1e3
MAX_PERIOD_S = 1e7
MAX_ACCEL_MPS2 = 1e3
MAX_JERK_MPS3 = 1e4
MAX_DB = 300.0  # |dBm| and |dB| of the radio figures
# No multicopter mission reaches this far from its site's origin (m): home, a node or a plan's
# position beyond it is a typo or a plan for another site, and a leg thousands of km long
# would exhaust the memory (replay samples, depth steps)
MAX_REACH_M = 100_000.0


class _Strict(BaseModel):
    # NaN and infinities are refused everywhere (YAML's .nan / .inf parse as floats).
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False, strict=True)


class OriginModel(_Strict):
    lat: Annotated[float, AfterValidator(check_latitude)] = Field(ge=-90, le=90)
    lon: float = Field(ge=-180, le=180)
    alt: float = Field(default=0.0, ge=-MAX_ALT_M, le=MAX_ALT_M)


def _check_one_way(x: float | None, y: float | None, lat: float | None,
                   lon: float | None) -> None:
    local = x is not None or y is not None
    geo = lat is not None or lon is not None
    if local and geo:
        raise ValueError("give the position either as x/y or as lat/lon, not both")
    if local and (x is None or y is None):
        raise ValueError("give both x and y")
    if geo and (lat is None or lon is None):
        raise ValueError("give both lat and lon")
    if not (local or geo):
        raise ValueError("give the position as x/y or as lat/lon")


class PointModel(_Strict):
    """A point given either as local metres (x, y) or as WGS84 degrees (lat, lon)."""

    x: float | None = Field(default=None, ge=-MAX_DISTANCE_M, le=MAX_DISTANCE_M)
    y: float | None = Field(default=None, ge=-MAX_DISTANCE_M, le=MAX_DISTANCE_M)
    lat: float | None = Field(default=None, ge=-90, le=90)
    lon: float | None = Field(default=None, ge=-180, le=180)

    @model_validator(mode="after")
    def _one_way(self) -> PointModel:
        _check_one_way(self.x, self.y, self.lat, self.lon)
        return self


class GroundNodeModel(PointModel):
    name: str = Field(min_length=1)


class NoFlyZoneModel(_Strict):
    """A circle (centre as a point, and a radius) or a polygon (its vertices as points)."""

    name: str = Field(min_length=1)
    x: float | None = Field(default=None, ge=-MAX_DISTANCE_M, le=MAX_DISTANCE_M)
    y: float | None = Field(default=None, ge=-MAX_DISTANCE_M, le=MAX_DISTANCE_M)
    lat: float | None = Field(default=None, ge=-90, le=90)
    lon: float | None = Field(default=None, ge=-180, le=180)
    radius: float | None = Field(default=None, gt=0, le=MAX_DISTANCE_M, description="m")
    polygon: list[PointModel] | None = Field(default=None, max_length=MAX_VERTICES)

    @model_validator(mode="after")
    def _circle_or_polygon(self) -> NoFlyZoneModel:
        if self.polygon is not None:
            if any(v is not None for v in (self.x, self.y, self.lat, self.lon, self.radius)):
                raise ValueError("a polygon zone takes no x/y/lat/lon/radius: give either a "
                                 "circle or a polygon")
            if len(self.polygon) < 3:
                raise ValueError(f"a polygon needs at least 3 vertices, got {len(self.polygon)}")
            return self
        if self.radius is None:
            raise ValueError("give a circle (x/y or lat/lon, and radius) or a polygon")
        _check_one_way(self.x, self.y, self.lat, self.lon)
        return self


class UavModel(_Strict):
    altitude: float = Field(gt=0, le=MAX_ALT_M, description="flight altitude H above ground, m")
    max_speed: float = Field(gt=0, le=MAX_SPEED_MPS,
                             description="the vehicle's real top speed V, m/s")
    period: float = Field(gt=0, le=MAX_PERIOD_S, description="service period T, s")
    slots: int = Field(gt=0, le=MAX_SLOTS, description="number of time slots N")
    max_accel: float = Field(default=DEFAULT_MAX_ACCEL_MPS2, ge=MIN_ACCEL_MPS2, le=MAX_ACCEL_MPS2,
                             description="m/s^2")
    max_jerk: float = Field(default=DEFAULT_MAX_JERK_MPS3, ge=MIN_JERK_MPS3, le=MAX_JERK_MPS3,
                            description="m/s^3")
    endurance: float | None = Field(default=None, gt=0, le=MAX_PERIOD_S,
                                    description="flight time from take-off until the vehicle "
                                    "must be on the ground with its landing reserve, s")


class RadioModel(_Strict):
    p_avg_dbm: float = Field(ge=-MAX_DB, le=MAX_DB)
    p_peak_dbm: float = Field(ge=-MAX_DB, le=MAX_DB)
    beta0_db: float = Field(ge=-MAX_DB, le=MAX_DB)
    noise_dbm: float = Field(ge=-MAX_DB, le=MAX_DB)

    @model_validator(mode="after")
    def _peak_above_avg(self) -> RadioModel:
        if self.p_peak_dbm < self.p_avg_dbm:
            raise ValueError("p_peak_dbm must not be below p_avg_dbm")
        return self


class SafetyModel(_Strict):
    buffer_m: float = Field(default=DEFAULT_BUFFER_M, ge=0, le=MAX_DISTANCE_M)


class SiteModel(_Strict):
    """The site file exactly as written (pydantic schema)."""

    name: str = Field(min_length=1)
    origin: OriginModel
    home: PointModel | None = None
    uav: UavModel
    radio: RadioModel
    ground_nodes: list[GroundNodeModel] = Field(min_length=1, max_length=MAX_NODES)
    no_fly_zones: list[NoFlyZoneModel] = Field(default_factory=list, max_length=MAX_NODES)
    airspace: str | list[str] | None = Field(
        default=None, min_length=1, description="airspace file(s) of more zones, beside the site")
    safety: SafetyModel = Field(default_factory=SafetyModel)
    wind: WindModel | None = None  # the forecast (validator.wind); none: still air


@dataclass(frozen=True)
class Site:
    """A validated site in SI units, positions in metres east/north of the origin.

    Arrays: ``gn_xy_m`` is (K, 2), ``nfz_xy_m`` is (M, 2), ``nfz_radius_m`` is (M,): the M
    circle zones. ``polygon_zones`` are the polygon zones, in file order after the circles (the
    site file's, then the airspace file's). Zones are as published; planning adds ``buffer_m``.
    ``airspace`` says which UAS zones within reach were taken and why (the report's table).
    """

    name: str
    frame: LocalFrame
    home_xy_m: NDArray[np.float64]
    altitude_m: float
    max_speed_mps: float
    period_s: float
    slots: int
    max_accel_mps2: float
    max_jerk_mps3: float
    p_avg_w: float
    p_peak_w: float
    beta0: float  # linear channel power gain at 1 m
    noise_w: float
    gn_names: tuple[str, ...]
    gn_xy_m: NDArray[np.float64]
    nfz_names: tuple[str, ...]
    nfz_xy_m: NDArray[np.float64]
    nfz_radius_m: NDArray[np.float64]
    buffer_m: float = DEFAULT_BUFFER_M
    polygon_zones: tuple[PolygonZone, ...] = ()
    airspace: SiteAirspace = SiteAirspace()
    wind: Wind | None = None  # the forecast the plan is made for; None: still air
    endurance_s: float | None = None  # take-off to landing with the reserve; None: unchecked

    @property
    def flight_wind(self) -> Wind | None:
        """The wind at the flight altitude (one layer), None in still air."""
        return None if self.wind is None or self.wind.calm else self.wind.at(self.altitude_m)

    @property
    def num_gns(self) -> int:
        return len(self.gn_names)

    @property
    def num_nfzs(self) -> int:
        """The number of circle zones."""
        return len(self.nfz_names)

    @property
    def zone_names(self) -> tuple[str, ...]:
        """Every zone's name: the circles, then the polygons."""
        return self.nfz_names + tuple(z.name for z in self.polygon_zones)

    @property
    def planning_radius_m(self) -> NDArray[np.float64]:
        """NFZ radii plus the safety buffer: the zones the planner keeps every leg out of."""
        return self.nfz_radius_m + self.buffer_m

    def with_buffer(self, buffer_m: float) -> Site:
        """The same site with another safety buffer (m), re-checked."""
        if not 0 <= buffer_m <= MAX_DISTANCE_M:  # (NaN too) the schema's bound on a buffer
            raise InputError(f"buffer_m: must be >= 0 and <= {MAX_DISTANCE_M:g} m, got {buffer_m}")
        site = dataclasses.replace(self, buffer_m=float(buffer_m))
        _check_home_clear(site, "buffer_m")
        return site

    def with_limits(self, **changes: Any) -> Site:
        """The same site with other UAV or radio numbers (``dataclasses.replace`` fields)."""
        return dataclasses.replace(self, **changes)

    def with_forecast(self, wind: Wind | None) -> Site:
        """The site in the day's forecast ``wind``, which overrides its own ``wind:`` (a calm
        one: still air); None keeps the site's (plan-mission's ``--wind``)."""
        if wind is None:
            return self
        return self.with_limits(wind=None if wind.calm else wind)


def _resolve(frame: LocalFrame, p: PointModel | NoFlyZoneModel) -> NDArray[np.float64]:
    if p.x is not None and p.y is not None:
        return np.array([p.x, p.y], dtype=float)
    assert p.lat is not None and p.lon is not None
    return frame.to_local(p.lat, p.lon)


def _check_home_clear(site: Site, field: str) -> None:
    inside = buffer_intrusion(site, site.home_xy_m)
    if inside:
        raise InputError(f"{field}: home lies inside {inside}")


@dataclass(frozen=True)
class _Zone:
    """A zone being read, with where it was written (for error messages)."""

    where: str
    name: str
    centre_m: NDArray[np.float64] | None = None  # a circle ...
    radius_m: float = 0.0
    polygon: PolygonZone | None = None  # ... or a polygon


def _site_zones(model: SiteModel, frame: LocalFrame, source: str, base_file: str | Path | None,
                points_m: NDArray[np.float64], options: AirspaceOptions | None
                ) -> tuple[list[_Zone], SiteAirspace]:
    zones = []
    for i, z in enumerate(model.no_fly_zones):
        where = f"{source}: no_fly_zones[{i}] ({z.name})"
        if z.polygon is not None:
            verts = [_resolve(frame, v) for v in z.polygon]
            zones.append(_Zone(where, z.name, polygon=polygon_zone(z.name, verts,
                                                                   f"{where}.polygon")))
        else:
            zones.append(_Zone(where, z.name, _resolve(frame, z), float(z.radius or 0.0)))
    paths = airspace_paths(model.airspace, base_file, source)
    buffer_m = (options or AirspaceOptions()).buffer_or(model.safety.buffer_m)
    band = Band(model.uav.altitude + buffer_m, model.origin.alt)
    air = site_airspace(paths, frame, points_m, band, options)
    for a in air.shapes:
        if a.vertices_m is not None:
            zones.append(_Zone(a.where, a.name, polygon=polygon_zone(a.name, a.vertices_m,
                                                                     a.where)))
        else:
            zones.append(_Zone(a.where, a.name, a.centre_m, a.radius_m))
    return zones, air


def _check_zones(zones: list[_Zone], model: SiteModel, gn_xy: NDArray[np.float64],
                 source: str) -> None:
    """Names unique, no two zones overlapping (touching is allowed), no ground node inside."""
    seen: dict[str, str] = {}
    for z in zones:
        if z.name in seen:
            raise InputError(f"{z.where}: duplicate zone name (also {seen[z.name]})")
        seen[z.name] = z.where
    for j, zj in enumerate(zones):
        for i in range(j):
            if _overlap(zones[i], zj):
                raise InputError(f"{zj.where}: overlaps {zones[i].name}")
    for k, g in enumerate(model.ground_nodes):
        for z in zones:
            if z.polygon is not None:
                inside = float(point_clearance_m(z.polygon, gn_xy[k])) < 0.0
            else:
                assert z.centre_m is not None
                inside = bool(np.linalg.norm(gn_xy[k] - z.centre_m) < z.radius_m)
            if inside:
                raise InputError(f"{source}: ground_nodes[{k}] ({g.name}): lies inside {z.name}")


def _overlap(a: _Zone, b: _Zone) -> bool:
    """Whether two zones share interior (touching is allowed), exactly for circles too."""
    if a.polygon is not None and b.polygon is not None:
        return bool(shapely.intersection(a.polygon.shape, b.polygon.shape).area > 0.0)
    if a.polygon is None and b.polygon is None:
        assert a.centre_m is not None and b.centre_m is not None
        return bool(np.linalg.norm(a.centre_m - b.centre_m) < a.radius_m + b.radius_m)
    poly, circle = (a, b) if a.polygon is not None else (b, a)
    assert poly.polygon is not None and circle.centre_m is not None
    return float(shapely.distance(poly.polygon.shape, shapely.Point(circle.centre_m))) \
        < circle.radius_m


def parse_site(data: object, source: str = "site", *, base_file: str | Path | None = None,
               airspace: AirspaceOptions | None = None) -> Site:
    """Validate a site given as a parsed YAML mapping and resolve it into a :class:`Site`.

    ``base_file`` is the site file, from whose folder an ``airspace:`` file is read;
    ``airspace`` the time, duration and authorisations its UAS zones are decided for."""
    if not isinstance(data, dict):
        raise InputError(f"{source}: expected a mapping at the top level")
    check_tree(data, source)
    try:
        model = SiteModel.model_validate(data)
    except ValidationError as err:
        raise InputError(f"{source}: {first_error(err, data, root='site')}") from None
    return site_from_model(model, source, base_file=base_file, airspace=airspace)


def site_from_model(model: SiteModel, source: str = "site", *,
                    base_file: str | Path | None = None,
                    airspace: AirspaceOptions | None = None) -> Site:
    """Resolve a validated :class:`SiteModel`; checks relations between items."""
    frame = LocalFrame(model.origin.lat, model.origin.lon, model.origin.alt)
    gn_xy = np.array([_resolve(frame, g) for g in model.ground_nodes], dtype=float)
    home = _resolve(frame, model.home) if model.home else np.zeros(2)
    for where, xy in [("home", home), *((f"ground_nodes[{i}] ({g.name})", gn_xy[i])
                                         for i, g in enumerate(model.ground_nodes))]:
        if np.hypot(*xy) > MAX_REACH_M:
            raise InputError(f"{source}: {where}: {np.hypot(*xy) / 1000:,.0f} km from the "
                             f"origin, beyond the {MAX_REACH_M / 1000:g} km a mission reaches")
    seen: set[str] = set()
    for i, g in enumerate(model.ground_nodes):
        if g.name in seen:
            raise InputError(f"{source}: ground_nodes[{i}] ({g.name}): duplicate name")
        seen.add(g.name)
    zones, air = _site_zones(model, frame, source, base_file, np.vstack([home, gn_xy]), airspace)
    _check_zones(zones, model, gn_xy, source)
    circles = [z for z in zones if z.polygon is None]
    site = Site(
        name=model.name,
        frame=frame,
        home_xy_m=home,
        altitude_m=model.uav.altitude,
        max_speed_mps=model.uav.max_speed,
        period_s=model.uav.period,
        slots=model.uav.slots,
        max_accel_mps2=model.uav.max_accel,
        max_jerk_mps3=model.uav.max_jerk,
        p_avg_w=dbm_to_w(model.radio.p_avg_dbm),
        p_peak_w=dbm_to_w(model.radio.p_peak_dbm),
        beta0=db_to_linear(model.radio.beta0_db),
        noise_w=dbm_to_w(model.radio.noise_dbm),
        gn_names=tuple(g.name for g in model.ground_nodes),
        gn_xy_m=gn_xy,
        nfz_names=tuple(z.name for z in circles),
        nfz_xy_m=np.array([z.centre_m for z in circles], dtype=float).reshape(-1, 2),
        nfz_radius_m=np.array([z.radius_m for z in circles], dtype=float),
        buffer_m=model.safety.buffer_m,
        polygon_zones=tuple(z.polygon for z in zones if z.polygon is not None),
        airspace=air,
        wind=Wind.from_model(model.wind) if model.wind is not None else None,
        endurance_s=model.uav.endurance,
    )
    _check_home_clear(site, f"{source}: home")
    return site


def load_site(path: str | Path, airspace: AirspaceOptions | None = None) -> Site:
    """Read, validate and resolve a site YAML file (limits: :mod:`validator.input_files`;
    ``airspace``: see :func:`parse_site`)."""
    path = Path(path)
    return loads_site(read_text(path, "site", MAX_SITE_BYTES), str(path), base_file=path,
                      airspace=airspace)


def loads_site(text: str, source: str = "site", *, base_file: str | Path | None = None,
               airspace: AirspaceOptions | None = None) -> Site:
    """Parse, validate and resolve site YAML text (``base_file``, ``airspace``: see
    :func:`parse_site`)."""
    return parse_site(parse_yaml(text, source), source, base_file=base_file, airspace=airspace)


def site_to_dict(site: Site) -> dict[str, object]:
    """A site file mapping (local x/y points) that :func:`parse_site` reads back to ``site``."""

    def dbm(w: float) -> float:
        return float(10.0 * np.log10(w) + 30.0)

    return {
        "name": site.name,
        "origin": {
            "lat": site.frame.lat0_deg,
            "lon": site.frame.lon0_deg,
            "alt": site.frame.alt0_m,
        },
        "home": {"x": float(site.home_xy_m[0]), "y": float(site.home_xy_m[1])},
        "uav": {
            "altitude": site.altitude_m,
            "max_speed": site.max_speed_mps,
            "period": site.period_s,
            "slots": site.slots,
            "max_accel": site.max_accel_mps2,
            "max_jerk": site.max_jerk_mps3,
            **({"endurance": site.endurance_s} if site.endurance_s is not None else {}),
        },
        "radio": {
            "p_avg_dbm": dbm(site.p_avg_w),
            "p_peak_dbm": dbm(site.p_peak_w),
            "beta0_db": float(10.0 * np.log10(site.beta0)),
            "noise_dbm": dbm(site.noise_w),
        },
        "ground_nodes": [
            {"name": n, "x": float(x), "y": float(y)}
            for n, (x, y) in zip(site.gn_names, site.gn_xy_m, strict=True)
        ],
        "no_fly_zones": [
            {"name": n, "x": float(x), "y": float(y), "radius": float(r)}
            for n, (x, y), r in zip(site.nfz_names, site.nfz_xy_m, site.nfz_radius_m, strict=True)
        ] + [
            {"name": z.name, "polygon": [{"x": float(x), "y": float(y)} for x, y in
                                         z.vertices_xy_m]}
            for z in site.polygon_zones
        ],
        "safety": {"buffer_m": site.buffer_m},
        **({"wind": site.wind.to_dict()} if site.wind is not None else {}),
    }
