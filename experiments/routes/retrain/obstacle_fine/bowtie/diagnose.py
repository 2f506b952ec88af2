"""Where a driver crashes into boxes in object-avoidance races on one track, and what is there.

    python experiments/routes/retrain/obstacle_fine/bowtie/diagnose.py DRIVER TRACK \
        [--races 20] [--seed 0]

Runs ``h2h-racing evaluate --race-type object_avoidance``'s races (``training.evaluate``'s
core: one car, 3 laps, DeepRacer's 6 boxes re-drawn per race from ``--seed``) and prints, for
every crash, the race, the car's arc position and offset, the box it hit (arc position, lane,
offset), the track's half-widths and curvature there, and the free width beside the box on
its other side; then crashes per race and a histogram of crash positions along the lap.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.policies import make_driver
from h2h_racing.sim.core import RaceCore
from h2h_racing.track.io import load_track
from h2h_racing.track.shape import CAR_WIDTH


def corners(centre: np.ndarray, yaw: float, length: float, width: float) -> np.ndarray:
    """The 4 corners of a ``length`` x ``width`` rectangle at ``centre`` heading ``yaw``."""
    c, s = np.cos(yaw), np.sin(yaw)
    local = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]]) * [0.5 * length, 0.5 * width]
    return centre + local @ np.array([[c, s], [-s, c]])


def inside(points: np.ndarray, centre: np.ndarray, yaw: float, length: float,
           width: float) -> bool:
    """Whether any of ``points`` lies inside the rectangle (DeepRacer's crash test)."""
    c, s = np.cos(yaw), np.sin(yaw)
    rel = (points - centre) @ np.array([[c, -s], [s, c]])
    return bool(((np.abs(rel[:, 0]) < 0.5 * length) & (np.abs(rel[:, 1]) < 0.5 * width)).any())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("driver", help="driver, shipped policy or policy.pt; options as "
                        "racing_line:box_clearance=0.2,box_speed_cap=1.8")
    parser.add_argument("track", help="track name or file")
    parser.add_argument("--races", type=int, default=20, help="races (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=0, help="seed (default: %(default)s)")
    parser.add_argument("--min-gap", type=float, default=None,
                        help="EnvConfig.obstacle_min_gap [m] (default: the env's)")
    args = parser.parse_args()
    track = load_track(args.track)
    rules = dataclasses.replace(RaceRules.preset("object_avoidance"), laps=3, time_limit=180.0)
    extra = {} if args.min_gap is None else {"obstacle_min_gap": args.min_gap}
    cfg = EnvConfig(track=args.track, num_cars=1, race_type="object_avoidance", rules=rules,
                    randomize_obstacles=True, **extra)
    core = RaceCore(cfg, track, num_envs=args.races)
    core.reset(seed=args.seed)
    name, _, rest = args.driver.partition(":") if not args.driver.endswith(".pt") else (
        args.driver, "", "")
    options = {k: float(v) for k, v in (item.split("=") for item in rest.split(",") if item)}
    driver = make_driver(name, seed=args.seed, **options)
    driver.reset(core)
    length = track.length
    print(f"{track.name}: {length:.2f} m, width {sum(track.half_widths_at(np.zeros(1)))[0]:.2f}"
          f" m at s=0, min width {track.min_width:.2f} m; box {cfg.obstacle_length} x "
          f"{cfg.obstacle_width} m, car {CAR_WIDTH} m wide")
    for e in range(min(args.races, 20)):
        order = np.argsort(core.obstacle_s[e] % length)
        print(f"race {e:2d} boxes (s, lane): " + ", ".join(
            f"{core.obstacle_s[e, k] % length:5.2f}{'L' if core.obstacle_lane[e, k] > 0 else 'R'}"
            for k in order))
    crashes_at: list[float] = []
    kinds: list[tuple[bool, bool]] = []
    prev = core.crashes[:, 0].copy()
    pose = (core.s[:, 0].copy(), core.d[:, 0].copy(), core.speed[:, 0].copy())
    print("race  car s   car d  speed | box s  lane  box d | half L  half R  curv  | "
          "free other side")
    while not core.done.all():
        core.step(*cfg.commands(np.asarray(driver.act(core, 0))[:, None, :]))
        hit = np.nonzero(core.crashes[:, 0] > prev)[0]
        for e in hit:
            s, d, v = pose[0][e], pose[1][e], pose[2][e]
            gap = (core.obstacle_s[e] - s + 0.5 * length) % length - 0.5 * length
            k = int(np.argmin(np.abs(gap)))
            bs = core.obstacle_s[e, k] % length
            bd = core.obstacle_d[e, k]
            left, right = track.half_widths_at(np.array([bs]))
            free = (left[0] - (bd + cfg.obstacle_width / 2) if bd < 0
                    else (bd - cfg.obstacle_width / 2) + right[0])
            curv = float(track.curvature_at(np.array([bs]))[0])
            crashes_at.append(float(bs))
            # DeepRacer counts a crash when a corner of the car is inside the box's rectangle
            # (one-sided); pymunk's contact is any overlap, a box corner in the car's side too.
            car_c = corners(core.position[e, 0], core.yaw[e, 0], cfg.car.length, cfg.car.width)
            box_c = corners(core.obstacle_position[e, k], core.obstacle_yaw[e, k],
                            cfg.obstacle_length, cfg.obstacle_width)
            one_sided = inside(car_c, core.obstacle_position[e, k], core.obstacle_yaw[e, k],
                               cfg.obstacle_length, cfg.obstacle_width)
            other_way = inside(box_c, core.position[e, 0], core.yaw[e, 0], cfg.car.length,
                               cfg.car.width)
            kinds.append((one_sided, other_way))
            print(f"{e:4d} {s:6.2f} {d:+6.2f} {v:5.2f} | {bs:5.2f} {core.obstacle_lane[e, k]:+4.0f}"
                  f" {bd:+6.2f} | {left[0]:6.2f} {right[0]:6.2f} {curv:+5.2f} | {free:5.2f} "
                  f"{'car corner in box' if one_sided else ''}"
                  f"{' box corner in car' if other_way else ''}")
        prev = core.crashes[:, 0].copy()
        pose = (core.s[:, 0].copy(), core.d[:, 0].copy(), core.speed[:, 0].copy())
    print("crashes per race:", core.crashes[:, 0].tolist())
    print("finished:", int(core.finished[:, 0].sum()), "of", args.races, "laps:",
          int(np.minimum(core.laps[:, 0], 3).sum()), "resets:", int(core.resets[:, 0].sum()))
    if kinds:
        print(f"at the crash step: a car corner in the box (DeepRacer's test) "
              f"{sum(a for a, _ in kinds)} of {len(kinds)}, a box corner in the car "
              f"{sum(b for _, b in kinds)}, neither {sum(not (a or b) for a, b in kinds)}")
    if crashes_at:
        hist, edges = np.histogram(crashes_at, bins=np.arange(0, length + 1.0, 1.0))
        print("crashes by box position (1 m bins):",
              ", ".join(f"{edges[i]:.0f}-{edges[i + 1]:.0f} m: {h}"
                        for i, h in enumerate(hist) if h))


if __name__ == "__main__":
    main()
