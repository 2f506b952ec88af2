"""A driver on 30 route-like procedural tracks: one-lap attempts, as `h2h-racing evaluate` runs
them on a folder of routes (it is that command, on track files written here).

    python experiments/routes/retrain/ppo_step6/routelike.py \
        --policy runs/routes_ppo6_s0/policy.pt --json .../ppo_step6/ppo6_s0_routelike.json
    python experiments/routes/retrain/ppo_step6/routelike.py --policy racing_line --json ...

The tracks are those of `experiments/planner/sweep_routelike.py`'s `route_like(k)`, k = 0-29:
drawn by the generator with `ppo_generalist/routes`'s [procedural] settings (the distribution
the policy trains on: widths 0.6-2 m, laps 15-90 m, chicanes, long-cornered circuits, 0.05-0.8 m
waypoint gaps), each from its own seed 1000 + k, which training never draws from (it draws from
the run's seed). They stand in for the real routes when a seed is chosen (`choose_seed.py`); the
routes in ../shared/data only check the choice. The call is copied here, not imported, so that
the set the rule reads stays fixed while experiments/planner changes.

The tracks are written with the project's own writer (`h2h_racing.track.io.save_track`: centre
line and widths, which is all a generated track has) to a temporary folder as
`routelike_KK.json`, and `h2h-racing evaluate --track FOLDER --episodes 20 --jobs 1` runs on
them; its stdout (the per-track table and summary) is passed through, `--json` written as the
command writes it.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

TRACKS = 30  # route_like(0) .. route_like(29)


def route_like(k: int):
    """Track ``k`` of the set (its own seed, 1000 + k); sweep_routelike.py's call."""
    from h2h_racing.training.tracks import random_training_track

    return random_training_track(
        np.random.default_rng(1000 + k), varying_share=0.3, min_radius=0.5,
        length=(15.0, 90.0), reverse_share=0.5, chicanes=(1, 4), tight_share=0.3,
        circuit_share=0.3, circuit_corners="long", narrowest=0.6, widest=2.0,
        waypoint_gap=(0.05, 0.8))


def write_tracks(folder: Path, count: int = TRACKS) -> list[Path]:
    """Write route_like(0 .. count - 1) to ``folder`` as routelike_KK.json."""
    from h2h_racing.track.io import save_track

    return [save_track(route_like(k), folder / f"routelike_{k:02d}.json") for k in range(count)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description="One-lap attempts on the 30 route-like procedural tracks (route_like(0-29)) "
                    "with h2h-racing evaluate.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--policy", required=True,
                        help="policy.pt, a shipped policy or a scripted driver (as evaluate)")
    parser.add_argument("--json", required=True, help="evaluate's --json file to write")
    parser.add_argument("--episodes", type=int, default=20, help="one-lap attempts per track")
    parser.add_argument("--tracks", type=int, default=TRACKS,
                        help="how many of the set, from route_like(0)")
    args = parser.parse_args(argv)
    if not 1 <= args.tracks <= TRACKS:
        parser.error(f"--tracks: expected 1 to {TRACKS} (the set's size), got {args.tracks}")
    with tempfile.TemporaryDirectory(prefix="routelike_") as folder:
        write_tracks(Path(folder), args.tracks)
        command = [sys.executable, "-m", "h2h_racing.cli", "evaluate", "--policy", args.policy,
                   "--track", folder, "--episodes", str(args.episodes), "--jobs", "1",
                   "--json", args.json, "--no-progress"]
        return subprocess.run(command).returncode


if __name__ == "__main__":
    sys.exit(main())
