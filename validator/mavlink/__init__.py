"""MAVLink: the wire format of a plan (:mod:`~validator.mavlink.wire`), a ground station's
mission and parameter protocols (:mod:`~validator.mavlink.link`), a simulated ArduCopter
(:mod:`~validator.mavlink.vehicle`, flying :mod:`~validator.mavlink.autoflight`), flying a plan
on any vehicle (:mod:`~validator.mavlink.driver`) and the commands (:mod:`~validator.mavlink.cli`).
"""
