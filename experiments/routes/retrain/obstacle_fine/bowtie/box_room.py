"""How much room DeepRacer's 6 random boxes leave beside them, on route files and on the
training tracks of a config's generator.

    python experiments/routes/retrain/obstacle_fine/bowtie/box_room.py \
        [--config obstacle_generalist/routes] [--tracks 300] [ROUTE.npy ...]

Layouts are drawn as the env draws them (``h2h_racing.sim.layouts.obstacle_layout``: one car,
env defaults, ``obstacle_min_gap`` 2 m; 400 layouts per track). For each box: the track's
width and curvature at its centre and the free width beside it on its other side: that side's
half-width plus the gap between the centre line and the box's near side, less how far a
straight box on the inside lane of a bend sticks out towards the outside at its ends
(``sqrt(R^2 + (L/2)^2) - R``, R the radius of its outer side). A box is *tight* when that room
is under ``TIGHT_ROOM`` (the car is 0.2 m wide: ``TIGHT_ROOM`` leaves it 4 cm of play).
Prints, per route and for the training tracks together: the share of boxes that are tight,
the share of layouts with one or more tight boxes, and the tight boxes' width and curvature.
"""

from __future__ import annotations

import argparse

import numpy as np

from h2h_racing.config.env import EnvConfig
from h2h_racing.sim import layouts
from h2h_racing.track.io import load_track
from h2h_racing.training.tight_boxes import box_room as box_room_at
from h2h_racing.track.shape import Track

LAYOUTS = 400
TIGHT_ROOM = 0.24
"""Free width beside a box under which it counts as tight [m]."""


def box_room(track: Track, layouts_n: int, rng: np.random.Generator,
             cfg: EnvConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(room, width, curvature)`` of every box of ``layouts_n`` layouts, each (layouts, 6)."""
    inner = 1 if track.is_ccw else -1
    s, lane = layouts.obstacle_layout(track, rng, layouts_n, 6, None, True, inner,
                                      grid_length=cfg.car.length,
                                      min_gap=cfg.obstacle_min_gap)
    return room_at(track, s, lane, cfg)


def room_at(track: Track, s: np.ndarray, lane: np.ndarray,
            cfg: EnvConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(room, width, curvature)`` beside boxes at arc positions ``s`` [m] in lanes
    ``lane`` (any shape, the same). The room is ``h2h_racing.training.tight_boxes.box_room``
    (the other side's half-width plus the gap to the box's near side, less the bulge of a
    straight box's ends on the inside lane of a bend), the measure this diagnosis made and
    training's tight boxes later took over."""
    s = np.mod(s, track.length)
    left, right = track.half_widths_at(s.ravel())
    k = track.curvature_at(s.ravel()).reshape(s.shape)
    room = box_room_at(track, s, lane, cfg.obstacle_length, cfg.obstacle_width)
    return room, (left + right).reshape(s.shape), k


def report(label: str, room: np.ndarray, width: np.ndarray, k: np.ndarray) -> None:
    tight = room < TIGHT_ROOM
    shown = (f"tight boxes {100 * tight.mean():5.1f} %, layouts with one "
             f"{100 * tight.any(1).mean():5.1f} %, with two "
             f"{100 * (tight.sum(1) >= 2).mean():5.1f} %")
    if tight.any():
        shown += (f"; tight boxes' room {room[tight].min():.2f}-{np.median(room[tight]):.2f}"
                  f" m (min-median), width {np.median(width[tight]):.2f} m, |curvature| "
                  f"{np.median(np.abs(k[tight])):.2f} /m (medians)")
    print(f"{label:32s} {shown}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("routes", nargs="*", help="route files (.npy)")
    parser.add_argument("--config", default="obstacle_generalist/routes",
                        help="training config whose [procedural] tracks are drawn "
                             "(default: %(default)s)")
    parser.add_argument("--tracks", type=int, default=300,
                        help="training tracks drawn (default: %(default)s)")
    args = parser.parse_args()
    cfg = EnvConfig(track="oval", num_cars=1, race_type="object_avoidance",
                    randomize_obstacles=True)
    for path in args.routes:
        room, width, k = box_room(load_track(path), LAYOUTS, np.random.default_rng(0), cfg)
        report(load_track(path).name, room, width, k)
    if args.tracks:
        from h2h_racing.training.config import TrainConfig
        from h2h_racing.config.shipped import resolve_config

        proc = TrainConfig.from_toml(resolve_config(args.config, "train")).procedural
        rng = np.random.default_rng(12345)
        rooms, widths, ks = [], [], []
        narrow_tight = 0
        for _ in range(args.tracks):
            track = proc.draw(rng)
            try:
                room, width, k = box_room(track, 40, rng, cfg)
            except ValueError:
                continue
            rooms.append(room)
            widths.append(width)
            ks.append(k)
            narrow_tight += bool(((width < 0.66) & (np.abs(k) > 0.9)).any())
        report(f"training tracks ({args.config}, {len(rooms)} tracks x 40)",
               np.concatenate(rooms), np.concatenate(widths), np.concatenate(ks))
        both = np.concatenate(widths) < 0.66
        bend = np.abs(np.concatenate(ks)) > 0.9
        print(f"  training boxes in a bend under 1.1 m radius on a track under 0.66 m wide: "
              f"{100 * (both & bend).mean():.2f} % of boxes; tracks with any: "
              f"{narrow_tight} of {len(rooms)}")


if __name__ == "__main__":
    main()
