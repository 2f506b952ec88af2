"""racing_line's own line on a track as it ships and re-drawn through coarser waypoints: the
lateral offsets it uses [m], its curvature and its planned lap [s] (``compute_race_line``, the
env's car and top speed), and the same on DeepRacer's routes (30 cm waypoints).

    python experiments/routes/retrain/obstacle_fine/why_slow/line_offsets.py RESAMPLED_FOLDER
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from h2h_racing.config.env import EnvConfig
from h2h_racing.policies.racing_line import compute_race_line
from h2h_racing.track.io import load_track

ROUTES = Path(__file__).resolve().parents[6] / "shared" / "data" / "deepracer_tracks"


def row(name: str, track) -> str:
    config = EnvConfig()
    line = compute_race_line(track, config.car, config.max_speed)
    gaps = np.diff(track.vertex_s)
    bend = np.percentile(np.abs(line.curvature), 95)
    return (f"{name:<28} waypoints {len(track.centre):4d} ({gaps.min():.2f}-{gaps.max():.2f} m "
            f"apart), half-width {track.width.min() / 2:.2f} m: offsets {line.d.min():+.2f} to "
            f"{line.d.max():+.2f} m, |curvature| p95 {bend:.2f} 1/m,"
            f" planned lap {line.lap_time:.2f} s")


def main(folder: Path) -> None:
    for path in sorted(folder.glob("*.json")):
        print(row(path.stem, load_track(path)))
    for path in sorted(ROUTES.glob("*.npy"))[:8]:
        print(row(path.stem, load_track(path)))


if __name__ == "__main__":
    main(Path(sys.argv[1]))
