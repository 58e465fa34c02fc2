"""How long a mission may last: the bound the resolver and the planner's metadata share."""

# No multicopter mission lasts a day (s): a hold, a commanded speed or slot times that make one
# are bad input; its times overflowed the audit's table (a 1e308 s hold read "Result: CLEAR"),
# and sampling it every 0.05 s would take more memory than any machine has
MAX_MISSION_S = 86_400.0
