"""Each autopilot's parameter table by name, and what a value outside its documented range says."""

from __future__ import annotations

from validator.autopilot import ardupilot, px4
from validator.autopilot.spec import ParamSpec
from validator.errors import InputError

AUTOPILOTS = ("ardupilot", "px4")
PARAM_TABLES: dict[str, dict[str, ParamSpec]] = {
    "ardupilot": ardupilot.PARAMS,
    "px4": px4.PARAMS,
}


def param_table(autopilot: str) -> dict[str, ParamSpec]:
    """The parameter table of ``autopilot`` ("ardupilot" or "px4")."""
    try:
        return PARAM_TABLES[autopilot]
    except KeyError:
        raise InputError(f"autopilot: unknown {autopilot!r} (choose from "
                         f"{', '.join(AUTOPILOTS)})") from None


def range_notes(autopilot: str, values: dict[str, float]) -> tuple[str, ...]:
    """One note per value of ``values`` (autopilot units) outside its documented range."""
    table = param_table(autopilot)
    return tuple(
        f"{name} {value:g} {table[name].unit} is outside the documented range "
        f"{table[name].minimum:g}-{table[name].maximum:g}: check that the vehicle accepts it"
        for name, value in values.items()
        if not table[name].in_range(value)
    )
