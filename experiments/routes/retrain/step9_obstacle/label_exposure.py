"""How many of a training config's boxes get new teacher labels from ``box_edge``: the boxes
where ``avoid_obstacles``' clearance does not fit and the border clip decides the target.

    python experiments/routes/retrain/step9_obstacle/label_exposure.py CONFIG [--tracks 100]

The target beside a box is the box's side plus half the car (0.098 m) plus ``box_clearance``,
clipped to ``edge`` inside the border (``policies/obstacles.py``). So the clip decides where
the room between the box's side and the border on the passing side is under 0.098 +
clearance + edge: 0.328 m for the card's teacher (clearance 0.2, EDGE 0.03). Moving the clip
to edge 0 changes the label (by up to 3 cm) at every such box. The room is the tight boxes'
``box_room`` (``../step8/box_room_tight.py``'s ``room_of``: layouts drawn as the env draws
them, 40 per track, generator seed 12345, step 8's measure); shares of boxes and of layouts.
"""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

import numpy as np

from h2h_racing.config.env import EnvConfig
from h2h_racing.config.shipped import resolve_config
from h2h_racing.sim import layouts
from h2h_racing.training.config import TrainConfig

HERE = Path(__file__).resolve().parent
SPEC = importlib.util.spec_from_file_location("box_room_tight",
                                              HERE.parent / "step8" / "box_room_tight.py")
TIGHT = importlib.util.module_from_spec(SPEC)
SPEC.loader.exec_module(TIGHT)
CLIP_ROOM = 0.09805 + 0.2 + 0.03
"""Room under which the card's teacher's target is the border clip [m]."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("config", help="training config (a file or a shipped name)")
    parser.add_argument("--tracks", type=int, default=100,
                        help="training tracks drawn (default: %(default)s)")
    args = parser.parse_args()
    train = TrainConfig.from_toml(resolve_config(args.config, "train"))
    cfg = EnvConfig(track="oval", num_cars=1, race_type="object_avoidance",
                    randomize_obstacles=True)
    rng = np.random.default_rng(12345)
    rooms = []
    for _ in range(args.tracks):
        track = train.procedural.draw(rng)
        inner = 1 if track.is_ccw else -1
        try:
            s, lane = layouts.obstacle_layout(track, rng, TIGHT.LAYOUTS, 6, None, True, inner,
                                              grid_length=cfg.car.length,
                                              min_gap=cfg.obstacle_min_gap)
        except ValueError:
            continue
        rooms.append(TIGHT.room_of(track, s, lane, cfg))
    room = np.concatenate(rooms)
    for limit, what in ((CLIP_ROOM, "clipped (new labels at edge 0)"), (0.24, "tight")):
        under = room < limit
        print(f"{args.config} ({len(rooms)} tracks x {TIGHT.LAYOUTS}): {what}, room under "
              f"{limit:.3f} m: {100 * under.mean():.1f} % of boxes, "
              f"{100 * under.any(1).mean():.1f} % of layouts")


if __name__ == "__main__":
    main()
