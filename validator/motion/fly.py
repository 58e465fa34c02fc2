"""A flight in time under a profile: the one entry to the three profiles' flights.

:func:`fly` evaluates a profile (:func:`~validator.motion.profile.make_profile`) and returns a
:class:`~validator.motion.path.FlownPath`: samples of the commanded position (the vehicle is
assumed to track its target; the position controller's small lag is not modelled) and the time
each leg started, reached its destination and completed. ``ideal``
(:mod:`validator.motion.ideal`) is the plan's own timing; ``arducopter``
(:mod:`validator.motion.arducopter`) ArduCopter 4.x's S-curve navigation; ``px4``
(:mod:`validator.motion.px4_mission`) PX4 v1.15's mission following.
"""

from __future__ import annotations

from validator.errors import InputError
from validator.flight import Finding, Flight
from validator.motion import arducopter, ideal, px4_mission
from validator.motion.arducopter_speed import yaw_findings
from validator.motion.path import FlownPath
from validator.motion.profile import Profile

__all__ = ["MAX_MISSION_S", "REPLAY_STEP_S", "fly", "model_findings"]

# The replay's sample interval (s), and its coarsest: 20 Hz keeps a sample within
# 0.05 s x top speed (under 1 m at 20 m/s) of any point the flight passes, finer than the
# buffers audited; also the rate a recorded track is read at (validate-mission --dt).
REPLAY_STEP_S = 0.05
# No multicopter mission lasts a day (s): a hold or a commanded speed that makes one is bad
# input, and sampling it every REPLAY_STEP_S would take more memory than any machine has
MAX_MISSION_S = 86_400.0


def fly(flight: Flight, profile: Profile, *, dt_s: float = REPLAY_STEP_S) -> FlownPath:
    """Fly ``flight`` with ``profile``, sampled every ``dt_s`` seconds (and at the very end)."""
    if not flight.legs:
        raise InputError(f"{flight.source}: nothing to replay (no navigation items)")
    if not dt_s > 0:
        raise InputError(f"--dt: must be > 0, got {dt_s}")
    _check_duration(flight)
    if profile.name == "ideal":
        return ideal.fly(flight, profile, dt_s)
    if profile.name == "arducopter":
        return arducopter.fly(flight, profile, dt_s)
    return px4_mission.fly(flight, profile, dt_s)


def _check_duration(flight: Flight) -> None:
    """:class:`InputError` for a mission whose holds and legs at their commanded speeds alone
    (a lower bound: the vehicle flies no faster) take over :data:`MAX_MISSION_S`, naming the
    leg that takes longest."""
    each = [leg.hold_s + (leg.length_m / leg.speed_mps if leg.speed_mps else 0.0)
            for leg in flight.legs]
    if sum(each) <= MAX_MISSION_S:
        return
    k = max(range(len(each)), key=each.__getitem__)
    leg = flight.legs[k]
    how = (f"a {leg.hold_s:g} s hold" if leg.hold_s >= each[k] / 2 else
           f"{leg.length_m:.0f} m at {leg.speed_mps:g} m/s")
    raise InputError(f"{flight.source}: item {leg.item}: {how}: the mission would fly over "
                     f"{sum(each):,.0f} s, beyond a day ({MAX_MISSION_S:g} s)")


def model_findings(flight: Flight, profile: Profile) -> tuple[Finding, ...]:
    """What ``profile``'s model knows of its own timing of ``flight`` that no track shows:
    for ``arducopter``, the legs flown leaning at the lean limit after a corner, where the
    timing is only as good as the drag model (:func:`~validator.motion.arducopter.
    lean_limited_findings`), and in wind a yaw the drag model does not fly
    (:func:`~validator.motion.arducopter_speed.yaw_findings`); nothing for the others."""
    if profile.name == "arducopter" and flight.legs:
        return (*yaw_findings(profile), *arducopter.lean_limited_findings(flight, profile))
    return ()
