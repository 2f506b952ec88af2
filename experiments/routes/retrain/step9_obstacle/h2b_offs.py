"""Where the head-to-bot off-tracks happen: a bot beside or just ahead, or the track alone.

    python experiments/routes/retrain/step9_obstacle/h2b_offs.py ROUTE [ROUTE ...] \
        --drivers DRIVER [DRIVER ...] [--races 20] [--seed 0]

Runs ``evaluate --race-type head_to_bot``'s races (``training.evaluate.race_config``, the same
core and seed) and, on every step a car's off-track count rises, notes the nearest bot's arc gap
(bot ahead positive, wrapped) and the track's width and curvature there. Prints per driver and
route: off-tracks, the share with a bot within 1.5 m along the track (behind or ahead), and the
median width; and, over the whole race, the share of steps the car's centre is within 3 cm of
a border or beyond it while a bot is within 1.5 m along the track, and while none is.
"""

from __future__ import annotations

import argparse

import numpy as np

from h2h_racing.policies import make_driver
from h2h_racing.sim.core import RaceCore
from h2h_racing.track.io import load_track
from h2h_racing.track.lookup import wrap_arcs
from h2h_racing.training.evaluate import race_config

NEAR = 1.5
"""A bot within this arc distance [m] counts as near."""
EDGE = 0.03
"""A centre within this of a border [m] (or beyond it) counts as on the border."""


def run(spec: str, route: str, races: int, seed: int) -> str:
    track = load_track(route)
    cfg = race_config(route, "head_to_bot", 3)
    core = RaceCore(cfg, track, num_envs=races)
    core.reset(seed=seed)
    driver = make_driver(spec, seed=seed)
    driver.reset(core)
    near_offs, widths, offs = 0, [], 0
    edge_near = edge_far = steps_near = steps_far = 0
    while not core.done.all():
        before = core.off_tracks[:, 0].copy()
        core.step(*cfg.commands(np.asarray(driver.act(core, 0))[:, None, :]))
        s, d = core.s[:, 0], core.d[:, 0]
        gap = np.abs(wrap_arcs(core.bot_s - s[:, None], track.length)).min(axis=1)
        near = gap < NEAR
        left, right = track.half_widths_at(s)
        on_edge = (d > left - EDGE) | (d < -right + EDGE)
        racing = ~core.done
        edge_near += int((on_edge & near & racing).sum())
        edge_far += int((on_edge & ~near & racing).sum())
        steps_near += int((near & racing).sum())
        steps_far += int((~near & racing).sum())
        rose = core.off_tracks[:, 0] > before
        offs += int(rose.sum())
        near_offs += int((rose & near).sum())
        widths += list((left + right)[rose])
    width = f"{np.median(widths):.2f} m" if widths else "-"
    return (f"{spec[-40:]:40s} {track.name:22s} off-tracks {offs:4d}, a bot within {NEAR} m at "
            f"{near_offs:4d}; median width {width}; centre within {100 * EDGE:.0f} cm of a "
            f"border: {100 * edge_near / max(steps_near, 1):.1f} % of steps with a bot near, "
            f"{100 * edge_far / max(steps_far, 1):.1f} % without")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("routes", nargs="+", help="route files")
    parser.add_argument("--drivers", nargs="+", required=True, help="drivers or policy.pt")
    parser.add_argument("--races", type=int, default=20, help="races (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=0, help="seed (default: %(default)s)")
    args = parser.parse_args()
    for route in args.routes:
        for spec in args.drivers:
            print(run(spec, route, args.races, args.seed), flush=True)


if __name__ == "__main__":
    main()
