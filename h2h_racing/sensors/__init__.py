"""Observations of the cars: the state vector, the front camera and the lidar."""

from h2h_racing.sensors.camera import CameraConfig, CameraSensor, save_camera_png
from h2h_racing.sensors.lidar import LidarConfig, LidarSensor

__all__ = ["CameraConfig", "CameraSensor", "LidarConfig", "LidarSensor", "save_camera_png"]
