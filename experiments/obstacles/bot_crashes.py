"""Where does a driver crash into the bots? The geometry of each crash in head-to-bot races.

    python experiments/obstacles/bot_crashes.py POLICY [--seeds 1 2 3 4 5 6]

On every catalogue track and DeepRacer route of ``evaluate_races.py``, 3-lap head-to-bot
races; at each crash the driver is charged with, the nearest bot's arc gap (+ ahead) and both
cars' lateral offsets, 3 steps (0.2 s) before and at the crash, and the driver's speed 0.2 s
before.
``toward`` marks a bot whose offset moved toward the driver's in those 3 steps (a lane change
across its line).
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from evaluate_races import ROUTES, SEEDS, parse_driver  # type: ignore[import-not-found]
from h2h_racing.match import run_race
from h2h_racing.policies import make_driver
from h2h_racing.track.io import list_tracks

BEFORE = 3
"""Steps before the crash whose state is shown."""


class CrashWatch:
    """Wraps a driver; records the nearest bot's geometry at each crash it is charged with."""

    def __init__(self, driver: Any) -> None:
        self.driver, self.name = driver, getattr(driver, "name", type(driver).__name__)
        self.rows: list[tuple[tuple[float, ...], tuple[float, ...]]] = []
        self._history: list[tuple[float, ...]] = []
        self._crashes = 0

    def reset(self, core: Any) -> None:
        self.driver.reset(core)
        self._history, self._crashes = [], 0

    def act(self, core: Any, car: int) -> np.ndarray:
        length = core.track.length
        gap = core.bot_s[0] - core.s[0, car]
        gap = gap - length * np.floor(gap / length + 0.5)
        bot = int(np.argmin(np.abs(gap)))
        self._history.append((float(gap[bot]), float(core.d[0, car]), float(core.bot_d[0, bot]),
                              float(core.speed[0, car])))
        crashes = int(core.crashes[0, car])
        if crashes > self._crashes and len(self._history) > BEFORE:
            self.rows.append((self._history[-1 - BEFORE], self._history[-1]))
        self._crashes = crashes
        return self.driver.act(core, car)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("policy", help="driver, shipped policy or policy.pt")
    parser.add_argument("--seeds", nargs="+", type=int, default=list(SEEDS),
                        help="race seeds (default: %(default)s)")
    args = parser.parse_args()
    name, options = parse_driver(args.policy)
    tracks = list_tracks() + [str(p) for p in sorted(ROUTES.glob("*.npy"))]
    crashes = ahead = toward = 0
    for track in tracks:
        for seed in args.seeds:
            watch = CrashWatch(make_driver(name, seed=seed, **options))
            run_race(track, [watch], race_type="head_to_bot", laps=3, seed=seed)
            for (gap0, d0, bot0, speed), (gap1, d1, bot1, _) in watch.rows:
                moved = abs(bot1 - d1) < abs(bot0 - d0)
                ahead += gap0 > 0
                toward += moved
                crashes += 1
                print(f"{track.split('/')[-1]:20s} seed {seed}  before: gap {gap0:+.2f} m, "
                      f"offsets {d0:+.2f} / bot {bot0:+.2f}, speed {speed:.2f} m/s  at: gap "
                      f"{gap1:+.2f} m, offsets {d1:+.2f} / bot {bot1:+.2f}"
                      f"{'  toward' if moved else ''}")
    print(f"{crashes} crashes into bots; the bot ahead 0.2 s before: {ahead}; its offset moving "
          f"toward ours: {toward}")


if __name__ == "__main__":
    main()
