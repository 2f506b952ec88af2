"""Planner contests on procedural tracks drawn as the routes of ../shared/data are (the
generator settings of `ppo_generalist/routes`: widths 0.6-2 m, laps up to 90 m, circuits of
tight corners, chicanes, coarse and uneven waypoints), never on the routes themselves:
10 races per track (seed 7), the planner from behind, or four planners together.

    python experiments/planner/sweep_routelike.py 30            # 30 tracks, every contest
    CONTESTS=four python experiments/planner/sweep_routelike.py 30

Prints, per contest, the sums over the tracks: ``four`` (crashes of all cars, races every car
finished), ``field`` (won from the back of racing_line, blocker, pure_pursuit; crashes caused),
``racing_line`` and ``blocker`` (won from behind, crashes caused, off-tracks).
"""

from __future__ import annotations

import os
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np

CONTESTS = tuple(os.environ.get("CONTESTS", "four,field,racing_line,blocker").split(","))


def route_like(k: int):
    """Track ``k`` of the set (its own seed, 1000 + k)."""
    from h2h_racing.training.tracks import random_training_track

    return random_training_track(
        np.random.default_rng(1000 + k), varying_share=0.3, min_radius=0.5,
        length=(15.0, 90.0), reverse_share=0.5, chicanes=(1, 4), tight_share=0.3,
        circuit_share=0.3, circuit_corners="long", narrowest=0.6, widest=2.0,
        waypoint_gap=(0.05, 0.8))


def measure(k: int) -> dict[str, tuple[int, ...]]:
    """Every contest of ``CONTESTS`` on track ``k``."""
    from h2h_racing.policies import make_driver
    from h2h_racing.training.evaluate import race_batch

    track = route_like(k)
    starts = np.random.default_rng(7).uniform(0.0, track.length, 10)

    def race(drivers: list, slots: np.ndarray):
        # The name only labels the env config; the geometry is the generated track's.
        return race_batch("oval", track, drivers, 3, 0.75, slots, starts, 7, 0.0, None)

    out: dict[str, tuple[int, ...]] = {}
    if "four" in CONTESTS:
        core = race([make_driver("planner") for _ in range(4)], np.tile(np.arange(4), (10, 1)))
        out["four"] = (int(core.crashes.sum()), int(core.finished.all(axis=1).sum()))
    if "field" in CONTESTS:
        orders = np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1], [0, 2, 1], [2, 1, 0], [1, 0, 2]])
        slots = np.stack([np.concatenate([[3], orders[i % 6]]) for i in range(10)])
        field = [make_driver(name) for name in ("planner", "racing_line", "blocker",
                                                "pure_pursuit")]
        core = race(field, slots)
        out["field"] = (int(((core.rank[:, 0] == 1) & core.finished[:, 0]).sum()),
                        int(core.crashes[:, 0].sum()))
    behind = np.stack([np.ones(10, dtype=np.int64), np.zeros(10, dtype=np.int64)], 1)
    for opponent in ("racing_line", "blocker"):
        if opponent in CONTESTS:
            core = race([make_driver("planner"), make_driver(opponent)], behind)
            out[opponent] = (int(((core.rank[:, 0] == 1) & core.finished[:, 0]).sum()),
                             int(core.crashes[:, 0].sum()), int(core.off_tracks[:, 0].sum()))
    return out


def main() -> None:
    count = int(sys.argv[1]) if len(sys.argv) > 1 else 30
    with ProcessPoolExecutor(2) as pool:
        results = list(pool.map(measure, range(count)))
    totals: dict[str, tuple[int, ...]] = {}
    for result in results:
        for key, value in result.items():
            totals[key] = tuple(a + b for a, b in zip(totals.get(key, (0,) * len(value)),
                                                      value))
    print(f"{10 * count} races:", totals, flush=True)


if __name__ == "__main__":
    main()
