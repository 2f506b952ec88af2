"""Does a camera policy leave the track because it is too fast, or because it loses the track?

    python experiments/camera/speed_capped.py POLICY TRACK[,TRACK...] [CAP ...]

One-lap attempts from 20 start points (``h2h-racing evaluate``'s protocol) with the policy's
speed action capped at each CAP (in [-1, 1]: 1 is no cap; -1 is 0.5 m/s, 1 is 4 m/s).
"""

from __future__ import annotations

import sys
from typing import Any

import numpy as np

from h2h_racing.policies import make_driver
from h2h_racing.training.evaluate import evaluate


class SpeedCapped:
    """A driver whose speed action is at most ``cap``."""

    def __init__(self, driver: Any, cap: float) -> None:
        self.driver, self.cap, self.name = driver, cap, f"speed action <= {cap:g}"

    def reset(self, core: Any) -> None:
        self.driver.reset(core)

    def act(self, core: Any, car: int) -> np.ndarray:
        action = np.array(self.driver.act(core, car), dtype=np.float64)
        action[:, 1] = np.minimum(action[:, 1], self.cap)
        return action


def main() -> None:
    policy, tracks = sys.argv[1], sys.argv[2].split(",")
    caps = [float(c) for c in sys.argv[3:]] or [1.0, 0.2, -0.2, -0.5]
    driver = make_driver(policy, seed=0)
    for track in tracks:
        for cap in caps:
            r = evaluate(SpeedCapped(driver, cap), track, episodes=20, seed=0)
            print(f"{track:16s} {r.driver:20s} laps {100 * r.lap_completion:5.1f} %  mean lap "
                  f"{r.mean_lap_time:6.2f} s  off-tracks {r.off_tracks}")


if __name__ == "__main__":
    main()
