"""How autopilots move a multicopter along a mission: one module per idea, one per profile.

- :mod:`~validator.motion.profile`: the profiles and their parameters, in autopilot units;
- :mod:`~validator.motion.limits`: the vehicle's own lean and top-speed limits;
- :mod:`~validator.motion.scurve`: 1-D motion along a leg (jerk-limited S-curves);
- :mod:`~validator.motion.path`: legs in 3-D and the flown path they add up to;
- :mod:`~validator.motion.ideal`, :mod:`~validator.motion.arducopter`,
  :mod:`~validator.motion.px4_mission`: each profile's flight; :mod:`~validator.motion.px4`
  holds PX4's own motion rules, ported.

:func:`validator.motion.fly.fly` flies a profile; the planner times its legs with the same
functions, so a rule lives in one place.
"""
