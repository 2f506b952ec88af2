"""Where the teacher's labels of step 10 differ from step 7's: the boxes of a training config's
tracks (drawn as the env draws them) by the room beside them, and by the track's width there.

    python experiments/routes/retrain/step10_obstacle/label_change.py [CONFIG] [--tracks 100]

Step 7's teacher (the card's: clearance 0.2, ``EDGE`` 3 cm) targets the border clip beside a box
with room under 0.328 m (``../step9_obstacle/label_exposure.py``'s ``CLIP_ROOM``). Step 9's
``box_edge = 0`` moved the label by up to 3 cm at all of those; step 10's ``box_edge_room =
0.24`` moves it only where the room is under 0.24 m (the tight boxes); ``box_edge = 0.015``
would move all of step 9's by up to 1.5 cm. The room is ``../step8/box_room_tight.py``'s
``room_of`` (the same layouts, generator seed 12345, as step 9's count).
"""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
_SPEC = importlib.util.spec_from_file_location(
    "label_exposure", HERE.parent / "step9_obstacle" / "label_exposure.py")
EXPOSURE = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(EXPOSURE)
TIGHT_ROOM = 0.24
"""step 10's box_edge_room [m]."""
WIDTHS = (0.6, 0.8, 1.0, 1.2, 1.6, 2.01)
"""Track-width bands at the box [m]."""


def main() -> None:
    from h2h_racing.config.env import EnvConfig
    from h2h_racing.config.shipped import resolve_config
    from h2h_racing.sim import layouts
    from h2h_racing.training.config import TrainConfig

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("config", nargs="?", default="obstacle_generalist/routes",
                        help="training config (a file or a shipped name) (default: %(default)s)")
    parser.add_argument("--tracks", type=int, default=100,
                        help="training tracks drawn (default: %(default)s)")
    args = parser.parse_args()
    train = TrainConfig.from_toml(resolve_config(args.config, "train"))
    cfg = EnvConfig(track="oval", num_cars=1, race_type="object_avoidance",
                    randomize_obstacles=True)
    rng = np.random.default_rng(12345)
    rooms, widths = [], []
    for _ in range(args.tracks):
        track = train.procedural.draw(rng)
        inner = 1 if track.is_ccw else -1
        try:
            s, lane = layouts.obstacle_layout(track, rng, EXPOSURE.TIGHT.LAYOUTS, 6, None, True,
                                              inner, grid_length=cfg.car.length,
                                              min_gap=cfg.obstacle_min_gap)
        except ValueError:
            continue
        rooms.append(EXPOSURE.TIGHT.room_of(track, s, lane, cfg))
        left, right = track.half_widths_at(np.mod(s.ravel(), track.length))
        widths.append((left + right).reshape(s.shape))
    room, width = np.concatenate(rooms), np.concatenate(widths)
    boxes = room.size
    print(f"{args.config}: {len(rooms)} tracks x {EXPOSURE.TIGHT.LAYOUTS} layouts, {boxes} boxes")
    for limit, what in ((EXPOSURE.CLIP_ROOM, "step 9 (box_edge 0, every clipped box) / 0.015"),
                        (TIGHT_ROOM, "step 10 (box_edge 0 under 0.24 m of room)")):
        under = room < limit
        print(f"labels moved, {what}: room under {limit:.3f} m: {100 * under.mean():.1f} % of "
              f"boxes, {100 * under.any(1).mean():.1f} % of layouts")
    print("by track width at the box [m]: boxes, step 9's moved, step 10's moved")
    for low, high in zip(WIDTHS[:-1], WIDTHS[1:]):
        band = (width >= low) & (width < high)
        print(f"  {low:.1f}-{min(high, 2.0):.1f}: {100 * band.mean():5.1f} % of boxes; "
              f"{100 * (band & (room < EXPOSURE.CLIP_ROOM)).mean():5.1f} %; "
              f"{100 * (band & (room < TIGHT_ROOM)).mean():5.1f} %")


if __name__ == "__main__":
    main()
