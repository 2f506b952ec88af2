"""Observations of the cars: the state vector (and, later, camera and lidar)."""
