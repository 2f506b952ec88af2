"""Is ppo_generalist's loss on Tokyo_Training_track its entry speed into the funnel? Its
one-lap attempts (``evaluate``'s 20 starts) with its speed command capped at CAP m/s from
FROM to TO metres of the lap, and nothing else changed.

    python experiments/routes/retrain/ppo_step6/tokyo/entry_speed.py TRACK FROM TO CAP [CAP ...]
"""

from __future__ import annotations

import sys

import numpy as np

from h2h_racing.policies import make_driver
from h2h_racing.training.evaluate import evaluate


class Capped:
    """``ppo_generalist`` with its speed action lowered to ``cap`` m/s where s is in
    [``start``, ``end``)."""

    def __init__(self, start: float, end: float, cap: float) -> None:
        self.driver = make_driver("ppo_generalist", seed=0)
        self.start, self.end, self.cap = start, end, cap
        self.name = f"ppo_generalist capped {cap} m/s"

    def reset(self, core) -> None:
        self.driver.reset(core)

    def act(self, core, car):
        action = np.array(self.driver.act(core, car), dtype=np.float32)
        where = (core.s[:, car] >= self.start) & (core.s[:, car] < self.end)
        # The speed action maps [-1, 1] linearly onto the speed range: invert it.
        _, _, mid, half = core.config.action_affine
        cap_action = (self.cap - mid) / half
        action[where, 1] = np.minimum(action[where, 1], cap_action)
        return action


def main() -> None:
    track, start, end = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
    base = evaluate("ppo_generalist", track, episodes=20)
    print(f"ppo_generalist: {100 * base.lap_completion:.0f} % laps, mean {base.mean_lap_time:.2f}"
          f" s, best {base.best_lap_time:.2f} s")
    for cap in sys.argv[4:]:
        r = evaluate(Capped(start, end, float(cap)), track, episodes=20)
        print(f"capped at {cap} m/s from {start} to {end} m: {100 * r.lap_completion:.0f} % "
              f"laps, mean {r.mean_lap_time:.2f} s, best {r.best_lap_time:.2f} s")


if __name__ == "__main__":
    main()
