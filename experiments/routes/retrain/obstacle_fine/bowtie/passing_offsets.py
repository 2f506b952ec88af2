"""How far from a box each driver passes it: the car's offset beside each box of the first
lap of ``evaluate --race-type object_avoidance``'s races, in the boxes' tight places.

    python experiments/routes/retrain/obstacle_fine/bowtie/passing_offsets.py TRACK \
        DRIVER [DRIVER ...] [--races 20] [--seed 0]

For each driver, each race and each box, the car's lateral offset d on the step its arc
position passes the box's centre (first lap, crashes or not), and the gap between the car's
side and the box's side there (``|d - box d| - (box width + car width) / 2``; negative: they
overlap across the track, which on a bend's inside-lane box is a crash). Printed for the boxes
with less than ``box_room.TIGHT_ROOM`` beside them: mean and range over the races.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.policies import make_driver
from h2h_racing.sim.core import RaceCore
from h2h_racing.track.io import load_track

from box_room import TIGHT_ROOM  # noqa: E402 (run as a script from this folder's path)


def offsets(spec: str, track_path: str, races: int,
            seed: int) -> tuple[list[tuple[float, float, float]], int]:
    """``(box s, car d, side gap)`` of every tight box passed on the first lap, and how many
    tight boxes the races have."""
    track = load_track(track_path)
    rules = dataclasses.replace(RaceRules.preset("object_avoidance"), laps=3, time_limit=180.0)
    cfg = EnvConfig(track=track_path, num_cars=1, race_type="object_avoidance", rules=rules,
                    randomize_obstacles=True)
    core = RaceCore(cfg, track, num_envs=races)
    core.reset(seed=seed)
    name, _, rest = spec.partition(":") if not spec.endswith(".pt") else (spec, "", "")
    options = {k: float(v) for k, v in (item.split("=") for item in rest.split(",") if item)}
    driver = make_driver(name, seed=seed, **options)
    driver.reset(core)
    k_box = track.curvature_at(core.obstacle_s.ravel()).reshape(core.obstacle_s.shape)
    left, right = track.half_widths_at(core.obstacle_s.ravel())
    left, right = left.reshape(k_box.shape), right.reshape(k_box.shape)
    bd = core.obstacle_d
    half_w, half_l = 0.5 * cfg.obstacle_width, 0.5 * cfg.obstacle_length
    inside = np.sign(bd) == np.sign(k_box)
    with np.errstate(divide="ignore", invalid="ignore"):
        r_edge = 1.0 / np.abs(k_box) - np.abs(bd) + half_w
        bulge = np.where(inside, np.sqrt(r_edge ** 2 + half_l ** 2) - r_edge, 0.0)
    room = np.where(bd > 0, right, left) + np.abs(bd) - half_w - bulge
    out: list[tuple[float, float, float]] = []
    seen = np.zeros(core.obstacle_s.shape, dtype=bool)
    prev = core.distance[:, 0].copy()
    start = core.distance[:, 0].copy()
    while not core.done.all():
        core.step(*cfg.commands(np.asarray(driver.act(core, 0))[:, None, :]))
        now = core.distance[:, 0]
        lap_pos_prev, lap_pos = prev - start, now - start
        crossed = ((lap_pos_prev[:, None] < core.obstacle_s) & (lap_pos[:, None] >= core.obstacle_s)
                   & ~seen & (now - prev < 1.0)[:, None])
        for e, b in zip(*np.nonzero(crossed)):
            seen[e, b] = True
            if room[e, b] < TIGHT_ROOM:
                d = float(core.d[e, 0])
                gap = abs(d - bd[e, b]) - half_w - 0.5 * cfg.car.width
                out.append((float(core.obstacle_s[e, b]), d, gap))
        prev = now.copy()
        if (lap_pos > track.length).all():
            break
    return out, int((room < TIGHT_ROOM).sum())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("track", help="track name or file")
    parser.add_argument("drivers", nargs="+", help="drivers (options as racing_line:k=v,...)")
    parser.add_argument("--races", type=int, default=20, help="races (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=0, help="seed (default: %(default)s)")
    args = parser.parse_args()
    for spec in args.drivers:
        rows, tight = offsets(spec, args.track, args.races, args.seed)
        if not rows:
            print(f"{spec}: no tight box passed")
            continue
        gaps = np.array([g for _, _, g in rows])
        print(f"{spec[:40]:40s} {len(rows)} of {tight} tight boxes passed on lap 1: "
              f"side gap at the box's centre "
              f"mean {100 * gaps.mean():+.1f} cm, {100 * gaps.min():+.1f} to "
              f"{100 * gaps.max():+.1f} cm; |d| mean {np.mean([abs(d) for _, d, _ in rows]):.3f} m")


if __name__ == "__main__":
    main()
