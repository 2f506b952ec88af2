"""Measure `planner` against issue 34's targets, per track, and write the figures as JSON.

Per track (every shipped track, and every route in ../shared/data/deepracer_tracks when it is
there), all races 3 laps, standing start, the grid's 0.75 m gap, start points drawn from the
seed (the same for every driver):

* ``behind``: 2-car races, the planner always in the slot behind, against `racing_line`,
  `blocker` and `pure_pursuit`: wins, passes, crashes caused and off-tracks per race;
* ``field``: 4-car races, the planner last on the grid behind `racing_line`, `pure_pursuit` and
  `blocker` (their order rotated over the races): wins, crashes caused, off-tracks;
* ``four``: four planners: races every car finished, crashes (all cars) per race;
* ``front``: 2-car races, the planner in front of `league_racer`: wins and defences;
* ``alone``: one-lap attempts alone (`evaluate`, training rules): laps, mean lap, off-tracks,
  against the minimum-time reference lap (`reference_lap_time`) and `racing_line`'s lap;
* ``pace``: `planner:grip_factor=0.6` (racing_line's own grip) behind `racing_line`: wins.

    python experiments/planner/evaluate_planner.py --out experiments/planner/figures/default.json

Tracks run in parallel worker processes (``--workers``); the JSON is rewritten after every
track, so a stopped run keeps what it measured. Summarise with ``summarise_planner.py``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

ROUTES = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "deepracer_tracks"
OPPONENTS = ("racing_line", "blocker", "pure_pursuit")


def _batch(track: str, drivers: list, slots: np.ndarray, seed: int):
    """Race ``drivers`` (car i is drivers[i]) once per row of ``slots``; returns the core."""
    from h2h_racing.track.io import load_track
    from h2h_racing.training.evaluate import race_batch

    loaded = load_track(track)
    starts = np.random.default_rng(seed).uniform(0.0, loaded.length, len(slots))
    return race_batch(track, loaded, drivers, 3, 0.75, slots, starts, seed, 0.0, None)


def measure(track: str, races: int, seed: int, spec: str) -> dict:
    """Every figure of one track (see the module docstring)."""
    from h2h_racing.policies import make_driver, reference_lap_time
    from h2h_racing.track.io import load_track
    from h2h_racing.training.evaluate import evaluate

    out: dict = {"track": track, "races": races}
    behind = np.stack([np.ones(races, dtype=np.int64), np.zeros(races, dtype=np.int64)], 1)
    for opponent in OPPONENTS:
        core = _batch(track, [make_driver(spec), make_driver(opponent)], behind, seed)
        won = (core.rank[:, 0] == 1) & core.finished[:, 0]
        out[f"behind_{opponent}"] = {
            "won": int(won.sum()), "passes": int(core.overtakes[:, 0].sum()),
            "crashes": int(core.crashes[:, 0].sum()), "off": int(core.off_tracks[:, 0].sum()),
            "finished": int(core.finished[:, 0].sum()),
            "opponent_crashes": int(core.crashes[:, 1].sum())}
    # 4-car field: the planner last (slot 3), the others' order rotated race by race.
    orders = np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1], [0, 2, 1], [2, 1, 0], [1, 0, 2]])
    slots = np.stack([np.concatenate([[3], orders[k % 6]]) for k in range(races)])
    core = _batch(track, [make_driver(spec)] + [make_driver(o) for o in OPPONENTS], slots, seed)
    won = (core.rank[:, 0] == 1) & core.finished[:, 0]
    out["field"] = {"won": int(won.sum()), "crashes": int(core.crashes[:, 0].sum()),
                    "off": int(core.off_tracks[:, 0].sum()),
                    "finished": int(core.finished[:, 0].sum())}
    four = np.tile(np.arange(4), (races, 1))
    core = _batch(track, [make_driver(spec) for _ in range(4)], four, seed)
    out["four"] = {"all_finished": int(core.finished.all(axis=1).sum()),
                   "crashes": int(core.crashes.sum()), "off": int(core.off_tracks.sum())}
    front = np.stack([np.zeros(races, dtype=np.int64), np.ones(races, dtype=np.int64)], 1)
    core = _batch(track, [make_driver(spec), make_driver("league_racer")], front, seed)
    won = (core.rank[:, 0] == 1) & core.finished[:, 0]
    out["front_league_racer"] = {"won": int(won.sum()), "defences": int(core.defences[:, 0].sum()),
                                 "crashes": int(core.crashes[:, 0].sum()),
                                 "off": int(core.off_tracks[:, 0].sum())}
    loaded = load_track(track)
    from h2h_racing.config.env import EnvConfig

    config = EnvConfig()
    alone = evaluate(make_driver(spec), track, episodes=races, seed=seed)
    line = evaluate(make_driver("racing_line"), track, episodes=races, seed=seed)
    out["alone"] = {"laps": alone.lap_completion, "mean_lap": alone.mean_lap_time,
                    "off": alone.off_tracks, "racing_line_lap": line.mean_lap_time,
                    "reference_lap": reference_lap_time(loaded, config.car, config.max_speed)}
    core = _batch(track, [make_driver(f"{spec}:grip_factor=0.6"), make_driver("racing_line")],
                  behind, seed)
    out["pace_0.6_behind_racing_line"] = {
        "won": int(((core.rank[:, 0] == 1) & core.finished[:, 0]).sum()),
        "crashes": int(core.crashes[:, 0].sum())}
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", required=True, help="JSON file to write")
    parser.add_argument("--races", type=int, default=10,
                        help="races (and lap attempts) per track and contest (default: 10)")
    parser.add_argument("--seed", type=int, default=7, help="start points' seed (default: 7)")
    parser.add_argument("--driver", default="planner",
                        help="the driver spec measured, e.g. planner:grip_factor=0.7 "
                             "(default: planner)")
    parser.add_argument("--tracks", default="all", choices=["all", "shipped", "routes"],
                        help="shipped tracks, the routes in ../shared/data, or both "
                             "(default: all)")
    parser.add_argument("--workers", type=int, default=2, help="processes (default: 2)")
    args = parser.parse_args(argv)
    from h2h_racing.track.io import list_tracks

    tracks = [] if args.tracks == "routes" else list(list_tracks())
    if args.tracks != "shipped":
        if ROUTES.is_dir():
            tracks += sorted(str(p) for p in ROUTES.glob("*.npy"))
        else:
            print(f"no routes at {ROUTES}: shipped tracks only", file=sys.stderr)
    results: list[dict] = []
    start = time.time()
    with ProcessPoolExecutor(args.workers) as pool:
        jobs = {pool.submit(measure, t, args.races, args.seed, args.driver): t for t in tracks}
        for job in as_completed(jobs):
            results.append(job.result())
            results.sort(key=lambda r: tracks.index(r["track"]))
            Path(args.out).write_text(json.dumps(
                {"driver": args.driver, "races": args.races, "seed": args.seed,
                 "seconds": round(time.time() - start), "tracks": results}, indent=1))
            print(f"{len(results)}/{len(tracks)} {Path(jobs[job]).stem} "
                  f"({time.time() - start:.0f} s)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
