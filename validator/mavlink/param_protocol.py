"""The MAVLink parameter protocol from the ground station's side: read a parameter, set one
and confirm the value the vehicle then holds (PARAM_REQUEST_READ / PARAM_SET -> PARAM_VALUE)."""

from __future__ import annotations

import struct
import time
from collections.abc import Mapping
from dataclasses import dataclass

from validator.mavlink.connection import Connection, LinkError
from validator.mavlink.wire import mavlink

# PX4 packs integer parameters bytewise into PARAM_VALUE's float: MAV_PARAM_TYPE -> layout
_BYTEWISE = {1: "<B3x", 2: "<b3x", 3: "<H2x", 4: "<h2x", 5: "<I", 6: "<i"}
_FLOATS = (mavlink.MAV_PARAM_TYPE_REAL32, mavlink.MAV_PARAM_TYPE_REAL64)


@dataclass(frozen=True)
class ParamValue:
    """A parameter as the vehicle reports it (value decoded, MAV_PARAM_TYPE)."""

    name: str
    value: float
    param_type: int


def decode_param(value: float, param_type: int, bytewise: bool) -> float:
    """PARAM_VALUE's float field as the parameter's value (PX4 packs integers bytewise:
    ``bytewise`` for a PX4 vehicle)."""
    if not bytewise or param_type in _FLOATS:
        return float(value)
    raw = struct.pack("<f", value)
    return float(struct.unpack(_BYTEWISE.get(param_type, "<i"), raw)[0])


def _encode_param(value: float, param_type: int, bytewise: bool) -> float:
    if not bytewise or param_type in _FLOATS:
        return float(value)
    fmt = _BYTEWISE.get(param_type, "<i")
    return float(struct.unpack("<f", struct.pack(fmt, int(round(value))))[0])


def _same_param(a: float, b: float, param_type: int) -> bool:
    if param_type in _FLOATS:
        return struct.pack("<f", a) == struct.pack("<f", b)
    return int(round(a)) == int(round(b))


def read_param(link: Connection, name: str) -> ParamValue:
    """Read one parameter by name (PARAM_REQUEST_READ -> PARAM_VALUE)."""
    ts, tc = link.target
    for msg in link.exchange(
        lambda: link.mav.param_request_read_send(ts, tc, name.encode("ascii"), -1),
        ["PARAM_VALUE"], lambda m: m.param_id == name,
    ):
        if msg is not None:
            return ParamValue(name, decode_param(msg.param_value, msg.param_type,
                                                  link.vehicle.is_px4), int(msg.param_type))
    raise LinkError(f"parameter {name}: vehicle did not report it within "
                    f"{link.timeout_s:g} s (unknown parameter?)")


def set_param(link: Connection, name: str, value: float) -> float:
    """Set one parameter and return the value the vehicle reports back; raises
    :class:`LinkError` unless it equals ``value`` (in the parameter's type)."""
    current = read_param(link, name)
    ts, tc = link.target
    encoded = _encode_param(value, current.param_type, link.vehicle.is_px4)
    held: float | None = None
    for msg in link.exchange(
        lambda: link.mav.param_set_send(ts, tc, name.encode("ascii"), encoded,
                                        current.param_type),
        ["PARAM_VALUE"], lambda m: m.param_id == name,
    ):
        if msg is not None:
            held = decode_param(msg.param_value, msg.param_type, link.vehicle.is_px4)
            if _same_param(held, value, current.param_type):
                return held
            # An answer to an earlier request may still carry the old value: ask again.
    if held is not None:
        raise LinkError(f"parameter {name}: set {value:g}, vehicle holds {held:g}")
    raise LinkError(f"parameter {name}: vehicle did not confirm {value:g} within "
                    f"{link.timeout_s:g} s")


def set_params(link: Connection, params: Mapping[str, float]) -> dict[str, float]:
    """Set and read back each parameter in order; the values read back."""
    return {name: set_param(link, name, value) for name, value in params.items()}


def read_all_params(link: Connection) -> dict[str, ParamValue]:
    """Every parameter the vehicle holds, by name: PARAM_REQUEST_LIST, then, whenever the
    stream pauses for the link's retry period, PARAM_REQUEST_READ by index for a few it
    missed. Raises :class:`LinkError` when the vehicle stays silent for the link's timeout
    before all ``param_count`` have come."""
    ts, tc = link.target
    got: dict[int, ParamValue] = {}
    count: int | None = None
    link.mav.param_request_list_send(ts, tc)
    heard = time.monotonic()
    while count is None or len(got) < count:
        msg = link.recv(["PARAM_VALUE"], time.monotonic() + link.retry_s)
        now = time.monotonic()
        if msg is None:
            if now - heard > link.timeout_s:
                raise LinkError(f"parameters: the vehicle sent {len(got)} of "
                                f"{'?' if count is None else count} before it went silent "
                                f"for {link.timeout_s:g} s")
            if count is None:
                link.mav.param_request_list_send(ts, tc)
            else:
                for i in [i for i in range(count) if i not in got][:10]:
                    link.mav.param_request_read_send(ts, tc, b"", i)
            continue
        heard = now
        count = int(msg.param_count)
        if 0 <= msg.param_index < count and msg.param_index not in got:
            got[int(msg.param_index)] = ParamValue(
                str(msg.param_id),
                decode_param(msg.param_value, msg.param_type, link.vehicle.is_px4),
                int(msg.param_type))
    return {p.name: p for p in got.values()}
