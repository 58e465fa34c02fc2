"""MAVLink: the wire format of a plan (:mod:`~validator.mavlink.wire`), a ground station's
mission and parameter protocols (:mod:`~validator.mavlink.link`, signed with
:mod:`~validator.mavlink.signing`), a simulated ArduCopter
(:mod:`~validator.mavlink.vehicle`, flying :mod:`~validator.mavlink.autoflight`), flying a plan
on any vehicle (:mod:`~validator.mavlink.driver`) and the commands (:mod:`~validator.mavlink.cli`).
"""

import re

# pymavlink connection strings of a network link (anything else it opens as a serial port or,
# for an existing file, as a log to replay)
NETWORK_URL = re.compile(r"^(udp|udpin|udpout|udpbcast|tcp|tcpin|mcast|ws|wss|wsserver):")
