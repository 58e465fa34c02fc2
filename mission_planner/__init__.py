"""Mission planning by optimisation: the paper's BCD optimiser, mission construction, studies.

Builds on :mod:`validator` (site files, geometry, plan formats); never imported by it.
"""
