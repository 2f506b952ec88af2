"""Policies on 20 held-out run funnels of ppo9.toml: how a seed rule that weighs them would
have ranked the step 9 seeds (measured after the choice; it chose nothing).

    python experiments/routes/retrain/step9/funnel_laps.py POLICY [POLICY ...]

Draws 20 tracks from `ppo9.toml`'s `[procedural]` with `funnel_share` set to 1 (every track a
run funnel), from generator seeds 2000-2019 as `../step8/check_funnels.py` does (training never
draws from them), writes them to a temporary folder and runs `h2h-racing evaluate --policy P
--track FOLDER --episodes 20 --jobs 1` for each policy; prints each policy's summary lines.
"""

from __future__ import annotations

import argparse
import dataclasses
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from h2h_racing.config.shipped import resolve_config
from h2h_racing.track.io import save_track
from h2h_racing.training.config import TrainConfig

HERE = Path(__file__).resolve().parent


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("policies", nargs="+", help="policy files or names")
    parser.add_argument("--tracks", type=int, default=20,
                        help="run funnels drawn (default: %(default)s)")
    args = parser.parse_args()
    proc = TrainConfig.from_toml(resolve_config(str(HERE / "ppo9.toml"), "train")).procedural
    proc = dataclasses.replace(proc, funnel_share=1.0)
    with tempfile.TemporaryDirectory(prefix="run_funnels_") as folder:
        for k in range(args.tracks):
            track = proc.draw(np.random.default_rng(2000 + k))
            save_track(track, Path(folder) / f"runfunnel_{k:02d}.json")
        for policy in args.policies:
            done = subprocess.run(
                [sys.executable, "-m", "h2h_racing.cli", "evaluate", "--policy", policy,
                 "--track", folder, "--episodes", "20", "--jobs", "1", "--no-progress"],
                capture_output=True, text=True)
            lines = [line for line in done.stdout.splitlines()
                     if line.startswith(("summary", "worst", "mean lap vs racing"))]
            print(f"{policy}: " + " | ".join(lines or [done.stderr.strip()[-300:]]), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
