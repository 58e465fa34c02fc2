"""How far each autopilot's vehicle coasts after it loses its position (GPS): the measured
figures behind :mod:`validator.position_loss`, one :class:`CoastRule` per autopilot.

**ArduCopter 4.5.6** (SITL, realistic site, 30 m): the EKF failsafe fires 8.1-8.2 s after the
loss (EKF3's ``posRetryTimeNoVel_ms`` and ``ekf_check``), the vehicle flies the mission's path
until then, and Land levels it: it ends within 12 m of the point 2.6 s of its speed ahead
(:mod:`validator.position_loss` has the table).

**PX4 v1.15.4** (SIH quadrotor, realistic site, 30 m; ``validate-mission --fault gps-loss``,
SIM_GPS_USED 0; 11 flights in ``tests/data/failsafe/gps-loss-px4.json``). EKF2 stops fusing
the receiver, flies on inertially, and gives up the horizontal position after EKF2_NOAID_TOUT
(5 s); the mission, which needs a position, cannot run, nor can RTL or Land, so the
commander's fallback chain ends in Descend (whatever COM_POSCTL_NAVL says: that parameter
picks the fallback of the manual position mode only). Descend has no horizontal control: it
holds the attitude level and sinks at MPC_LAND_SPEED (0.7 m/s: on the ground 42-47 s after
it, from 30 m), so the vehicle coasts to a stop on the air's drag, then wanders on its unaided
attitude estimate's tilt. Unlike ArduCopter, PX4 does not stay on the mission's path until the
failsafe: its inertial estimate carries it off. From each flight's log (the true speed when
Descend began):

============== ============ ================ =============== ==================
true speed     delay        off the path     coast to 1 m/s  wander after it
============== ============ ================ =============== ==================
2.0 m/s        4.75 s       6.9 m            1.3 m           8.3 m
4.9-5.3 m/s    4.5-5.0 s    5.1-7.2 m        4.2-4.8 m       1.5-3.6 m
6.2-7.4 m/s    4.1-5.0 s    3.2-7.2 m        6.4-6.7 m       3.0-10.6 m
8.7-8.9 m/s    4.3-4.6 s    0.6-1.5 m        8.8-9.0 m       5.0-14.8 m
============== ============ ================ =============== ==================

(delay: from the receiver's lost fix to Descend; off the path: the estimate's error then;
coast: until under 1 m/s, 0.66-1.03 s of the speed; wander: from there to touchdown.) The
rule takes each part at its worst, since they are independent (the worst wander came with a
small error off the path, and the worst error with a small wander): off the path up to
7.5 m, ahead 1.1 s of the speed, then anywhere within 15 m. SIH's drag is strong (SIH_KDV
1 N per m/s on its 1 kg quad): a real airframe with less drag coasts further than these
figures, and its wander depends on its sensors; fly its own ``--fault gps-loss`` before
trusting them.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class CoastRule:
    """Where a vehicle that lost its position goes: it flies the mission for ``delay_s``
    (off its path by up to ``offpath_m``), then ends within ``wander_m`` of the point
    ``coast_s`` of its speed ahead along its velocity. ``failsafe`` names the failsafe's
    parameter and ``action`` what it does, for messages."""

    autopilot: str
    delay_s: float
    coast_s: float
    wander_m: float
    offpath_m: float
    failsafe: str
    action: str

    @property
    def failsafe_name(self) -> str:
        """The failsafe alone, for a sentence ("ArduCopter's EKF failsafe")."""
        return self.action.split(" (")[0]

    @property
    def reach_m(self) -> float:
        """How far (m) from the coast's end point the vehicle may be: the wander, widened by
        the drift off the path before the failsafe."""
        return self.wander_m + self.offpath_m


ARDUCOPTER = CoastRule(
    "ardupilot",
    delay_s=8.2,  # from the GPS loss to the EKF failsafe's mode change (measured 8.1-8.2 s)
    coast_s=2.6,  # the coast reaches this many seconds of the speed ahead (fitted)
    wander_m=12.0,  # ... give or take this much in any direction (measured up to 11.3 m)
    offpath_m=0.0,  # on the mission's path until the failsafe (the mission audit covers it)
    failsafe="FS_EKF_ACTION", action="ArduCopter's EKF failsafe (Land without a position)")
# ... to the dead-reckoning failsafe's with drag fusion (posRetryTimeUseVel_ms; measured
# 10.3-10.45 s)
ARDUCOPTER_DEAD_RECKONING_DELAY_S = 10.4

PX4 = CoastRule(
    "px4",
    delay_s=5.0,  # EKF2_NOAID_TOUT's 5 s, then Descend (measured 4.1-5.0 s after the lost fix)
    coast_s=1.1,  # PX4 SIH's drag stops it in about a second of its speed (measured 0.66-1.03 s)
    wander_m=15.0,  # ... then its attitude estimate's tilt carries it (measured up to 14.8 m)
    offpath_m=7.5,  # the inertial estimate's error when the failsafe fires (measured 7.2 m)
    failsafe="COM_POSCTL_NAVL", action="PX4's navigation-loss failsafe (Descend without a "
                                       "position)")


def coast_rule(autopilot: str) -> CoastRule:
    """The coast of ``autopilot`` ("ardupilot" or "px4") after a position loss."""
    return PX4 if autopilot == "px4" else ARDUCOPTER
