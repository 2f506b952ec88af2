"""Regenerate the camera golden images on purpose (the tests never overwrite them).

    python tests/h2h_racing/sensors/make_golden.py

Run this only after a deliberate change to what the camera draws, look at the new PNGs, and
commit them with the change. The scenes are defined here and used by ``test_camera.py``.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

import h2h_racing
from h2h_racing.config.env import EnvConfig
from h2h_racing.sim.core import RaceCore
from h2h_racing.sensors.camera import CameraConfig, CameraSensor

GOLDEN_DIR = Path(__file__).resolve().parent / "golden"
TRACK = "oval"
EGO = (-2.0, 0.0, 0.0)
"""Ego car (x [m], y [m], yaw [rad]): on the oval's bottom straight, looking along it (+x)."""


def scene(name: str) -> RaceCore:
    """A fixed scene on the oval: 3 cars and 2 obstacles placed by hand (no stepping)."""
    config = EnvConfig(track=TRACK, num_cars=3, num_obstacles=2, grid="fixed")
    core = RaceCore(config, h2h_racing.load_track(TRACK), num_envs=1)
    core.reset(seed=0)
    poses = {
        # Two cars ahead (one left, one right and turned), an obstacle on the right lane.
        "traffic": ([EGO, (-0.6, 0.25, 0.0), (-1.2, -0.15, -0.3)],
                    [(0.6, -0.27, 0.0), (3.4, 1.2, 1.57)]),
        # Entering the right-hand bend of the oval with an obstacle in the bend.
        "bend": ([(1.6, 0.05, 0.25), (-3.0, 0.2, 0.0), (-3.5, -0.2, 0.0)],
                 [(3.3, 0.6, 1.0), (-2.5, 3.4, 3.14)]),
    }
    cars, obstacles = poses[name]
    for i, (x, y, yaw) in enumerate(cars):
        core.position[0, i] = (x, y)
        core.yaw[0, i] = yaw
    for k, (x, y, yaw) in enumerate(obstacles):
        core.obstacle_position[0, k] = (x, y)
        core.obstacle_yaw[0, k] = yaw
    return core


GOLDEN: dict[str, tuple[str, CameraConfig]] = {
    "traffic_160x120.png": ("traffic", CameraConfig()),
    "bend_160x120.png": ("bend", CameraConfig()),
    "traffic_stereo_80x60.png": ("traffic", CameraConfig(width=80, height=60, stereo=True)),
}
"""File name -> (scene, camera). Stereo frames are stored left | right side by side."""


def render_golden(scene_name: str, config: CameraConfig) -> np.ndarray:
    """Car 0's view of ``scene_name``, (H, W * cameras) uint8, cameras side by side."""
    core = scene(scene_name)
    sensor = CameraSensor(config, core.track, core.config.car,
                          (core.config.obstacle_length, core.config.obstacle_width))
    frame = sensor.render(core, 0, 0)
    return np.concatenate([frame[:, :, c] for c in range(frame.shape[2])], axis=1)


def main() -> None:
    GOLDEN_DIR.mkdir(exist_ok=True)
    for file_name, (scene_name, config) in GOLDEN.items():
        path = GOLDEN_DIR / file_name
        cv2.imwrite(str(path), render_golden(scene_name, config))
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
