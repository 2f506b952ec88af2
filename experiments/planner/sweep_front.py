"""The planner in front of `league_racer` on the tuning tracks (the 7 shipped and
``random:0-12``, or ``TRACKS``; never the routes): 2-car 3-lap races, the planner on pole,
10 start points per track (seed 7). Prints the races won and, of the races lost, when
`league_racer` first got 0.3 m ahead: in the first 3 s (off the grid), at 3-10 s, or later.

    python experiments/planner/sweep_front.py            # the planner's defaults
    python experiments/planner/sweep_front.py planner:cover_gap=3
    PLANNER='{"COVER_BONUS": 0.5}' python experiments/planner/sweep_front.py

``PLANNER`` (environment, JSON) sets module constants of ``h2h_racing.policies.planner``
that are read in Python each step (the defence's, not the compiled kernel's) for the run.
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np

from h2h_racing.config.env import EnvConfig
from h2h_racing.config.rules import RaceRules
from h2h_racing.policies import make_driver
from h2h_racing.policies import planner as planner_module
from h2h_racing.sim.core import RaceCore
from h2h_racing.track.io import list_tracks, load_track

TUNING = list_tracks() + [f"random:{k}" for k in range(13)]


def main() -> None:
    spec = sys.argv[1] if len(sys.argv) > 1 else "planner"
    for key, value in json.loads(os.environ.get("PLANNER", "{}")).items():
        if not hasattr(planner_module, key):
            raise SystemExit(f"PLANNER: h2h_racing.policies.planner has no {key!r}")
        setattr(planner_module, key, value)
    names = os.environ["TRACKS"].split(",") if "TRACKS" in os.environ else TUNING
    won, passed = 0, []
    for name in names:
        track = load_track(name)
        starts = np.random.default_rng(7).uniform(0.0, track.length, 10)
        config = EnvConfig(track=name, num_cars=2, race_type="head_to_head",
                           rules=RaceRules(laps=3, time_limit=180.0), grid_spacing=0.75)
        core = RaceCore(config, track, num_envs=10)
        core.reset(seed=7, slots=np.tile(np.array([0, 1]), (10, 1)), start=starts, rolling=0.0)
        drivers = [make_driver(spec), make_driver("league_racer")]
        for driver in drivers:
            driver.reset(core)
        first = np.full(10, np.nan)
        while not core.done.all():
            actions = np.stack([d.act(core, c) for c, d in enumerate(drivers)], axis=1)
            core.step(*config.commands(actions))
            ahead = (core.distance[:, 1] > core.distance[:, 0] + 0.3) & ~core.done.any(axis=1)
            first = np.where(np.isnan(first) & ahead, core.time, first)
        wins = (core.rank[:, 0] == 1) & core.finished[:, 0]
        won += int(wins.sum())
        passed += list(first[~wins])
    at = np.array(passed)
    print(f"{spec}: won {won} of {10 * len(names)}; lost, league_racer ahead first at "
          f"< 3 s: {np.sum(at < 3)}, 3-10 s: {np.sum((at >= 3) & (at < 10))}, "
          f">= 10 s: {np.sum(at >= 10)}, never: {np.sum(np.isnan(at))}", flush=True)


if __name__ == "__main__":
    main()
