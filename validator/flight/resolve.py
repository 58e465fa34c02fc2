"""The one interpreter of a plan: :func:`resolve_flight` walks a
:class:`~validator.plan_format.Plan`'s items the way ArduCopter executes them (PX4 agrees on
everything used here) and returns the :class:`~validator.flight.model.Flight` the vehicle
flies, in the site's local east/north frame (metres), altitudes in metres above home.

Conventions:

- Items are 0-based indices of the ``.plan``'s ``mission.items``; messages name them by
  number (:func:`~validator.item_numbers.item_number`: index + 1, QGroundControl's and
  ArduPilot's seq, home being 0). A DO_JUMP's param1 is that number (a ``.plan`` names its
  target by doJumpId: read as this), so it targets index ``param1 - 1``.
- NAV_TAKEOFF climbs straight up where the vehicle is. NAV_WAYPOINT flies a straight leg and
  holds param1 seconds. DO_CHANGE_SPEED (param2 m/s, param1 0/1 = horizontal) applies at once
  and holds until changed. DO_JUMP repeats param2 times (-1: forever). RTL flies straight to
  the nearest of the rally points and the home in force (DO_SET_HOME moves it: each leg carries
  it, :mod:`.home`), then lands; LAND flies to its position (if given) and descends. Both end
  the mission, as does an unlimited loiter.
- An item without latitude and longitude (each 0 or NaN: both travel as 0) means "where the
  vehicle is"; one of them alone is refused (:mod:`.frames`, with every item's frame); an
  altitude of 0 or NaN in a waypoint means "the current altitude" (ArduPilot's rule).

What the resolution cannot model is reported as findings: unsupported navigation commands
(the vehicle's path is unknown, so clearance cannot be proven: ``violation``), unknown
commands without a position (``warning``) and notes.

The planner's metadata (:mod:`validator.flight.service`), else the mission's DO_JUMP
structure, decides which legs form the repeated service cycle.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from validator.autopilot.ardupilot import PARAMS as ARDUPILOT_PARAMS
from validator.errors import InputError
from validator.flight.bounds import MAX_MISSION_S
from validator.flight.frames import AMSL_FRAMES, TERRAIN_FRAMES, plan_refusal, unplaced
from validator.flight.home import CONDITIONS, home_finding, home_height_finding, moved_home
from validator.flight.model import CycleSpan, Finding, Flight, Home, Leg, LegKind, Severity
from validator.flight.service import ServicePlan, parse_service
from validator.item_numbers import item_label
from validator.plan_format import Autopilot, Cmd, MissionItem, Plan
from validator.site import MAX_REACH_M, Site

HOME = "plannedHomePosition"  # the plan's home, as QGroundControl's .plan names it

MAX_LEGS = 200_000  # a resolved mission longer than this is a runaway loop, not a flight
FOREVER_REPEATS = 1  # a DO_JUMP that repeats forever is resolved with this many repeats

# Commands that never move the vehicle (cameras, servos, gimbals, conditions, markers).
PASSIVE_COMMANDS: dict[int, str] = {
    112: "CONDITION_DELAY",
    114: "CONDITION_DISTANCE",
    115: "CONDITION_YAW",
    176: "DO_SET_MODE",
    181: "DO_SET_RELAY",
    182: "DO_REPEAT_RELAY",
    183: "DO_SET_SERVO",
    184: "DO_REPEAT_SERVO",
    189: "DO_LAND_START",
    195: "DO_SET_ROI_LOCATION",
    197: "DO_SET_ROI_NONE",
    200: "DO_CONTROL_VIDEO",
    201: "DO_SET_ROI",
    202: "DO_DIGICAM_CONFIGURE",
    203: "DO_DIGICAM_CONTROL",
    204: "DO_MOUNT_CONFIGURE",
    205: "DO_MOUNT_CONTROL",
    206: "DO_SET_CAM_TRIGG_DIST",
    211: "DO_GRIPPER",
    214: "DO_SET_CAM_TRIGG_INTERVAL",
    215: "DO_SET_RESUME_REPEAT_DIST",
    218: "DO_AUX_FUNCTION",
    1000: "DO_GIMBAL_MANAGER_PITCHYAW",
    2000: "IMAGE_START_CAPTURE",
    2001: "IMAGE_STOP_CAPTURE",
    2500: "VIDEO_START_CAPTURE",
    2501: "VIDEO_STOP_CAPTURE",
}
DO_SET_HOME = 179
DO_FENCE_ENABLE = 207
UNSUPPORTED_NAV: dict[int, str] = {
    30: "NAV_CONTINUE_AND_CHANGE_ALT",
    31: "NAV_LOITER_TO_ALT",
    34: "DO_ORBIT",
    82: "NAV_SPLINE_WAYPOINT",
    84: "NAV_VTOL_TAKEOFF",
    85: "NAV_VTOL_LAND",
    92: "NAV_GUIDED_ENABLE",
    94: "NAV_PAYLOAD_PLACE",
    192: "DO_REPOSITION",
}


def _command_name(command: int) -> str:
    try:
        return Cmd(command).name
    except ValueError:
        return PASSIVE_COMMANDS.get(command) or UNSUPPORTED_NAV.get(command) or f"command {command}"


@dataclass
class _State:
    xy: NDArray[np.float64]
    alt_m: float
    speed_mps: float | None
    home: Home
    airborne: bool = False


class _Resolver:
    """Walks the items once, emitting legs and findings (a program counter with jump counts)."""

    def __init__(self, plan: Plan, site: Site, source: str) -> None:
        self.plan = plan
        self.site = site
        self.source = source
        self._idx = 0  # the item being resolved, for error messages
        self.home_xy = self.local(plan.home_lat_deg, plan.home_lon_deg, HOME)
        self.state = _State(self.home_xy.copy(), 0.0, None, Home(self.home_xy.copy()))
        self.gate: tuple[int, str] | None = None  # a CONDITION_* holding back the DO items
        self.legs: list[Leg] = []
        self.findings: list[Finding] = []
        self.fence_disabled: list[int] = []
        self.pending_first: int | None = None  # first item executed since the last leg
        self.reported: set[tuple[int, str]] = set()
        self.rally_xy = [self.local(lat, lon, f"rally point {k}")
                         for k, (lat, lon, _) in enumerate(plan.rally)]

    def find(self, severity: Severity, message: str, item: int | None) -> None:
        key = (item if item is not None else -1, message)
        if key not in self.reported:  # DO_JUMP repeats must not repeat findings
            self.reported.add(key)
            self.findings.append(Finding(severity, message, item))

    # -- helpers ----------------------------------------------------------------------------
    def local(self, lat: float, lon: float, what: str) -> NDArray[np.float64]:
        """``what``'s position (degrees) in the site's frame (m); :class:`InputError` beyond
        :data:`~validator.site.MAX_REACH_M` of the origin (a plan for another site, or a home
        of 0°, 0°: a vehicle that had none yet)."""
        xy = np.asarray(self.site.frame.to_local(lat, lon), dtype=float)
        far_m = float(np.hypot(*xy))
        if far_m > MAX_REACH_M:
            why = ("0°, 0°: no home (a vehicle without one yet writes that); set it to where "
                   "the vehicle takes off" if what == HOME and lat == lon == 0.0 else
                   f"({lat:.6f}, {lon:.6f}), {far_m / 1000:,.0f} km from the origin of site "
                   f"{self.site.name!r} (beyond {MAX_REACH_M / 1000:g} km): a plan for "
                   "another site?")
            raise InputError(f"{self.source}: {what} at {why}")
        return xy

    def position(self, it: MissionItem) -> NDArray[np.float64]:
        lat, lon = it.params[4], it.params[5]
        if unplaced(it):
            return self.state.xy.copy()
        if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
            raise InputError(
                f"{self.source}: {item_label(self._idx)}: latitude/longitude ({lat}, {lon}) "
                "out of range")
        return self.local(lat, lon, item_label(self._idx))

    def altitude(self, it: MissionItem, i: int, *, zero_is_current: bool) -> float:
        alt = it.params[6]
        if math.isnan(alt) or (zero_is_current and alt == 0.0):
            return self.state.alt_m
        if it.frame in AMSL_FRAMES:
            return float(alt - self.plan.home_alt_m)
        if it.frame in TERRAIN_FRAMES:
            self.find("warning", "altitude above terrain treated as above home", i)
        return float(alt)

    def add_leg(
        self,
        i: int,
        kind: LegKind,
        end_xy: NDArray[np.float64],
        end_alt: float,
        hold_s: float = 0.0,
        loiter_radius_m: float = 0.0,
    ) -> None:
        if len(self.legs) >= MAX_LEGS:
            raise InputError(f"{self.source}: mission resolves to more than {MAX_LEGS} legs")
        if not abs(end_alt) <= MAX_REACH_M:  # its climb had a replay sample 155 TiB at 1e12 m
            raise InputError(f"{self.source}: {item_label(i)}: altitude {end_alt:g} m from home, "
                             f"beyond the {MAX_REACH_M / 1000:g} km a mission reaches")
        first = self.pending_first if self.pending_first is not None else i
        self.legs.append(
            Leg(
                item=i,
                first_item=first,
                kind=kind,
                start_xy_m=self.state.xy.copy(),
                end_xy_m=np.asarray(end_xy, dtype=float).copy(),
                start_alt_m=self.state.alt_m,
                end_alt_m=float(end_alt),
                speed_mps=self.state.speed_mps,
                hold_s=max(0.0, float(hold_s)),
                loiter_radius_m=loiter_radius_m,
                home=self.state.home,
            )
        )
        self.pending_first = None
        self.gate = None
        self.state.xy = np.asarray(end_xy, dtype=float).copy()
        self.state.alt_m = float(end_alt)

    def return_point(self) -> NDArray[np.float64]:
        """ArduCopter RTL goes to the nearest of the home in force and the rally points."""
        candidates = [self.state.home.xy_m, *self.rally_xy]
        d = [float(np.hypot(*(c - self.state.xy))) for c in candidates]
        return candidates[int(np.argmin(d))]

    # -- the walk ---------------------------------------------------------------------------
    def run(self) -> None:
        items = self.plan.items
        jumps_done: dict[int, int] = {}
        pc = 0
        while pc < len(items):
            self._idx = pc
            it = items[pc]
            if self.pending_first is None:
                self.pending_first = pc
            cmd = it.command
            nxt = pc + 1
            if cmd == Cmd.DO_JUMP:
                nxt = self.jump(pc, it, jumps_done)
                if nxt != pc + 1:
                    self.pending_first = None  # the leg after a jump starts at its target
            elif cmd == Cmd.DO_CHANGE_SPEED:
                self.change_speed(pc, it)
            elif cmd == Cmd.NAV_TAKEOFF:
                alt = self.altitude(it, pc, zero_is_current=False)
                if alt <= 0:
                    self.find("violation", f"takeoff altitude {alt:g} m is not above home", pc)
                self.add_leg(pc, "takeoff", self.state.xy, max(alt, self.state.alt_m))
                self.state.airborne = True
            elif cmd in (Cmd.NAV_WAYPOINT, Cmd.NAV_LOITER_TIME):
                self.waypoint(pc, it)
            elif cmd == Cmd.NAV_LOITER_TURNS:
                self.loiter_turns(pc, it)
            elif cmd == Cmd.NAV_LOITER_UNLIM:
                self.add_leg(pc, "loiter", self.position(it),
                             self.altitude(it, pc, zero_is_current=True))
                self.find("note", "the mission ends in an unlimited loiter here", pc)
                break
            elif cmd == Cmd.NAV_RETURN_TO_LAUNCH:
                self.add_leg(pc, "rtl", self.return_point(), self.state.alt_m)
                self.add_leg(pc, "land", self.state.xy, 0.0)
                break
            elif cmd == Cmd.NAV_LAND:
                target = self.position(it)
                if np.hypot(*(target - self.state.xy)) > 0.01:
                    self.add_leg(pc, "waypoint", target, self.state.alt_m)
                self.add_leg(pc, "land", target, 0.0)
                break
            elif cmd == Cmd.NAV_DELAY:
                delay = it.params[0]
                if math.isnan(delay) or delay < 0:
                    self.find("warning", "NAV_DELAY until a time of day: not modelled", pc)
                    delay = 0.0
                self.add_leg(pc, "waypoint", self.state.xy, self.state.alt_m, hold_s=delay)
            elif cmd == DO_SET_HOME:
                self.set_home(pc, it)
            elif cmd == DO_FENCE_ENABLE:
                if it.params[0] == 0:
                    self.fence_disabled.append(pc)
                    self.find("violation", "DO_FENCE_ENABLE disables the geofence", pc)
            elif cmd in PASSIVE_COMMANDS:
                if cmd in CONDITIONS:
                    self.gate = (pc, CONDITIONS[cmd])
            elif cmd in UNSUPPORTED_NAV or 16 <= cmd < 100:
                self.unsupported_nav(pc, it)
            elif cmd in (
                Cmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                Cmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
                Cmd.NAV_FENCE_CIRCLE_INCLUSION,
                Cmd.NAV_FENCE_CIRCLE_EXCLUSION,
                Cmd.NAV_RALLY_POINT,
            ):
                self.find("warning", f"{_command_name(cmd)} in the mission list is ignored; "
                          "fences and rally points belong in geoFence/rallyPoints", pc)
            else:
                self.find("warning", f"unknown command {cmd}: ignored (assumed not to move "
                          "the vehicle)", pc)
            pc = nxt
        else:
            if self.legs and self.legs[-1].kind not in ("land", "rtl", "loiter"):
                self.find("note", "the mission ends without RTL or LAND: the vehicle hovers "
                          "at its last waypoint", len(items) - 1)

    def jump(self, pc: int, it: MissionItem, done: dict[int, int]) -> int:
        target = it.params[0]
        repeats = it.params[1]
        if math.isnan(target) or int(target) != target or not 1 <= target <= len(self.plan.items):
            raise InputError(
                f"{self.source}: {item_label(pc)} (DO_JUMP): target {target:g} is not an item "
                f"(1..{len(self.plan.items)})"
            )
        t = int(target) - 1
        if math.isnan(repeats):
            repeats = 0.0
        if repeats < 0:
            endurance = self.site.endurance_s
            if endurance is None:
                self.find("warning", f"DO_JUMP repeats forever; resolved with "
                          f"{FOREVER_REPEATS} repeat(s)", pc)
            else:  # had passed the endurance check on the one repeat it was resolved with
                self.find("violation", f"DO_JUMP repeats forever: the mission flies until a "
                          f"failsafe ends it, beyond the UAV's endurance of {endurance:g} s "
                          f"(uav.endurance); give it a count (resolved with "
                          f"{FOREVER_REPEATS} repeat(s))", pc)
            repeats = FOREVER_REPEATS
        count = done.get(pc, 0)
        if count < int(repeats):
            done[pc] = count + 1  # like ArduPilot, counts are kept for the whole mission
            return t
        return pc + 1

    def change_speed(self, pc: int, it: MissionItem) -> None:
        kind, speed = it.params[0], it.params[1]
        if math.isnan(speed) or speed <= 0:
            return  # -1 (or 0) means "no change"
        if kind in (2, 3):
            self.find("note", "climb/descent speed change: ignored by the horizontal model", pc)
            return
        self.state.speed_mps = float(speed)

    def waypoint(self, pc: int, it: MissionItem) -> None:
        hold = it.params[0] if not math.isnan(it.params[0]) else 0.0
        if not self.state.airborne:
            self.find("warning", "waypoint before any takeoff: assumed airborne", pc)
            self.state.airborne = True
        self.add_leg(pc, "waypoint", self.position(it),
                     self.altitude(it, pc, zero_is_current=True), hold_s=hold)

    def set_home(self, pc: int, it: MissionItem) -> None:
        """DO_SET_HOME: the home later legs return to, if known (:mod:`validator.flight.home`)."""
        home, unknown = moved_home(it, pc, self.plan.firmware_type == Autopilot.PX4,
                                   here_xy_m=self.state.xy, here_alt_m=self.state.alt_m,
                                   home=self.state.home, plan_home_amsl_m=self.plan.home_alt_m,
                                   item_xy_m=lambda: self.position(it))
        if home is None:
            self.find("violation", unknown, pc)
            return
        if (height := home_height_finding(self.state.home, home)) is not None:
            self.find(*height, pc)
        self.state.home = home
        self.find(*home_finding(self.site, home.xy_m), pc)
        if self.gate is not None:
            self.find("warning", f"DO_SET_HOME waits for {self.gate[1]} "
                      f"({item_label(self.gate[0])}): home moves once it is met, never if the "
                      "next waypoint comes first; the audit moves it at the leg's start", pc)

    def loiter_turns(self, pc: int, it: MissionItem) -> None:
        turns = abs(it.params[0]) if not math.isnan(it.params[0]) else 1.0
        radius = abs(it.params[2]) if not math.isnan(it.params[2]) else 0.0
        default = ""
        if radius == 0 and self.plan.firmware_type == Autopilot.ARDUPILOTMEGA:
            # ArduCopter keeps its circle's radius for a 0 (ModeAuto::circle_movetoedge_start):
            # CIRCLE_RADIUS, 10 m by default, not a hover at the centre
            spec = ARDUPILOT_PARAMS["CIRCLE_RADIUS"]
            radius = spec.default * spec.to_si
            default = " (radius 0: ArduCopter's CIRCLE_RADIUS default)"
        speed = self.state.speed_mps or self.site.max_speed_mps
        hold = turns * 2.0 * math.pi * radius / speed if radius > 0 else 0.0
        self.find("note", f"LOITER_TURNS: a {radius:g} m circle{default}, replayed as a "
                  f"{hold:.1f} s hold at its centre", pc)
        self.add_leg(pc, "loiter", self.position(it),
                     self.altitude(it, pc, zero_is_current=True), hold_s=hold,
                     loiter_radius_m=radius)

    def unsupported_nav(self, pc: int, it: MissionItem) -> None:
        name = _command_name(it.command)
        self.find("violation", f"{name} is not supported: its path cannot be verified "
                  "(replayed as a straight leg)", pc)
        self.add_leg(pc, "waypoint", self.position(it),
                     self.altitude(it, pc, zero_is_current=True))


def _mark_pass_through(legs: list[Leg]) -> list[Leg]:
    """A leg may blend into the next one when it has no hold and both are waypoint legs.

    Not into a LAND's approach (a waypoint leg followed by the land leg of the same item):
    ArduCopter queues only a waypoint or loiter as the next destination, so it stops first.
    """
    out = []
    for i, leg in enumerate(legs):
        nxt = legs[i + 1] if i + 1 < len(legs) else None
        after = legs[i + 2] if i + 2 < len(legs) else None
        approach = (nxt is not None and after is not None and after.kind == "land"
                    and after.item == nxt.item)
        blend = (
            nxt is not None
            and leg.hold_s == 0.0
            and leg.kind == "waypoint"
            and nxt.kind in ("waypoint", "loiter")
            and not approach
        )
        out.append(dataclasses.replace(leg, pass_through=blend))
    return out


def _cycle_from_metadata(legs: tuple[Leg, ...], service: ServicePlan) -> CycleSpan | None:
    first, last = service.cycle_items
    start = next((k for k, leg in enumerate(legs) if leg.first_item <= first <= leg.item), None)
    ends = [k for k, leg in enumerate(legs) if leg.item == last]
    if start is None or not ends or ends[-1] < start:
        return None
    return CycleSpan(start, legs[start].item == first, ends[-1], service.cycles, "metadata")


def _cycle_from_plan(plan: Plan, legs: tuple[Leg, ...]) -> CycleSpan | None:
    jumps = [
        (i, int(it.params[1]) if not math.isnan(it.params[1]) else 0, int(it.params[0]) - 1)
        for i, it in enumerate(plan.items)
        if it.command == Cmd.DO_JUMP and not math.isnan(it.params[0])
    ]
    for i, repeats, target in jumps:
        if target >= i:
            continue
        inside = [k for k, leg in enumerate(legs) if target <= leg.item < i]
        if not inside:
            continue
        cycles = (repeats if repeats >= 0 else FOREVER_REPEATS) + 1
        return CycleSpan(inside[0], False, inside[-1], cycles, "jump")
    wps = [k for k, leg in enumerate(legs) if leg.kind == "waypoint"]
    if len(wps) < 2:
        return None
    return CycleSpan(wps[0], True, wps[-1], 1, "waypoints")


def resolve_flight(plan: Plan, site: Site, source: str = "plan") -> Flight:
    """Resolve ``plan`` into the :class:`Flight` the vehicle will fly over ``site``.

    Raises :class:`InputError` for missions no autopilot would accept (a DO_JUMP to nowhere,
    coordinates out of range, runaway jumps), for an item the plan's autopilot would refuse
    or misplace for its frame (:func:`~.frames.plan_refusal`), and for malformed planner
    metadata.
    """
    refused = plan_refusal(plan.items, plan.firmware_type == Autopilot.PX4)
    if refused is not None:
        raise InputError(f"{source}: {refused}")
    service = parse_service(plan.extra, site, source)
    if service is not None and service.cycle_items[1] >= len(plan.items):
        last = service.cycle_items[1]  # a 0-based index, as the file holds it
        raise InputError(f"{source}.nfzMission.cycle_items: index {last} "
                         f"({item_label(last)}) does not exist ({len(plan.items)} items)")
    r = _Resolver(plan, site, source)
    r.run()
    if not r.legs:
        r.find("warning", "the mission has no navigation items", None)
    legs = tuple(_mark_pass_through(r.legs))
    cycle = _cycle_from_metadata(legs, service) if service is not None else None
    if service is not None and cycle is None:
        r.find("warning", f"nfzMission.cycle_items {list(service.cycle_items)} do not match "
               "the mission's items", None)
    if service is not None:
        if service.site_name and service.site_name != site.name:
            r.find("warning", f"the plan was made for site {service.site_name!r}, "
                   f"not {site.name!r}", None)
    if cycle is None:
        cycle = _cycle_from_plan(plan, legs)
    flight = Flight(
        legs=legs,
        home_xy_m=r.home_xy,
        firmware_type=plan.firmware_type,
        findings=tuple(r.findings),
        cycle=cycle,
        service=service,
        fence_disabled_at=tuple(r.fence_disabled),
        source=source,
    )
    check_duration(flight)
    return flight


def check_duration(flight: Flight) -> None:
    """:class:`InputError` for a mission whose holds and legs at their commanded speeds alone
    (a lower bound: the vehicle flies no faster) take over :data:`MAX_MISSION_S`, naming the
    leg that takes longest."""
    each = [leg.hold_s + (leg.length_m / leg.speed_mps if leg.speed_mps else 0.0)
            for leg in flight.legs]
    total_s = sum(each)
    if total_s <= MAX_MISSION_S:
        return
    k = max(range(len(each)), key=each.__getitem__)
    leg = flight.legs[k]
    how = (f"a {leg.hold_s:g} s hold" if leg.hold_s >= each[k] / 2 else
           f"{leg.length_m:.0f} m at {leg.speed_mps:g} m/s")
    over = f"{total_s:,.0f}" if total_s < 1e9 else f"{total_s:.2e}"
    raise InputError(f"{flight.source}: {item_label(leg.item)}: {how}: the mission would fly over "
                     f"{over} s, beyond a day ({MAX_MISSION_S:g} s)")
