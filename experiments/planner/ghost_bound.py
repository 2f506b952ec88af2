"""What pace alone would win from behind: each driver alone from its grid slot, the first
0.75 m back (the grid's gap), the second from the start line; the first "wins" a start point
if it covers 3 laps + 0.75 m sooner than the second covers 3 laps (10 start points a track,
seed 7, as the contests of `sweep_settings.py`). The tracks default to the tuning set (the 7
shipped and `random:0-12`), never the routes of ../shared/data.

    python experiments/planner/ghost_bound.py                        # planner vs racing_line
    python experiments/planner/ghost_bound.py planner blocker oval,technical

Prints, per track, the wins, the mean margin [s] and the lap-time margin, then the total:
an upper bound for racecraft (races are lost to blocking, never won by it).
"""

from __future__ import annotations

import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np

TUNING = ",".join(["grand_loop", "hairpin_valley", "kidney", "oval", "speedway", "technical",
                   "varying"] + [f"random:{k}" for k in range(13)])
GRID_GAP = 0.75
"""Distance the first driver starts behind [m] (EnvConfig's grid spacing)."""


def alone(job: tuple[str, str, float]) -> np.ndarray:
    """Times [s] at which ``spec`` alone on ``name``, starting ``back`` metres behind each
    start point, has covered 3 laps + ``back`` (nan: not within 120 s)."""
    from h2h_racing.config.env import EnvConfig
    from h2h_racing.config.rules import RaceRules
    from h2h_racing.policies import make_driver
    from h2h_racing.sim.core import RaceCore
    from h2h_racing.track.io import load_track

    name, spec, back = job
    track = load_track(name)
    starts = np.random.default_rng(7).uniform(0.0, track.length, 10) - back
    config = EnvConfig(track=name, num_cars=1, race_type="time_trial",
                       rules=RaceRules(laps=4, time_limit=180.0))
    core = RaceCore(config, track, num_envs=10)
    core.reset(seed=7, start=starts, rolling=0.0)
    driver = make_driver(spec)
    driver.reset(core)
    start = core.distance[:, 0].copy()
    done = np.full(10, np.nan)
    while np.isnan(done).any() and core.time[0] < 120.0:
        core.step(*config.commands(driver.act(core, 0)[:, None, :]))
        now = np.isnan(done) & (core.distance[:, 0] - start >= 3 * track.length + back)
        done[now] = core.time[now]
    return done


def main() -> None:
    first = sys.argv[1] if len(sys.argv) > 1 else "planner"
    second = sys.argv[2] if len(sys.argv) > 2 else "racing_line"
    names = (sys.argv[3] if len(sys.argv) > 3 else TUNING).split(",")
    jobs = [(n, first, GRID_GAP) for n in names] + [(n, second, 0.0) for n in names]
    with ProcessPoolExecutor(2) as pool:
        times = list(pool.map(alone, jobs))
    total = 0
    for k, name in enumerate(names):
        behind, ahead = times[k], times[len(names) + k]
        won = int(np.sum(behind < ahead))
        total += won
        print(f"{name}: {won} of 10, margin {np.nanmean(ahead - behind):+.2f} s, lap "
              f"{100 * np.nanmean(ahead / behind - 1):+.1f} %")
    print(f"{first} from {GRID_GAP} m behind {second}, on pace alone: {total} of "
          f"{10 * len(names)}")


if __name__ == "__main__":
    main()
