"""MAVLink: plans on the wire, a ground station, a simulated vehicle, and flying a plan.

The wire format of a plan (:mod:`~validator.mavlink.wire`, :mod:`~validator.mavlink.storage`);
a ground station's connection (:mod:`~validator.mavlink.connection`), mission and parameter
protocols (:mod:`~validator.mavlink.mission_protocol`, :mod:`~validator.mavlink.param_protocol`)
and their use (:mod:`~validator.mavlink.link`), signed with :mod:`~validator.mavlink.signing`,
tried on a bad link with :mod:`~validator.mavlink.lossy_relay`;
a simulated ArduCopter (:mod:`validator.mavlink.sim`, flying
:mod:`~validator.mavlink.autoflight`); flying a plan on any vehicle
(:mod:`~validator.mavlink.driver`, :mod:`~validator.mavlink.modes`,
:mod:`~validator.mavlink.telemetry`, :mod:`~validator.mavlink.link_loss`); real SITL
binaries (:mod:`~validator.mavlink.sitl_process`) and the commands (:mod:`~validator.mavlink.cli`).
"""

import re

# how long a link waits for a vehicle's answer (s) by default; here, not in .connection, so
# that the commands' parsers name it without loading pymavlink
DEFAULT_TIMEOUT_S = 10.0

# pymavlink connection strings of a network link (anything else it opens as a serial port or,
# for an existing file, as a log to replay)
NETWORK_URL = re.compile(r"^(udp|udpin|udpout|udpbcast|tcp|tcpin|mcast|ws|wss|wsserver):")
