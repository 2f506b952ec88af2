"""Figure: the 120 deg camera as a 64 x 48 image against a 128 x 24 band (distill_band.toml).

    python experiments/camera/band_figure.py [--track technical] [--out figures/band_technical.png]

``ppo_generalist`` drives one lap's start; at four moments the same car's camera is drawn
both ways (left 64 x 48, right 128 x 24, nearest-neighbour at 4 x). Both images have 3,072
pixels; the band spends them from 0.2 m ahead to the horizon instead of on the sky.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import cv2
import numpy as np

from h2h_racing.config.env import EnvConfig
from h2h_racing.envs.parallel import RacingEnv
from h2h_racing.policies import make_driver

SCALE = 4
STEPS = (10, 25, 40, 55)


def frames(track: str, width: int, height: int) -> list[np.ndarray]:
    """The 120 deg camera's (height, width) images at ``STEPS`` of ``ppo_generalist``'s lap."""
    camera = dataclasses.replace(EnvConfig().camera, width=width, height=height, hfov_deg=120.0)
    env = RacingEnv(track=track, num_cars=1, race_type="time_trial", camera=camera,
                    sensors=("camera",))
    obs, _ = env.reset(seed=0)
    driver = make_driver("ppo_generalist", seed=0)
    driver.reset(env.core)
    out = []
    for step in range(max(STEPS) + 1):
        if step in STEPS:
            out.append(np.asarray(obs["car_0"]["camera"]).reshape(height, width))
        obs, *_ = env.step({"car_0": driver.act(env.core, 0)[0]})
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--track", default="technical", help="track (default: technical)")
    parser.add_argument("--out", default=str(Path(__file__).parent / "figures" /
                                             "band_technical_64x48_vs_128x24.png"),
                        help="PNG path (default: figures/band_technical_64x48_vs_128x24.png)")
    args = parser.parse_args()
    rows = []
    for full, band in zip(frames(args.track, 64, 48), frames(args.track, 128, 24)):
        left = cv2.resize(full.astype(np.uint8), (64 * SCALE, 48 * SCALE),
                          interpolation=cv2.INTER_NEAREST)
        right = np.full((48 * SCALE, 128 * SCALE), 128, np.uint8)
        right[12 * SCALE:36 * SCALE] = cv2.resize(band.astype(np.uint8),
                                                  (128 * SCALE, 24 * SCALE),
                                                  interpolation=cv2.INTER_NEAREST)
        rows.append(np.concatenate([left, np.full((48 * SCALE, 16), 128, np.uint8), right], 1))
    cv2.imwrite(args.out, np.concatenate(rows, 0))
    print(args.out)


if __name__ == "__main__":
    main()
