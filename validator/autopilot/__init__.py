"""What we know of each autopilot: parameter tables, flight rules, geofence rules, param files."""
