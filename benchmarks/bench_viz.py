"""Cost of recording a race for the rerun viewer; prints figures, asserts nothing.

    python benchmarks/bench_viz.py               # about 10 s
    python benchmarks/bench_viz.py --out race.rrd --track oval

What is timed: a 2-car, 3-lap head-to-head race (racing_line vs pure_pursuit) run by
``h2h_racing.match.run_race`` (what ``h2h-racing race`` runs), recorded with ``save=`` to a
``.rrd`` file, cameras on (one JPEG per car per step, rendered by the recorder's own camera
since the env observes state only). The clock covers the whole call (env, drivers, race,
logging and closing the file); the rerun import is done before. Budgets (issue 5): real-time factor >= 5x, file < 30 MB.

Figures printed:
- real-time factor: simulated race seconds / wall seconds;
- the same race without recording, for comparison;
- the size of the ``.rrd`` file and the bytes per car-step.
"""

from __future__ import annotations

import argparse
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

from h2h_racing.config.env import EnvConfig
from h2h_racing.match import run_race
from h2h_racing.viz.recorder import import_rerun

DRIVERS = ("racing_line", "pure_pursuit")
RTF_BUDGET = 5.0
SIZE_BUDGET_MB = 30.0


def race(track: str, laps: int, out: Path | None) -> tuple[float, float, int]:
    """Run the race with ``run_race``, recorded to ``out`` when given: (simulated s, wall s,
    steps)."""
    start = time.perf_counter()
    result = run_race(track, list(DRIVERS), laps=laps, seed=0, save=out)
    wall = time.perf_counter() - start
    return result.steps * EnvConfig().step_dt, wall, result.steps


def main() -> None:
    """Run the benchmark and print one line per figure."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--track", default="speedway")
    parser.add_argument("--laps", type=int, default=3)
    parser.add_argument("--out", default=None, help="keep the recording here (default: temp)")
    args = parser.parse_args()
    rr = import_rerun()
    # Warm up: compile the kernels (cached on disk after the first run), racing-line cache.
    race(args.track, 1, None)
    print(f"machine: {platform.machine()}, {platform.python_implementation()} "
          f"{platform.python_version()}, numpy {np.__version__}, rerun-sdk {rr.__version__}")
    sim, wall, steps = race(args.track, args.laps, None)
    print(f"race without recording ({args.track}, 2 cars, {args.laps} laps): {steps} steps, "
          f"{sim:.1f} simulated s in {wall:.2f} s = {sim / wall:.1f}x real time")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(args.out) if args.out else Path(tmp) / "race.rrd"
        sim, wall, steps = race(args.track, args.laps, out)
        size = out.stat().st_size
    rtf = sim / wall
    mb = size / 1e6
    print(f"race recorded with cameras:  {sim:.1f} simulated s in {wall:.2f} s = "
          f"{rtf:.1f}x real time (budget >= {RTF_BUDGET:g}x: "
          f"{'ok' if rtf >= RTF_BUDGET else 'OVER'})")
    print(f".rrd size: {mb:.2f} MB, {size / (steps * len(DRIVERS)) / 1e3:.1f} kB per car-step "
          f"(budget < {SIZE_BUDGET_MB:g} MB: {'ok' if mb < SIZE_BUDGET_MB else 'OVER'})")


if __name__ == "__main__":
    main()
