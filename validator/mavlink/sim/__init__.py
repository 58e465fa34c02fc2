"""A software-in-the-loop multicopter that speaks MAVLink 2 as an ArduCopter does.

:class:`SitlVehicle` listens on a pymavlink connection string (normally ``udpin:HOST:PORT``)
and behaves like ArduCopter 4.x towards a ground station:

- HEARTBEAT as MAV_AUTOPILOT_ARDUPILOTMEGA / MAV_TYPE_QUADROTOR with ArduCopter's custom mode
  numbers (STABILIZE 0, AUTO 3, GUIDED 4, LOITER 5, RTL 6, LAND 9, BRAKE 17):
  :mod:`.arducopter`;
- the vehicle side of the mission protocol for mission, fence and rally lists, done by
  MAVSDK's ``MissionRawServer`` through a ``raw://`` connection (:mod:`.mission_server`): the
  vehicle owns the socket (:mod:`.radio`) and hands MAVSDK the mission-protocol packets only,
  so MAVSDK's generic heartbeat and our ArduCopter telemetry do not fight over one port, and
  ``loss`` applies to MAVSDK's packets too;
- arming (COMPONENT_ARM_DISARM), modes (DO_SET_MODE, SET_MODE), NAV_TAKEOFF in GUIDED,
  MISSION_START, MISSION_SET_CURRENT, RTL and LAND (:mod:`.commands`, carried out by
  :mod:`.copter`), parameters (PARAM_*: :mod:`.params`), REQUEST_MESSAGE for HOME_POSITION and
  AUTOPILOT_VERSION;
- its home where it arms, moved by a mission's DO_SET_HOME as the resolved flight moves it
  (:mod:`validator.flight.home`: param1 1 where the vehicle is, its altitude too; else the
  item's location): HOME_POSITION is sent as it moves, RTL flies there and climbs RTL_ALT above
  it, and the relative altitude is reported above it;
- flying the uploaded mission in AUTO along the validator's replay of it (the same dynamics
  model; see :mod:`validator.mavlink.autoflight`), GLOBAL_POSITION_INT at ``telemetry_hz``
  (simulated seconds), MISSION_CURRENT, MISSION_ITEM_REACHED, EXTENDED_SYS_STATE and
  FENCE_STATUS (breach of any uploaded fence circle or polygon: :mod:`.fence`) in
  :mod:`.telemetry`.

Time is simulated (:mod:`.vehicle`): ``speedup`` simulated seconds pass per wall second, and
every timestamp the vehicle sends (``time_boot_ms``) is simulated time. ``loss`` drops that
fraction of packets at random in each direction (seeded). With ``signing_key`` it signs
everything it sends (MAVSDK's answers re-signed as a second stream) and ignores every packet
not signed with that key, as ArduPilot does on a signed port
(:mod:`validator.mavlink.signing`). Differences from ArduCopter, on purpose: the fence is on
and report-only by default (``FENCE_ENABLE`` 1, ``FENCE_ACTION`` 0; set ``FENCE_ACTION`` 1 for
RTL, 2 for LAND, 4 for BRAKE); outside AUTO the vehicle moves by a plain speed- and
acceleration-limited point follower (:mod:`.physics`).
"""

from validator.mavlink.sim.arducopter import CopterMode
from validator.mavlink.sim.config import VehicleConfig
from validator.mavlink.sim.vehicle import SitlVehicle

__all__ = ["CopterMode", "SitlVehicle", "VehicleConfig"]
