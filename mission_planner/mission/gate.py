"""The exporter's safety gate: why a laid-out plan must not be written.

The gate is the validator's audit (:func:`validator.audit.audit`), the same check
``validate-mission`` makes, with one difference: every leg must keep the site's safety buffer
too (``require_buffer``), since the planner laid every leg out R + buffer from each centre.
One tolerance, :data:`~validator.audit.CLEARANCE_TOLERANCE_M`, absorbs MAVLink's rounding; the
exporter lays legs out a centimetre beyond R + buffer (:mod:`.clearance`), so a plan it makes
passes with rounding to spare.
"""

from __future__ import annotations

from validator.audit import CLEARANCE_TOLERANCE_M, audit
from validator.plan_format import Plan
from validator.site import Site


def plan_problems(plan: Plan, site: Site) -> list[str]:
    """Why the safety gate refuses ``plan`` (empty if it is safe to fly): every violation the
    audit finds with the safety buffer required (legs, geofence, home, rally and breach-return
    points, speeds above the site's V, altitudes, items it cannot resolve)."""
    return [f.message for f in audit(plan, site, require_buffer=True).violations]


__all__ = ["CLEARANCE_TOLERANCE_M", "plan_problems"]
