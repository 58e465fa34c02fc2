"""What the validator knows about each autopilot: parameter files and geofence rules."""
