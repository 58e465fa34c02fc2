"""A ground station's use of one vehicle: upload a plan and verify it, download one
(``upload-mission``, ``download-mission``).

:class:`Link` is a :class:`~validator.mavlink.connection.Connection` (open, heartbeat, receive,
COMMAND_LONG) that also speaks the mission protocol (:mod:`~validator.mavlink.mission_protocol`)
and the parameter protocol (:mod:`~validator.mavlink.param_protocol`). :func:`upload_plan` and
:func:`download_plan` are what ``upload-mission`` and ``download-mission`` do. An upload is
reported as a success only when all three lists read back from the vehicle are identical, item
by item, to what was sent. The names of those modules stay importable from here.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field

from validator.autopilot.fence_storage import fence_storage_problem
from validator.errors import InputError
from validator.flight.frames import plan_refusal
from validator.geodesy import from_int_e7
from validator.mavlink import mission_protocol, param_protocol
from validator.mavlink.connection import (
    DEFAULT_RETRY_S,
    DEFAULT_TIMEOUT_S,
    GCS_COMPONENT_ID,
    GCS_SYSTEM_ID,
    Connection,
    Exchange,
    LinkError,
    VehicleInfo,
    command_name,
    open_connection,
)
from validator.mavlink.mission_protocol import (
    BOOT_PATIENCE_S,
    RESENDS_BEFORE_RESTART,
    RESTART_AFTER_S,
    TRANSFER_ATTEMPTS,
    UnconfirmedUpload,
)
from validator.mavlink.param_protocol import ParamValue
from validator.mavlink.storage import first_stored_difference, storage_losses
from validator.mavlink.wire import (
    MissionType,
    WireItem,
    WireLists,
    mavlink,
    plan_to_wire,
    wire_to_plan,
)
from validator.plan_format import Autopilot, Plan

__all__ = [
    "BOOT_PATIENCE_S",
    "DEFAULT_RETRY_S",
    "DEFAULT_TIMEOUT_S",
    "GCS_COMPONENT_ID",
    "GCS_SYSTEM_ID",
    "OTHERS_LISTEN_S",
    "RESENDS_BEFORE_RESTART",
    "RESTART_AFTER_S",
    "TRANSFER_ATTEMPTS",
    "Connection",
    "Exchange",
    "Link",
    "LinkError",
    "ParamValue",
    "ReadBackMismatch",
    "UploadReport",
    "VehicleInfo",
    "command_name",
    "download_from",
    "download_plan",
    "fence_problems",
    "home_of",
    "open_connection",
    "upload_plan",
    "upload_to",
    "verify_lists",
]


class Link(Connection):
    """A connection to one vehicle that also moves mission lists and parameters (see
    :class:`~validator.mavlink.connection.Connection` for opening it). Use as a context
    manager."""

    def upload_list(self, items: tuple[WireItem, ...], mission_type: MissionType) -> bool:
        """:func:`~validator.mavlink.mission_protocol.upload_list`."""
        return mission_protocol.upload_list(self, items, mission_type)

    def download_list(self, mission_type: MissionType) -> tuple[WireItem, ...]:
        """:func:`~validator.mavlink.mission_protocol.download_list`."""
        return mission_protocol.download_list(self, mission_type)

    def upload(self, lists: WireLists) -> None:
        """Upload mission, fence and rally lists, in that order. A list whose last item drew
        a NACK that a lost ACK also explains is read back at once: held as sent, it is
        uploaded; otherwise the NACK is the error."""
        for mtype in MissionType:
            try:
                self.upload_list(lists.of(mtype), mtype)
            except UnconfirmedUpload as err:
                if _held_difference(self, lists.of(mtype), self.download_list(mtype),
                                    mtype) is not None:
                    raise LinkError(str(err)) from None

    def download(self) -> WireLists:
        """Download all three lists."""
        return WireLists(*(self.download_list(t) for t in MissionType))

    def read_param(self, name: str) -> ParamValue:
        """:func:`~validator.mavlink.param_protocol.read_param`."""
        return param_protocol.read_param(self, name)

    def set_param(self, name: str, value: float) -> float:
        """:func:`~validator.mavlink.param_protocol.set_param`."""
        return param_protocol.set_param(self, name, value)

    def set_params(self, params: Mapping[str, float]) -> dict[str, float]:
        """Set and read back each parameter in order; the values read back."""
        return param_protocol.set_params(self, params)


@dataclass
class UploadReport:
    """What :func:`upload_plan` sent and verified."""

    vehicle: VehicleInfo
    counts: dict[str, int]  # items per list as sent (mission includes ArduPilot's home item)
    params: dict[str, float] = field(default_factory=dict)  # as read back from the vehicle

    def summary(self) -> str:
        c = self.counts
        text = (f"uploaded and verified {c['mission']} mission, {c['fence']} fence and "
                f"{c['rally']} rally items on system {self.vehicle.system_id} "
                f"({self.vehicle.autopilot_name})")
        if self.params:
            text += f"; {len(self.params)} parameters set"
        return text


# -- what the commands do ------------------------------------------------------------------


class ReadBackMismatch(LinkError):
    """The vehicle holds lists other than those sent: a verdict on the upload (exit status 1),
    not a failed link."""

    exit_status = 1


def verify_lists(link: Link, sent: WireLists) -> None:
    """Download all three lists and raise :class:`ReadBackMismatch` at the first item the vehicle
    does not hold as sent (verbatim, or as its autopilot documents to store it:
    :mod:`validator.mavlink.storage`)."""
    held = link.download()
    for mtype in MissionType:
        diff = _held_difference(link, sent.of(mtype), held.of(mtype), mtype)
        if diff is not None:
            raise ReadBackMismatch(f"read-back differs from the upload: {diff}")


def _held_difference(link: Connection, sent: tuple[WireItem, ...], held: tuple[WireItem, ...],
                     mtype: MissionType) -> str | None:
    """The first item of a list the vehicle does not hold as sent (by its autopilot's
    storage rules; ArduPilot's home item is its own), or None."""
    return first_stored_difference(sent, held, mtype, link.vehicle.autopilot,
                                   skip_seq0=mtype == MissionType.MISSION
                                   and link.vehicle.is_ardupilot)


def fence_problems(link: Link, plan: Plan) -> list[str]:
    """Why the fence the vehicle holds for ``plan`` is off or has an unsafe breach action,
    read from the vehicle's own parameters (empty when fine, or when ``plan`` has no fence or
    the autopilot is neither ArduPilot nor PX4)."""
    autopilot = Autopilot.known(link.vehicle.autopilot)
    if autopilot is None or not (plan.circles or plan.polygons):
        return []
    rules = autopilot.fence_rules
    return rules.problems({n: link.read_param(n).value for n in rules.param_names})


def upload_to(link: Link, plan: Plan, params: Mapping[str, float] | None = None, *,
              require_fence: bool = True, source: str = "plan") -> UploadReport:
    """Upload ``plan`` (read from ``source``, for messages)'s three lists, set ``params`` (each
    read back, in order, after the lists: a fence is switched on only once it is loaded) and
    verify the lists by downloading them again. Raises :class:`InputError` before sending
    anything when the vehicle's autopilot would refuse an item for its frame or fly it
    elsewhere (:func:`validator.flight.frames.plan_refusal`: what ``validate-mission`` judges,
    here with or without a site) or store an item with another meaning (a fractional
    ArduPilot hold), and :class:`LinkError` on any failure, any difference, or, with
    ``require_fence``, a plan whose fence the vehicle then holds switched off or with a breach
    action that can cross another zone."""
    refused = plan_refusal(plan.items, link.vehicle.is_px4)
    if refused is not None:
        raise InputError(f"{source}: {refused}")
    storage = fence_storage_problem(plan, link.vehicle.is_ardupilot)
    if storage is not None:
        raise InputError(f"{source}: the vehicle would not keep the plan as written: {storage}")
    sent = plan_to_wire(plan, home_item=link.vehicle.is_ardupilot)
    losses = [line for mtype in MissionType
              for line in storage_losses(sent.of(mtype), link.vehicle.autopilot)]
    if losses:
        raise InputError(f"{source}: the vehicle would not keep the plan as written: {losses[0]}"
                         + (f" (and {len(losses) - 1} more)" if len(losses) > 1 else ""))
    link.upload(sent)
    got_params = link.set_params(params) if params else {}
    verify_lists(link, sent)
    if require_fence:
        problems = fence_problems(link, plan)
        if problems:
            raise LinkError(f"the mission is on the vehicle but its geofence is not protecting "
                            f"it: {problems[0]}; set the plan's parameter file (--params "
                            "X.param) or pass --allow-fence-off")
    return UploadReport(
        link.vehicle,
        {t.label: len(sent.of(t)) for t in MissionType},
        got_params,
    )


def upload_plan(
    plan: Plan,
    url: str,
    *,
    timeout_s: float = DEFAULT_TIMEOUT_S,
    sysid: int | None = None,
    params: Mapping[str, float] | None = None,
    require_fence: bool = True,
    signing_key: bytes | None = None,
    source: str = "plan",
) -> UploadReport:
    """Upload ``plan`` (read from ``source``) to the vehicle at ``url`` and verify it
    (``upload-mission``; see :func:`upload_to`); with ``signing_key``, over a signed link
    (:mod:`.signing`)."""
    with Link(url, timeout_s=timeout_s, target_system=sysid, signing_key=signing_key) as link, \
            _explaining(link, sysid):
        return upload_to(link, plan, params, require_fence=require_fence, source=source)


# How long a failed command without --sysid listens for other autopilots (heartbeats: 1 Hz).
OTHERS_LISTEN_S = 1.5


@contextmanager
def _explaining(link: Link, sysid: int | None) -> Iterator[None]:
    """Add to a :class:`LinkError` the other autopilots heard (without ``--sysid`` the vehicle
    is the first heard, perhaps not the one meant: then listen a moment to find out) and the
    packets a signed link refused."""
    try:
        yield
    except LinkError as err:
        if sysid is None and not link.other_autopilots:
            link.recv((), time.monotonic() + min(OTHERS_LISTEN_S, link.timeout_s))
        text = str(err)
        if link.other_autopilots:
            others = ", ".join(str(s) for s in sorted(link.other_autopilots))
            text += (f" (talking to system id {link.vehicle.system_id}; also heard system id "
                     f"{others}: choose one with --sysid)")
        if link.refused:
            text += f"; {link.refused.explanation()}"
        elif link.refused is None and link.vehicle_signs:
            text += ("; the vehicle signs its packets and may refuse unsigned ones: connect "
                     "with --signing-key FILE")
        if text == str(err):
            raise
        raise LinkError(text) from None


def home_of(link: Link) -> tuple[float, float, float] | None:
    """The vehicle's home (lat, lon, alt AMSL) from HOME_POSITION, or None if it never says."""
    ts, tc = link.target

    def request() -> None:
        link.mav.command_long_send(ts, tc, mavlink.MAV_CMD_REQUEST_MESSAGE, 0,
                                   float(mavlink.MAVLINK_MSG_ID_HOME_POSITION), 0, 0, 0, 0, 0, 0)

    # The answer may come before or after the COMMAND_ACK: wait for the message itself, as
    # long as for a command's ACK.
    for msg in link.exchange(request, ["HOME_POSITION"], resend_s=3 * link.retry_s):
        if msg is not None:
            return (float(from_int_e7(msg.latitude)), float(from_int_e7(msg.longitude)),
                    msg.altitude / 1000.0)
    return None


def download_from(link: Link, note: Callable[[str], None] | None = None) -> Plan:
    """The three lists the vehicle holds, as a :class:`Plan`; ``note`` is told in one line
    when the vehicle reported no home and the plan's stands in for it
    (:func:`~validator.mavlink.wire.wire_to_plan`)."""
    lists = link.download()
    home = None if link.vehicle.is_ardupilot and lists.mission else home_of(link)
    firmware = int(Autopilot.known(link.vehicle.autopilot) or Autopilot.GENERIC)
    return wire_to_plan(lists, home_item=link.vehicle.is_ardupilot, home=home,
                        firmware_type=firmware, note=note)


def download_plan(url: str, *, timeout_s: float = DEFAULT_TIMEOUT_S,
                  sysid: int | None = None, signing_key: bytes | None = None,
                  note: Callable[[str], None] | None = None) -> Plan:
    """What the vehicle at ``url`` holds, as a plan (``download-mission``); with
    ``signing_key``, over a signed link (:mod:`.signing`); ``note`` as for
    :func:`download_from`."""
    with Link(url, timeout_s=timeout_s, target_system=sysid, signing_key=signing_key) as link, \
            _explaining(link, sysid):
        return download_from(link, note)

