"""The planner's two field contests on a list of tuning tracks (never the routes of
../shared/data): the 4-car field from the back (against racing_line, blocker and
pure_pursuit, their order rotated) and four planners, 10 races each per track (seed 7).

    python experiments/planner/sweep_fields.py planner:follow_gap=0.08 oval,technical,random:0
"""

from __future__ import annotations

import sys
import time

import numpy as np

from evaluate_planner import _batch
from h2h_racing.policies import make_driver

ORDERS = np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1], [0, 2, 1], [2, 1, 0], [1, 0, 2]])


def main() -> None:
    spec, tracks, races = sys.argv[1], sys.argv[2].split(","), 10
    total = dict.fromkeys(("field_won", "field_crashes", "four_finished", "four_crashes",
                           "four_off"), 0)
    start = time.time()
    for track in tracks:
        slots = np.stack([np.concatenate([[3], ORDERS[k % 6]]) for k in range(races)])
        field = [make_driver(spec)] + [make_driver(o) for o in
                                       ("racing_line", "blocker", "pure_pursuit")]
        core = _batch(track, field, slots, 7)
        total["field_won"] += int(((core.rank[:, 0] == 1) & core.finished[:, 0]).sum())
        total["field_crashes"] += int(core.crashes[:, 0].sum())
        core = _batch(track, [make_driver(spec) for _ in range(4)],
                      np.tile(np.arange(4), (races, 1)), 7)
        total["four_finished"] += int(core.finished.all(axis=1).sum())
        total["four_crashes"] += int(core.crashes.sum())
        total["four_off"] += int(core.off_tracks.sum())
    print(spec, total, f"({time.time() - start:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
