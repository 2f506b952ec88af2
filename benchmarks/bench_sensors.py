"""Throughput of the camera and lidar sensors; prints figures, asserts nothing.

    python benchmarks/bench_sensors.py            # about 40 s
    python benchmarks/bench_sensors.py --quick    # a few seconds, for a smoke run

What is timed (the simulation step is excluded; the cars drive between calls so that every
call sees a new state):
- Camera, 160 x 120 greyscale, DeepRacer mount: ``CameraSensor.observe(core)`` for 1 env x 2
  cars and 512 envs x 2 cars, on the oval without and with 6 obstacles, and the split of a
  frame into ground warp and box drawing. OpenCV is limited to one thread, so the figures are
  per core.
- Lidar, 64 beams, 1.0 m: ``LidarSensor.observe(core, rng)`` for the same layouts (with the
  0.01 m noise of DeepRacer's Gazebo lidar), and ``sector_lidar``.
"""

from __future__ import annotations

import argparse
import platform
import time
from collections.abc import Callable

import cv2
import numba
import numpy as np

import h2h_racing
from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.sim.core import RaceCore
from h2h_racing.sensors.camera import CameraConfig, CameraSensor
from h2h_racing.sensors.lidar import LidarConfig, LidarSensor

from bench_env import centre_controller  # benchmarks/ is on sys.path when run as a script

ENDLESS = RaceRules(laps=0, time_limit=1e9)
"""A race that never ends by itself, so that the timed loop never hits a reset."""
TRACK = "oval"


def make_core(num_envs: int, obstacles: int) -> RaceCore:
    """A seeded core on the oval with 2 cars and ``obstacles`` boxes per env copy."""
    config = EnvConfig(track=TRACK, num_cars=2, rules=ENDLESS, num_obstacles=obstacles)
    core = RaceCore(config, h2h_racing.load_track(TRACK), num_envs=num_envs)
    core.reset(seed=0)
    return core


def timed(core: RaceCore, call: Callable[[], object], seconds: float) -> float:
    """Return calls per second of ``call``, stepping the core (untimed) between calls."""
    call()
    calls, spent = 0, 0.0
    deadline = time.perf_counter() + seconds
    while time.perf_counter() < deadline or calls < 3:
        core.step(*centre_controller(core))
        start = time.perf_counter()
        call()
        spent += time.perf_counter() - start
        calls += 1
    return calls / spent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short runs (smoke test)")
    args = parser.parse_args()
    seconds = 0.5 if args.quick else 3.0
    cv2.setNumThreads(1)
    print(f"machine: {platform.platform()}, {platform.processor() or platform.machine()}, "
          f"python {platform.python_version()}, numpy {np.__version__}, opencv "
          f"{cv2.__version__}, numba {numba.__version__}, cv2 threads 1")
    camera = CameraConfig()
    print(f"camera {camera.width}x{camera.height}x{camera.channels}, lidar 64 beams, "
          f"track {TRACK}, 2 cars per env copy")
    for obstacles in (0, 6):
        for num_envs in (1, 512):
            core = make_core(num_envs, obstacles)
            size = (core.config.obstacle_length, core.config.obstacle_width)
            frames = num_envs * 2
            sensor = CameraSensor(camera, core.track, core.config.car, size)
            out = np.empty((num_envs, 2, camera.height, camera.width, 1), dtype=np.uint8)
            rate = timed(core, lambda s=sensor, c=core, o=out: s.observe(c, o), seconds)
            print(f"camera  envs={num_envs:4d} obstacles={obstacles}: "
                  f"{rate * frames:10,.0f} frames/s ({1e6 / (rate * frames):6.1f} us/frame)")
            lidar = LidarSensor(LidarConfig(noise_std=0.01), core.config.car, size)
            rng = np.random.default_rng(0)
            rate = timed(core, lambda s=lidar, c=core, r=rng: s.observe(c, r), seconds)
            print(f"lidar   envs={num_envs:4d} obstacles={obstacles}: "
                  f"{rate * frames:10,.0f} scans/s")
            sector = LidarSensor(LidarConfig(mode="sector_lidar"), core.config.car, size)
            rate = timed(core, lambda s=sector, c=core: s.observe(c), seconds)
            print(f"sector  envs={num_envs:4d} obstacles={obstacles}: "
                  f"{rate * frames:10,.0f} scans/s")
    # Breakdown of one 512 x 2 camera call: the ground warps alone versus the whole frame.
    core = make_core(512, 6)
    sensor = CameraSensor(camera, core.track, core.config.car, (0.5, 0.4))
    maps = sensor.ground_maps(core.position, core.yaw)[1].reshape(-1, 3, 3)
    band = np.empty((maps.shape[0], camera.height - sensor.ground_row, camera.width), np.uint8)

    def warps() -> None:
        for f in range(maps.shape[0]):
            cv2.warpPerspective(sensor.texture.image, maps[f], (camera.width, band.shape[1]),
                                dst=band[f], flags=sensor._flags,
                                borderMode=cv2.BORDER_CONSTANT, borderValue=95)

    rate = timed(core, warps, seconds)
    print(f"breakdown (512 envs, 6 obstacles): ground warp alone "
          f"{1e6 / (rate * maps.shape[0]):6.1f} us/frame, texture "
          f"{sensor.texture.image.shape[1]}x{sensor.texture.image.shape[0]} px")


if __name__ == "__main__":
    main()
