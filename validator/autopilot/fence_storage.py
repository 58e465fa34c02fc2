"""Whether a plan's geofence fits in the autopilot's fence storage.

ArduCopter 4.5 keeps the fence in a storage area of its own (``StorageManager``: 48 + 256 + 256
= 560 bytes for copters on boards with 16 kB or more of storage, and in SITL), written by
``AC_PolyFence_loader::write_fence``: a 4-byte header, then per polygon a type byte, a vertex
count byte and 8 bytes (int32 lat, lon) per vertex, per circle a type byte and 12 bytes
(radius, lat, lon), the return point a type byte and 8 bytes, and an end-of-storage byte. The
mission protocol also refuses more fence items than ``max_items()``, min(255, bytes / 8) = 70.
A fence that does not fit is refused by the vehicle (\"Fence exceeds storage size\"), so it is
refused here first, before any upload. PX4 keeps the fence in its dataman file, with room for
far more than a site holds.
"""

from __future__ import annotations

from validator.plan_format import Plan

ARDUPILOT_FENCE_BYTES = 560
ARDUPILOT_FENCE_ITEMS = min(255, ARDUPILOT_FENCE_BYTES // 8)
MAX_POLYGON_VERTICES = 255  # the vertex count travels in a uint8


def ardupilot_fence_bytes(plan: Plan) -> int:
    """Bytes of ArduCopter's fence storage ``plan``'s fence takes (see the module doc)."""
    return fence_bytes([len(p.vertices_deg) for p in plan.polygons], len(plan.circles),
                       plan.breach_return is not None)


def fence_bytes(polygon_vertices: list[int], circles: int, return_point: bool) -> int:
    """Bytes of ArduCopter's fence storage for polygons of these vertex counts, ``circles``
    circles and, when ``return_point``, a breach return point."""
    total = 4 + 1  # header, end-of-storage marker
    total += sum(2 + 8 * n for n in polygon_vertices)
    total += 13 * circles
    total += 9 if return_point else 0
    return total


def fits_ardupilot(polygon_vertices: list[int], circles: int, return_point: bool) -> bool:
    """Whether ArduCopter can store such a fence (bytes and items)."""
    items = sum(polygon_vertices) + circles + return_point
    return (fence_bytes(polygon_vertices, circles, return_point) <= ARDUPILOT_FENCE_BYTES
            and items <= ARDUPILOT_FENCE_ITEMS)


def fence_items(plan: Plan) -> int:
    """How many fence items ``plan``'s fence takes on the wire."""
    return (sum(len(p.vertices_deg) for p in plan.polygons) + len(plan.circles)
            + (plan.breach_return is not None))


def fence_storage_problem(plan: Plan, ardupilot: bool) -> str | None:
    """Why an autopilot (ArduPilot when ``ardupilot``) would not store ``plan``'s fence (None
    when it fits)."""
    big = [i for i, p in enumerate(plan.polygons) if len(p.vertices_deg) > MAX_POLYGON_VERTICES]
    if big:
        return (f"geoFence.polygons[{big[0]}] has {len(plan.polygons[big[0]].vertices_deg)} "
                f"vertices; a fence polygon holds at most {MAX_POLYGON_VERTICES}")
    if not ardupilot:
        return None
    size, items = ardupilot_fence_bytes(plan), fence_items(plan)
    if fits_ardupilot([len(p.vertices_deg) for p in plan.polygons], len(plan.circles),
                      plan.breach_return is not None):
        return None
    return (f"the geofence ({len(plan.polygons)} polygon(s) of "
            f"{sum(len(p.vertices_deg) for p in plan.polygons)} vertices, "
            f"{len(plan.circles)} circle(s)) needs {size} bytes and {items} items; ArduCopter "
            f"stores at most {ARDUPILOT_FENCE_BYTES} bytes and {ARDUPILOT_FENCE_ITEMS} items: "
            "simplify the polygon zones or split the mission")
