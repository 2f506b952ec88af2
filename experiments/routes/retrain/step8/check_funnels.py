"""Funnel tracks of a step-8 config: their geometry, their validity, and racing_line on them.

    python experiments/routes/retrain/step8/check_funnels.py CONFIG [--tracks 20] [--episodes 3]

Draws ``--tracks`` tracks from the config's ``[procedural]`` with ``funnel_share`` set to 1
(every track a funnel track, with all the config's other settings: waypoint gaps, reversal),
each from its own generator seed 2000 + k, which training never draws from. For each: its lap,
widest and narrowest width, tightest radius (``Track.curvature_at`` every 1 cm), the funnel
ratio of ``ppo_step6/tokyo/funnels.py`` (its ``funnel``, imported from there) and the checks
(``Track`` built: no border folds; no crossing of the centre line or of the borders the env
races on, ``Track.left_border`` and ``right_border``, by ``find_crossings``; borders recomputed
from per-segment normals, ``border_polylines``, zig-zag by millimetres on one re-drawn track of
20, on its wide part, where waypoints 5-10 cm apart turn the normals unevenly). Then writes
them with ``save_track`` to a temporary folder and runs
``h2h-racing evaluate --policy racing_line --track FOLDER --episodes E --jobs 1`` on them (its
table passed through): racing_line must lap every one.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from h2h_racing.config.shipped import resolve_config
from h2h_racing.track.generator import find_crossings
from h2h_racing.track.io import save_track
from h2h_racing.training.config import TrainConfig

HERE = Path(__file__).resolve().parent
SPEC = importlib.util.spec_from_file_location(
    "funnels", HERE.parent / "ppo_step6" / "tokyo" / "funnels.py")
FUNNELS = importlib.util.module_from_spec(SPEC)
SPEC.loader.exec_module(FUNNELS)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("config", help="training config (a file or a shipped name)")
    parser.add_argument("--tracks", type=int, default=20,
                        help="funnel tracks drawn (default: %(default)s)")
    parser.add_argument("--episodes", type=int, default=3,
                        help="racing_line's one-lap attempts per track; 0 runs none "
                             "(default: %(default)s)")
    args = parser.parse_args()
    proc = TrainConfig.from_toml(resolve_config(args.config, "train")).procedural
    proc = dataclasses.replace(proc, funnel_share=1.0)
    with tempfile.TemporaryDirectory(prefix="funnels_") as folder:
        ratios = []
        for k in range(args.tracks):
            track = proc.draw(np.random.default_rng(2000 + k))
            s = np.arange(0.0, track.length, 0.01)
            left, right = track.half_widths_at(s)
            width = left + right
            radius = 1.0 / np.abs(track.curvature_at(s)).max()
            # The borders the env races on (Track's, from its vertex normals).
            crossings = (len(find_crossings(track.centre))
                         + len(find_crossings(track.left_border, track.right_border)))
            ratio, entry, at = FUNNELS.funnel(track)
            ratios.append(ratio)
            print(f"funnel_{k:02d} {track.name:24s} lap {track.length:5.1f} m, "
                  f"{width.min():.2f}-{width.max():.2f} m wide, tightest radius {radius:.2f} m, "
                  f"funnel x{ratio:.2f} (from {entry:.2f} m at {at:.1f} m), "
                  f"crossings {crossings}", flush=True)
            save_track(track, Path(folder) / f"funnel_{k:02d}.json")
        ratios = np.array(ratios)
        print(f"funnel over x1.5 (funnels.py, bends under 0.67 m radius) on "
              f"{100 * (ratios > 1.5).mean():.0f} % of {args.tracks}", flush=True)
        if not args.episodes:
            return 0
        command = [sys.executable, "-m", "h2h_racing.cli", "evaluate", "--policy", "racing_line",
                   "--track", folder, "--episodes", str(args.episodes), "--jobs", "1",
                   "--no-progress"]
        return subprocess.run(command).returncode


if __name__ == "__main__":
    sys.exit(main())
