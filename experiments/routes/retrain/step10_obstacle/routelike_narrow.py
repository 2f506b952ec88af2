"""A driver in head-to-bot races on 20 narrow route-like procedural tracks, as `h2h-racing
evaluate --race-type head_to_bot` runs them on a folder of routes (it is that command, on
track files written here). Step 10's seed rule reads it (``choose_seed.py``); the real routes
only check the choice.

    python experiments/routes/retrain/step10_obstacle/routelike_narrow.py \
        --policy runs/obstacle10_s0/policy.pt --json .../obstacle10_s0_routelike_narrow.json

The tracks are ``../ppo_step6/routelike.py``'s route-like tracks (the generator's call with
``ppo_generalist/routes``' settings: laps 15-90 m, chicanes, long-cornered circuits, tight
tracks, 0.05-0.8 m waypoint gaps) drawn narrow, 0.9-1.07 m, as the real routes' narrow "pro"
ones are (``2022_october_pro``, ``red_star_*``, ``2022_march_pro``: 1.07 m; ``July_2020``,
``FS_June2020``: 0.91 m), where step 9's students went over 1 reset a lap in head to bot. Each
track from its own seed 3000 + k (k = 0-19): training draws from the run's seed, the ppo set
from 1000 + k. Written with ``h2h_racing.track.io.save_track`` to a temporary folder as
``narrow_KK.json``; evaluate's stdout passed through, ``--json`` written as it writes it.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

TRACKS = 20
SEED0 = 3000
NARROWEST, WIDEST = 0.9, 1.07
"""Track widths drawn [m]: the real routes' narrow "pro" ones."""


def narrow_route_like(k: int):
    """Track ``k`` of the set (its own seed, SEED0 + k)."""
    from h2h_racing.training.tracks import random_training_track

    return random_training_track(
        np.random.default_rng(SEED0 + k), varying_share=0.3, min_radius=0.5,
        length=(15.0, 90.0), reverse_share=0.5, chicanes=(1, 4), tight_share=0.3,
        circuit_share=0.3, circuit_corners="long", narrowest=NARROWEST, widest=WIDEST,
        waypoint_gap=(0.05, 0.8))


def write_tracks(folder: Path, count: int = TRACKS) -> list[Path]:
    """Write narrow_route_like(0 .. count - 1) to ``folder`` as narrow_KK.json."""
    from h2h_racing.track.io import save_track

    return [save_track(narrow_route_like(k), folder / f"narrow_{k:02d}.json")
            for k in range(count)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description="Head-to-bot races on the 20 narrow route-like procedural tracks with "
                    "h2h-racing evaluate.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--policy", required=True,
                        help="policy.pt, a shipped policy or a scripted driver (as evaluate)")
    parser.add_argument("--json", required=True, help="evaluate's --json file to write")
    parser.add_argument("--races", type=int, default=20, help="3-lap races per track")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="narrow_") as folder:
        write_tracks(Path(folder))
        command = [sys.executable, "-m", "h2h_racing.cli", "evaluate", "--policy", args.policy,
                   "--track", folder, "--race-type", "head_to_bot", "--races", str(args.races),
                   "--jobs", "1", "--json", args.json, "--no-progress"]
        return subprocess.run(command).returncode


if __name__ == "__main__":
    sys.exit(main())
