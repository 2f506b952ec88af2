"""How often DeepRacer's 6 random boxes, as the env draws them, make a slalom the car cannot
steer through, per track.

    python experiments/obstacles/impassable_slaloms.py [MIN_GAP] [ROUTE.npy ...]

MIN_GAP is ``EnvConfig.obstacle_min_gap`` [m] (default 2.0, env v4; 0 draws as env v3 did).

A slalom is two consecutive boxes passed on opposite sides. Passing a box, the car's centre
stays ``obstacle_width / 2 + car.width / 2`` from the box's centre line, on the side with more
room (as ``h2h_racing.policies.obstacles`` chooses it), at most 3 cm inside the border. Between
leaving one box (body clear of it) and reaching the next, the car has ``gap - box length - car
length`` of lap; an S-bend at full steering lock (turning radius ``wheelbase / tan(max_steer)``)
moves across at most ``2 R (1 - sqrt(1 - (x / 2R)^2))`` in ``x``. A layout is impassable when
some slalom needs more. Centre-line geometry only: no clearance, no body yaw, no track
curvature, so the real share is higher.
"""

from __future__ import annotations

import math
import sys

import numpy as np

from h2h_racing.sim import layouts as spawn
from h2h_racing.config.env import EnvConfig
from h2h_racing.track.io import list_tracks, load_track

LAYOUTS = 4000
EDGE = 0.03


def impassable_share(name: str, cfg: EnvConfig) -> float:
    track = load_track(name)
    car = cfg.car
    radius = car.wheelbase / math.tan(car.max_steer)
    half_w = cfg.obstacle_width / 2
    need = half_w + car.width / 2
    s, lane = spawn.obstacle_layout(track, np.random.default_rng(0), LAYOUTS, 6, None, True, 1,
                                    min_gap=cfg.obstacle_min_gap)
    s_wrapped = np.mod(s, track.length)
    d = spawn.lane_offset(track, s_wrapped, lane)
    left, right = track.half_widths_at(s_wrapped)
    side = np.where(left - (d + half_w) >= (d - half_w) + right, 1.0, -1.0)
    bound = np.clip(d + side * need, -right + EDGE, left - EDGE)
    lateral = np.abs(np.diff(bound, axis=1)) * (side[:, 1:] != side[:, :-1])
    x = np.clip(np.diff(s, axis=1) - cfg.obstacle_length - car.length, 0.0, None)
    reach = np.where(x >= 2 * radius, np.inf,
                     2 * radius * (1 - np.sqrt(np.clip(1 - (x / (2 * radius)) ** 2, 0, 1))))
    return float((lateral > reach).any(axis=1).mean())


def main() -> None:
    # Env v4's draw (obstacle_min_gap 2 m); obstacle_min_gap=0.0 gives v3's.
    cfg = EnvConfig(track="speedway", obstacle_min_gap=float(sys.argv[1]) if len(sys.argv) > 1
                    and not sys.argv[1].endswith(".npy") else 2.0)
    for name in [*list_tracks(), *[a for a in sys.argv[1:] if a.endswith(".npy")]]:
        print(f"{name:40s} {100 * impassable_share(name, cfg):5.1f} % of {LAYOUTS} layouts")


if __name__ == "__main__":
    main()
