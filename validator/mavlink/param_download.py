"""A vehicle's whole parameter set, fetched over MAVLink and written as a parameter file
(``download-mission --params``), so what the vehicle really holds can be audited."""

from __future__ import annotations

from validator.autopilot.param_file import format_params
from validator.mavlink.link import Link
from validator.mavlink.param_protocol import read_all_params


def download_params_text(url: str, *, timeout_s: float, sysid: int | None = None,
                         signing_key: bytes | None = None) -> tuple[int, str]:
    """Every parameter of the vehicle at ``url`` as parameter-file text
    (:func:`validator.autopilot.param_file.format_params`, in its autopilot's format), and
    how many there are."""
    with Link(url, timeout_s=timeout_s, target_system=sysid, signing_key=signing_key) as link:
        held = read_all_params(link)
        autopilot = "px4" if link.vehicle.is_px4 else "ardupilot"
        who = f"{link.vehicle.autopilot_name} system {link.vehicle.system_id}"
    values = {n: held[n].value for n in sorted(held)}
    text = format_params(values, autopilot, [f"parameters read from {who} at {url}"],
                         {n: held[n].param_type for n in values})
    return len(values), text

