"""Which teacher margin reaches the tight boxes: the teacher's side gap at tight boxes on the
generator's waist tracks, for a few margins, before any training (step 9, README.md here).

    python experiments/routes/retrain/step9_obstacle/teacher_margin.py [--tracks 6] [--races 20]

Draws ``--tracks`` waist tracks from step 8's ``obstacle8.toml`` generator (``funnel_share``
set to 1; generator seeds 2000 + k, which training never draws from; no real route), writes
them to a temporary folder and runs ``../obstacle_fine/bowtie/passing_offsets.py``'s
``offsets`` (the env's object-avoidance layouts, the first lap, the gap between the car's
side and the box's side at each tight box's centre) for each teacher variant, with the
crashes, off-tracks and resets of those first-lap runs. The variants:

- ``teacher``: the card's teacher (``box_clearance = 0.2``: ``avoid_obstacles`` keeps the
  car's side 0.2 m from the box's, its centre clipped to ``EDGE`` = 0.03 m inside the border);
- ``clearance 0.3``: a wider ``box_clearance``;
- ``edge E``: the card's teacher with ``box_edge = E``: the clip at ``E`` inside the border
  (default: ``obstacles.EDGE`` = 0.03 m; a negative ``E`` puts the car's centre outside the
  border, still on the track while a wheel is on it: wheels 0.08 m either side).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path

import numpy as np

from h2h_racing.config.shipped import resolve_config
from h2h_racing.track.io import save_track
from h2h_racing.training.config import TrainConfig

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "obstacle_fine" / "bowtie"))
from passing_offsets import offsets  # noqa: E402

TEACHER = ("racing_line:follow_gap=2.0,closing_speed=0.3,box_clearance=0.2,"
           "box_speed_cap=1.8,box_bend_grip=0.35")
VARIANTS = {  # name: driver spec (passing_offsets' form: options after ":", split by ",")
    "teacher": TEACHER,
    "clearance 0.3": TEACHER.replace("box_clearance=0.2", "box_clearance=0.3"),
    "edge 0.0": TEACHER + ",box_edge=0.0",
    "edge -0.03": TEACHER + ",box_edge=-0.03",
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tracks", type=int, default=6,
                        help="waist tracks drawn (default: %(default)s)")
    parser.add_argument("--races", type=int, default=20,
                        help="races a track (default: %(default)s)")
    args = parser.parse_args()
    proc = TrainConfig.from_toml(
        resolve_config(str(HERE.parent / "step8" / "obstacle8.toml"), "train")).procedural
    proc = dataclasses.replace(proc, funnel_share=1.0)
    with tempfile.TemporaryDirectory(prefix="waists_") as folder:
        paths = []
        for k in range(args.tracks):
            path = Path(folder) / f"waist_{k:02d}.json"
            save_track(proc.draw(np.random.default_rng(2000 + k)), path)
            paths.append(str(path))
        for name, spec in VARIANTS.items():
            gaps, passed, tight = [], 0, 0
            for path in paths:
                rows, n = offsets(spec, path, args.races, seed=0)
                gaps += [g for _, _, g in rows]
                passed += len(rows)
                tight += n
            gaps = np.array(gaps)
            print(f"{name:14s} {passed} of {tight} tight boxes passed on lap 1; side gap mean "
                  f"{100 * gaps.mean():+.1f} cm, {100 * gaps.min():+.1f} to "
                  f"{100 * gaps.max():+.1f} cm; under 5 cm: {np.mean(gaps < 0.05):.0%}",
                  flush=True)


if __name__ == "__main__":
    main()
