"""Sweep planner settings on the shipped tracks (never on the routes of ../shared/data): 2-car
3-lap races from behind against racing_line, blocker and pure_pursuit, one line per setting
with wins, crashes caused and off-tracks over ``races`` races per track and opponent (seed 7).

    python experiments/planner/sweep_settings.py '{"follow_gap": [0.1, 0.2]}' 10

``OPPONENTS=racing_line,blocker`` and ``TRACKS=oval,random:0,...`` (environment) choose the
opponents and tracks; the defaults are all three and the shipped tracks.
"""

from __future__ import annotations

import itertools
import json
import os
import sys
import time

import numpy as np

from h2h_racing.policies import make_driver
from h2h_racing.policies.planner import Planner
from h2h_racing.track.io import list_tracks, load_track
from h2h_racing.training.evaluate import grid_slots, race_batch

OPPONENTS = tuple(os.environ.get("OPPONENTS", "racing_line,blocker,pure_pursuit").split(","))


def main() -> None:
    grid = json.loads(sys.argv[1])
    races = int(sys.argv[2]) if len(sys.argv) > 2 else 10
    keys = list(grid)
    for values in itertools.product(*[grid[k] for k in keys]):
        settings = dict(zip(keys, values))
        cells, start = [], time.time()
        for opponent in OPPONENTS:
            total = np.zeros(3, dtype=np.int64)
            names = os.environ["TRACKS"].split(",") if "TRACKS" in os.environ else list_tracks()
            for name in names:
                track = load_track(name)
                starts = np.random.default_rng(7).uniform(0.0, track.length, races)
                core = race_batch(name, track, [Planner(**settings), make_driver(opponent)], 3,
                                  0.75, grid_slots(races, "behind"), starts, 7, 0.0, None)
                won = (core.rank[:, 0] == 1) & core.finished[:, 0]
                total += [won.sum(), core.crashes[:, 0].sum(), core.off_tracks[:, 0].sum()]
            cells.append(f"{opponent}: won {total[0]} crashes {total[1]} off {total[2]}")
        print(settings, " | ".join(cells), f"({time.time() - start:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
