"""Sweep the planner's tracking constants alone, on the shipped tracks, random tracks and hard
random tracks (never the routes of ../shared/data): 2-lap runs from 10 random start points per
track (seed 7), one line per setting and grip with the tracks left unclean, the off-tracks and
the flying (second) lap over the minimum-time reference.

    RANDOM=1,21 HARD=30 python experiments/planner/sweep_tracking.py \
        '{"STEER_SMOOTH": [0.5, 0.7]}' 0.8,0.95

Keys are constants of ``h2h_racing.policies.tracking``; ``RANDOM=a,b`` adds ``random:a`` ..
``random:b-1``; ``HARD=n`` adds n procedural training tracks drawn narrow (from 0.6 m), with
chicanes, tight circuits and clockwise laps (seeds 1000 ..).
"""

from __future__ import annotations

import itertools
import json
import os
import sys
import time

import numpy as np

from h2h_racing.config.env import EnvConfig
from h2h_racing.policies import tracking
from h2h_racing.policies.planner import Planner
from h2h_racing.policies.racing_line import reference_lap_time
from h2h_racing.track.io import list_tracks, load_track
from h2h_racing.training.evaluate import race_batch
from h2h_racing.training.tracks import random_training_track


def tracks() -> dict:
    first, last = map(int, os.environ.get("RANDOM", "1,21").split(","))
    loaded = {name: load_track(name) for name in
              list(list_tracks()) + [f"random:{k}" for k in range(first, last)]}
    for k in range(int(os.environ.get("HARD", "0"))):
        track = random_training_track(
            np.random.default_rng(1000 + k), varying_share=0.5, chicanes=(0, 3),
            tight_share=0.3, circuit_share=0.3, narrowest=0.6, length=(17.0, 60.0),
            reverse_share=0.5)
        loaded[f"hard:{k}:{track.name}"] = track
    return loaded


def main() -> None:
    grid = json.loads(sys.argv[1])
    grips = [float(g) for g in sys.argv[2].split(",")]
    config = EnvConfig()
    loaded = tracks()
    refs = {n: reference_lap_time(t, config.car, config.max_speed) for n, t in loaded.items()}
    keys = list(grid)
    for values in itertools.product(*[grid[k] for k in keys]):
        for key, value in zip(keys, values):
            setattr(tracking, key, value)
        for grip in grips:
            start, off, unclean, ratios = time.time(), 0, [], []
            for name, track in loaded.items():
                core = race_batch(name, track, [Planner(grip_factor=grip)], 2, 0.75,
                                  np.zeros((10, 1), dtype=np.int64),
                                  np.random.default_rng(7).uniform(0, track.length, 10), 7,
                                  0.0, None)
                count = int(core.off_tracks.sum())
                off += count
                if count or not core.finished.all():
                    unclean.append(f"{name}({count})")
                laps = [times[0][1] for times in core.lap_times if len(times[0]) > 1]
                ratios.append(np.mean(laps) / refs[name] if laps else np.nan)
            print(dict(zip(keys, values)), grip, f"off {off} unclean {len(unclean)}",
                  " ".join(unclean), f"| flying lap / reference: mean {np.nanmean(ratios):.4f}"
                  f" shipped {np.nanmean(ratios[:len(list_tracks())]):.4f}"
                  f" ({time.time() - start:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
