"""The picture in a camera policy's card: what the policy sees at one moment of a race.

    python experiments/camera/card_image.py POLICY OUT.png [--track speedway] [--steps 45]

Races POLICY (a camera or camera + lidar policy) from behind against ``racing_line`` and
saves, side by side at 8 x, the camera image the policy gets (its own size, e.g. 32 x 24
greyscale) and, for a lidar policy, its lidar ranges seen from above (car at the centre,
facing up, 1 m to the edge; grey: nothing within range).
"""

from __future__ import annotations

import argparse
import math

import cv2
import numpy as np

from h2h_racing.config.env import RaceRules
from h2h_racing.envs.parallel import RacingEnv
from h2h_racing.policies import make_driver

SCALE = 8


def lidar_picture(ranges: np.ndarray, fov_deg: float, max_range: float, size: int) -> np.ndarray:
    """Ranges (B,) over +-fov/2 from straight ahead (left first or right first as the sensor
    orders them: the sensor's docstring) drawn from above."""
    img = np.full((size, size), 40, dtype=np.uint8)
    centre = np.array([size // 2, size // 2])
    pixels = (size // 2 - 4) / max_range
    cv2.circle(img, tuple(int(c) for c in centre), int(max_range * pixels), 90, 1)
    angles = np.radians(np.linspace(-fov_deg / 2, fov_deg / 2, len(ranges)))
    for angle, r in zip(angles, ranges):
        hit = r < max_range - 1e-6
        tip = centre + pixels * r * np.array([-math.sin(angle), -math.cos(angle)])
        cv2.line(img, tuple(int(c) for c in centre), tuple(int(c) for c in tip),
                 255 if hit else 120, 1)
    corner = np.array([3, 5])
    cv2.rectangle(img, tuple(int(c) for c in centre - corner),
                  tuple(int(c) for c in centre + corner), 255, -1)
    return img


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("policy")
    parser.add_argument("out")
    parser.add_argument("--track", default="speedway")
    parser.add_argument("--steps", type=int, default=45)
    args = parser.parse_args()
    driver = make_driver(args.policy, seed=0)
    other = make_driver("racing_line", seed=0)
    env = RacingEnv(track=args.track, num_cars=2, race_type="head_to_head",
                    rules=RaceRules.preset("head_to_head"))
    env.reset(seed=0, options={"grid": [1, 0]})
    core = env.core
    driver.reset(core)
    other.reset(core)
    for _ in range(args.steps):
        env.step({"car_0": driver.act(core, 0)[0], "car_1": other.act(core, 1)[0]})
    groups = driver._observe(core, 0)
    frame = (groups["camera"][0, 0] * 255).astype(np.uint8)
    h, w = frame.shape
    panels = [cv2.resize(frame, (w * SCALE, h * SCALE), interpolation=cv2.INTER_NEAREST)]
    if "lidar" in groups:
        lidar = driver._lidar.config
        panels.append(lidar_picture(groups["lidar"][0], lidar.fov_deg, lidar.max_range,
                                    h * SCALE))
    cv2.imwrite(args.out, np.concatenate(panels, axis=1))
    print(f"{args.out}: {args.policy} on {args.track} after {args.steps} steps, "
          f"gap to racing_line {core.distance[0, 1] - core.distance[0, 0]:+.2f} m")


if __name__ == "__main__":
    main()
