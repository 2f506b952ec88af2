"""Where the planner gains and loses behind a car: the time it spends, and the rate at which
the gap to the other car closes, by what it plans (following, its racing line, another lane)
and by how far behind it is. 2-car 3-lap races, the planner starting behind, 10 start points
per track (seed 7), the first 2 s (the launch) left out. Tracks: the tuning set (the 7
shipped and ``random:0-12``, or ``TRACKS``; never the routes).

    python experiments/planner/gap_by_mode.py                    # behind racing_line
    python experiments/planner/gap_by_mode.py blocker

The gap is the other car's race distance less the planner's (centre to centre) [m]; the rate
is positive where the planner gains [m/s]. Also prints the wins and passes (the gap turning
from positive to zero or less) per track. Two worker processes.
"""

from __future__ import annotations

import os
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np

BANDS = ((-1e9, 0.0), (0.0, 0.6), (0.6, 1.2), (1.2, 2.0), (2.0, 4.0), (4.0, 1e9))
"""Gap bands [m]: ahead, overlapping, close behind, ..., far behind."""
MODES = ("follow", "line", "other lane")
LAUNCH = 2.0
"""Time left out at the start of each race [s]."""


def one(job: tuple[str, str]) -> tuple[str, np.ndarray, int, int]:
    """Per track: (band, mode, [steps, gap change]) totals, the wins and the passes."""
    from h2h_racing.config.env import EnvConfig
    from h2h_racing.config.rules import RaceRules
    from h2h_racing.policies import make_driver
    from h2h_racing.sim.core import RaceCore
    from h2h_racing.track.io import load_track
    from h2h_racing.training.evaluate import grid_slots

    name, opponent = job
    track = load_track(name)
    starts = np.random.default_rng(7).uniform(0.0, track.length, 10)
    config = EnvConfig(track=name, num_cars=2, race_type="head_to_head",
                       rules=RaceRules(laps=3, time_limit=180.0), grid_spacing=0.75)
    core = RaceCore(config, track, num_envs=10)
    core.reset(seed=7, slots=grid_slots(10, "behind"), start=starts, rolling=0.0)
    drivers = [make_driver("planner"), make_driver(opponent)]
    for driver in drivers:
        driver.reset(core)
    totals = np.zeros((len(BANDS), len(MODES), 2))
    passes = 0
    while not core.done.all():
        actions = np.stack([d.act(core, car) for car, d in enumerate(drivers)], axis=1)
        gap = core.distance[:, 1] - core.distance[:, 0]
        choice = drivers[0].choice
        mode = np.where(choice < 0, 0, np.where(choice == 0, 1, 2))
        core.step(*config.commands(actions))
        live = ~core.done.any(axis=1) & (core.time > LAUNCH)
        after = core.distance[:, 1] - core.distance[:, 0]
        passes += int(np.sum(live & (gap > 0.0) & (after <= 0.0)))
        for band, (lo, hi) in enumerate(BANDS):
            for k in range(len(MODES)):
                sel = live & (gap >= lo) & (gap < hi) & (mode == k)
                totals[band, k] += (sel.sum(), (gap - after)[sel].sum())
    won = int(np.sum((core.rank[:, 0] == 1) & core.finished[:, 0]))
    return name, totals * np.array([core.dt, 1.0]), won, passes


def main() -> None:
    opponent = sys.argv[1] if len(sys.argv) > 1 else "racing_line"
    from h2h_racing.track.io import list_tracks

    names = (os.environ["TRACKS"].split(",") if "TRACKS" in os.environ
             else list_tracks() + [f"random:{k}" for k in range(13)])
    with ProcessPoolExecutor(2) as pool:
        results = list(pool.map(one, [(name, opponent) for name in names]))
    totals = sum(r[1] for r in results)
    print(f"planner behind {opponent}: won {sum(r[2] for r in results)} of {10 * len(names)}, "
          f"passes {sum(r[3] for r in results)}")
    print("gap [m]      | " + " | ".join(f"{m}: time [s], gain [m/s]" for m in MODES))
    for band, (lo, hi) in enumerate(BANDS):
        cells = []
        for k in range(len(MODES)):
            time, gained = totals[band, k]
            cells.append(f"{time:5.0f}, {gained / time if time else 0.0:+.3f}")
        label = f"{max(lo, -9):>4.1f} to {min(hi, 99):<4.1f}"
        print(f"{label} | " + " | ".join(cells))
    print("; ".join(f"{r[0]} {r[2]} won, {r[3]} passes" for r in results))


if __name__ == "__main__":
    main()
