"""Room beside the boxes on a training config's tracks, with its ``[race] tight_box_share``
applied as the training VecEnv applies it, against the same layouts without it.

    python experiments/routes/retrain/step8/box_room_tight.py CONFIG [--tracks 300] \
        [--tight-share S]

The room is ``obstacle_fine/bowtie/box_room.py``'s measure (its ``box_room``, imported from
there); layouts are drawn as there (``obstacle_layout``, one car, env defaults, 40 per track,
the tracks from the config's ``[procedural]`` with generator seed 12345), then each is moved
by ``h2h_racing.training.tight_boxes.tighten`` with the config's ``tight_box_share`` and
``tight_box_room`` (the VecEnv's call). Prints, for the layouts as drawn and as moved: the
share of boxes and of layouts with a box under 0.24 m of room (``box_room.py``'s *tight*) and
with one of 0.25 m or less, and how many layouts had a box moved.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
from pathlib import Path

import numpy as np

from h2h_racing.config.env import EnvConfig
from h2h_racing.config.shipped import resolve_config
from h2h_racing.sim import layouts
from h2h_racing.training.config import TrainConfig
from h2h_racing.training.tight_boxes import tight_places, tighten

HERE = Path(__file__).resolve().parent
SPEC = importlib.util.spec_from_file_location(
    "box_room", HERE.parent / "obstacle_fine" / "bowtie" / "box_room.py")
BOX_ROOM = importlib.util.module_from_spec(SPEC)
SPEC.loader.exec_module(BOX_ROOM)
LAYOUTS = 40


def room_of(track, s, lane, cfg: EnvConfig) -> np.ndarray:
    """``box_room.py``'s room beside the boxes at ``s`` on ``lane`` (its code)."""
    return BOX_ROOM.room_at(track, s, lane, cfg)[0]


def shares(room: np.ndarray) -> str:
    under = room < BOX_ROOM.TIGHT_ROOM
    upto = room <= 0.25 + 1e-9
    return (f"boxes under {BOX_ROOM.TIGHT_ROOM} m {100 * under.mean():5.1f} %, layouts with one "
            f"{100 * under.any(1).mean():5.1f} %; boxes <= 0.25 m {100 * upto.mean():5.1f} %, "
            f"layouts with one {100 * upto.any(1).mean():5.1f} %")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("config", help="training config (a file or a shipped name)")
    parser.add_argument("--tracks", type=int, default=300,
                        help="training tracks drawn (default: %(default)s)")
    parser.add_argument("--tight-share", type=float, default=None,
                        help="tight_box_share instead of the config's (its tight_box_room "
                             "kept) (default: the config's)")
    args = parser.parse_args()
    train = TrainConfig.from_toml(resolve_config(args.config, "train"))
    if args.tight_share is not None:
        race = dataclasses.replace(train.race, tight_box_share=args.tight_share)
        train = dataclasses.replace(train, race=race)
    settings = train.race.tight_boxes()
    cfg = EnvConfig(track="oval", num_cars=1, race_type="object_avoidance",
                    randomize_obstacles=True)
    rng = np.random.default_rng(12345)
    before, after, moved, funnels, drawn = [], [], 0, 0, 0
    for _ in range(args.tracks):
        track = train.procedural.draw(rng)
        funnels += track.name.startswith("funnel-")
        inner = 1 if track.is_ccw else -1
        try:
            s, lane = layouts.obstacle_layout(track, rng, LAYOUTS, 6, None, True, inner,
                                              grid_length=cfg.car.length,
                                              min_gap=cfg.obstacle_min_gap)
        except ValueError:
            continue
        drawn += 1
        before.append(room_of(track, s, lane, cfg))
        if settings is not None:
            places = tight_places(track, settings.room, cfg.obstacle_length,
                                  cfg.obstacle_width, cfg.car.length)
            s, lane, n = tighten(s, lane, places, rng, settings.share, cfg.obstacle_min_gap)
            moved += n
        after.append(room_of(track, s, lane, cfg))
    flag = "" if args.tight_share is None else f" --tight-share {args.tight_share}"
    label = f"{args.config}{flag} ({drawn} tracks x {LAYOUTS}, {funnels} funnel tracks)"
    print(f"{label}\n  as drawn: {shares(np.concatenate(before))}")
    if settings is not None:
        print(f"  moved (tight_box_share {settings.share}, room {settings.room} m): "
              f"{shares(np.concatenate(after))}; {moved} of {drawn * LAYOUTS} layouts had a "
              f"box moved")


if __name__ == "__main__":
    main()
