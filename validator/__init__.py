"""Base layer: site files, geometry, plan formats, flight model, audit and MAVLink.

Nothing here imports :mod:`mission_planner`, so the auditor can judge plans from any source.
"""
