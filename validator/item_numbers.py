"""The one number a person reads for a mission item (and how fence and rally items are named).

Code keeps 0-based indices (``plan.items[i]``, a leg's ``item``). What a person reads
(messages, CLI text, the HTML view, the report JSON's ``item`` and ``from_item`` fields, track
and timeline labels) is the item's **number**, :func:`item_number`: index + 1. That is
QGroundControl's sequence number (home is 0, the first ``.plan`` item is 1), ArduPilot's wire
seq (MISSION_ITEM_INT, MISSION_CURRENT), the ``.waypoints`` (QGC WPL 110) seq column and the
number a DO_JUMP names (``doJumpId``): "item 21" in an audit is the item QGroundControl shows as
21, on either autopilot. Home is number 0 (``from_item`` 0 in a report), written "home" in
text. PX4 keeps no home item on the wire, so its mission seq is the index and seq + 1 the
number (:func:`wire_item_number`).

Fence and rally lists have no home item on either autopilot and QGroundControl shows them no
number: they keep their wire seq (from 0, the same on ArduPilot and PX4, and the seq column of
a fence or rally ``.waypoints`` file), always written "fence item N" / "rally item N"
(:func:`list_item_label`), so a bare "item N" is always a mission item's number.
"""

from __future__ import annotations

MISSION, FENCE, RALLY = 0, 1, 2  # MAV_MISSION_TYPE
_LIST_NAMES = {MISSION: "mission", FENCE: "fence", RALLY: "rally"}


def item_number(index: int) -> int:
    """The number of the mission item at 0-based ``index``: ``index + 1`` (index -1, home: 0)."""
    return index + 1


def item_label(index: int) -> str:
    """``"item N"`` for the mission item at ``index``; ``"home"`` for index < 0 (from home)."""
    return "home" if index < 0 else f"item {item_number(index)}"


def wire_item_number(seq: int, *, home_item: bool, mission_type: int = MISSION) -> int:
    """The number of the item a MAVLink ``seq`` names. ``home_item``: the vehicle keeps home at
    mission seq 0 (ArduPilot), so its mission seq is the number; PX4's mission seq is the index,
    one less. Fence and rally items keep their seq on both (see the module doc)."""
    if mission_type != MISSION or home_item:
        return seq
    return item_number(seq)


def list_item_label(seq: int, *, home_item: bool, mission_type: int = MISSION) -> str:
    """``"mission item N"``, ``"fence item N"`` or ``"rally item N"`` for the item a MAVLink
    ``seq`` names, N by :func:`wire_item_number`: the same words for the same ``.plan`` item
    from ArduPilot and PX4."""
    number = wire_item_number(seq, home_item=home_item, mission_type=mission_type)
    return f"{_LIST_NAMES.get(mission_type, 'mission')} item {number}"
