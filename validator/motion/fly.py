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
from validator.flight import Finding, Flight, check_duration
from validator.motion import arducopter, ideal, px4_mission
from validator.motion.arducopter_speed import yaw_findings
from validator.motion.path import FlownPath
from validator.motion.profile import Profile

__all__ = ["MIN_REPLAY_STEP_S", "REPLAY_STEP_S", "check_step", "fly", "model_findings"]

# The replay's sample interval (s), and its coarsest: 20 Hz keeps a sample within
# 0.05 s x top speed (under 1 m at 20 m/s) of any point the flight passes, finer than the
# buffers audited; also the rate a recorded track is read at (validate-mission --dt).
REPLAY_STEP_S = 0.05
# The finest: a day's mission (MAX_MISSION_S, the longest check_duration lets through) is then
# 8.6 million samples, about 70 MB a column; finer steps would move no point by a centimetre
# the buffers could see (0.01 s x 20 m/s = 0.2 m already), and --dt 1e-9 asked for 1.8 TiB.
MIN_REPLAY_STEP_S = 0.01


def check_step(dt_s: float, name: str, coarsest_s: float = float("inf")) -> None:
    """:class:`InputError` naming ``name`` unless ``dt_s`` lies in [MIN_REPLAY_STEP_S,
    ``coarsest_s``]."""
    if not MIN_REPLAY_STEP_S <= dt_s <= coarsest_s:
        most = f" and <= {coarsest_s:g} s" if coarsest_s < float("inf") else ""
        raise InputError(f"{name}: must be >= {MIN_REPLAY_STEP_S:g} s{most}, got {dt_s}")


def fly(flight: Flight, profile: Profile, *, dt_s: float = REPLAY_STEP_S) -> FlownPath:
    """Fly ``flight`` with ``profile``, sampled every ``dt_s`` seconds (and at the very end)."""
    if not flight.legs:
        raise InputError(f"{flight.source}: nothing to replay (no navigation items)")
    check_step(dt_s, "dt_s")
    check_duration(flight)  # a Flight built without resolve_flight (the planner's) too
    if profile.name == "ideal":
        return ideal.fly(flight, profile, dt_s)
    if profile.name == "arducopter":
        return arducopter.fly(flight, profile, dt_s)
    return px4_mission.fly(flight, profile, dt_s)


def model_findings(flight: Flight, profile: Profile) -> tuple[Finding, ...]:
    """What ``profile``'s model knows of its own timing of ``flight`` that no track shows:
    for ``arducopter``, the legs flown leaning at the lean limit after a corner, where the
    timing is only as good as the drag model (:func:`~validator.motion.arducopter.
    lean_limited_findings`), and in wind a yaw the drag model does not fly
    (:func:`~validator.motion.arducopter_speed.yaw_findings`); nothing for the others."""
    if profile.name == "arducopter" and flight.legs:
        return (*yaw_findings(profile), *arducopter.lean_limited_findings(flight, profile))
    return ()
