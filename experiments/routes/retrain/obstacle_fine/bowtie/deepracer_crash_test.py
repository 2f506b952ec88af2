"""Object-avoidance races judged with DeepRacer's one-sided box crash test (a counterfactual).

    python experiments/routes/retrain/obstacle_fine/bowtie/deepracer_crash_test.py DRIVER \
        TRACK [TRACK ...] [--races 20] [--seed 0]

The env's boxes are pymunk bodies of DeepRacer's 0.4 x 0.5 m crash rectangle, and any contact
between a car and a box is a crash at the car's fault (``h2h_racing.sim.race.judge_contacts``):
a box's corner that grazes the car's side is one. DeepRacer counts a crash only when a corner
of the car's rectangle is inside the box's rectangle (``../shared/docs/deepracer_reference.md``
1.4: "the test is one-sided; it does not check the other object's corners inside this car"),
and that rectangle is the real box plus a 0.1 m buffer, so a car that grazes it with its side
touches nothing. This script races ``training.evaluate.evaluate_races``' races (the races of
``h2h-racing evaluate --race-type object_avoidance``) twice per track: as the env judges them,
and with the boxes made pymunk sensors (no physical contact) and a car-box crash reported on
the step a corner of the car comes inside a box's rectangle (DeepRacer's test, checked every
step as DeepRacer does at 15 Hz); car-car and bot contacts as before. Nothing in the env is
changed outside this process.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from h2h_racing.policies import make_driver
from h2h_racing.training.evaluate import evaluate_races


def car_corner_in_box(core) -> np.ndarray:
    """Whether a corner of each car is inside each box of its copy, (E, N, K)."""
    cfg = core.config
    local = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]]) * [0.5 * cfg.car.length,
                                                               0.5 * cfg.car.width]
    c, s = np.cos(core.yaw), np.sin(core.yaw)                      # (E, N)
    # Corners in track coordinates, (E, N, 4, 2).
    corners = core.position[:, :, None, :] + np.stack(
        [local[:, 0] * c[..., None] - local[:, 1] * s[..., None],
         local[:, 0] * s[..., None] + local[:, 1] * c[..., None]], axis=-1)
    rel = corners[:, :, None, :, :] - core.obstacle_position[:, None, :, None, :]
    bc, bs = np.cos(core.obstacle_yaw), np.sin(core.obstacle_yaw)   # (E, K)
    along = rel[..., 0] * bc[:, None, :, None] + rel[..., 1] * bs[:, None, :, None]
    across = -rel[..., 0] * bs[:, None, :, None] + rel[..., 1] * bc[:, None, :, None]
    inside = (np.abs(along) < 0.5 * cfg.obstacle_length) & (
        np.abs(across) < 0.5 * cfg.obstacle_width)
    return inside.any(axis=-1)


class DeepRacerJudge:
    """Wraps a driver; at each reset, makes the core's boxes sensors and its contacts
    DeepRacer's box test (see the module docstring)."""

    def __init__(self, driver) -> None:
        self.driver = driver
        self.name = getattr(driver, "name", type(driver).__name__)

    def reset(self, core) -> None:
        self.driver.reset(core)
        world = core.world
        e, n, k = core.num_envs, core.num_cars, core.num_obstacles
        first_box, first_bot = e * n, e * n + e * k
        for body in world._bodies[first_box:first_bot]:
            for shape in body.shapes:
                shape.sensor = True
        pymunk_contacts = world.pop_contacts
        was_in = np.zeros((e, n, k), dtype=bool)

        def contacts():
            a, b = pymunk_contacts()
            keep = ~(((a >= first_box) & (a < first_bot)) | ((b >= first_box) & (b < first_bot)))
            now = car_corner_in_box(core)
            new = now & ~was_in
            was_in[...] = now
            env, car, box = np.nonzero(new)
            return (np.concatenate([a[keep], env * n + car]),
                    np.concatenate([b[keep], first_box + env * k + box]))

        world.pop_contacts = contacts

    def act(self, core, car):
        return self.driver.act(core, car)


def figures(spec: str, track: str, races: int, seed: int, deepracer: bool) -> str:
    name, _, rest = spec.partition(":") if not spec.endswith(".pt") else (spec, "", "")
    options = {k: float(v) for k, v in (item.split("=") for item in rest.split(",") if item)}
    driver = make_driver(name, seed=seed, **options)
    r = evaluate_races(DeepRacerJudge(driver) if deepracer else driver, track,
                       "object_avoidance", races=races, laps=3, seed=seed)
    laps = max(r.laps_done, 1)
    ok = (r.finished >= 0.9 * r.races and r.crashes / laps <= 0.5 and r.resets / laps <= 1.0)
    return (f"{r.finished:2d}/{r.races}, {r.crashes / laps:5.2f}, {r.resets / laps:5.2f}"
            f" {'ok' if ok else 'MISSED'}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("driver", help="driver, shipped policy or policy.pt (options as "
                        "racing_line:box_clearance=0.2)")
    parser.add_argument("tracks", nargs="+", help="track names, files or folders of .npy")
    parser.add_argument("--races", type=int, default=20, help="races a track (default: "
                        "%(default)s)")
    parser.add_argument("--seed", type=int, default=0, help="seed (default: %(default)s, "
                        "as h2h-racing evaluate)")
    args = parser.parse_args()
    tracks = []
    for item in args.tracks:
        path = Path(item)
        tracks += sorted(str(p) for p in path.glob("*.npy")) if path.is_dir() else [item]
    print(f"{args.driver}: finished, crashes a lap, resets a lap")
    print(f"{'track':28s} | {'the env (any contact)':24s} | DeepRacer's test (car corner in box)")
    met = [0, 0]
    for track in tracks:
        env = figures(args.driver, track, args.races, args.seed, False)
        deepracer = figures(args.driver, track, args.races, args.seed, True)
        met[0] += env.endswith("ok")
        met[1] += deepracer.endswith("ok")
        print(f"{Path(track).stem:28s} | {env:24s} | {deepracer}", flush=True)
    print(f"on target: {met[0]} of {len(tracks)} as the env judges, {met[1]} with DeepRacer's "
          f"test")


if __name__ == "__main__":
    main()
