"""How autopilots move a multicopter along a mission: each autopilot's motion rules, ported.

:mod:`validator.dynamics` turns a resolved flight into motion in time with these rules; the
planner times its legs with the same functions, so a rule lives in one place.
"""
