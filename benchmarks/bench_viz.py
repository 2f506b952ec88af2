"""Cost of recording a race for the rerun viewer; prints figures, asserts nothing.

    python benchmarks/bench_viz.py               # about 10 s
    python benchmarks/bench_viz.py --out race.rrd --track oval

What is timed: a 2-car, 3-lap head-to-head race (racing_line vs pure_pursuit) recorded with
``h2h_racing.viz.RaceRecorder`` to a ``.rrd`` file, cameras on (one JPEG per car per step,
rendered by the recorder's own camera since the env observes state only). The clock runs
from the recorder's creation (rerun import excluded, done before) through ``env.reset``,
every ``env.step`` with its logging, and ``close`` (the file flushed), so it includes the
drivers and the race itself. Budgets (issue 5): real-time factor >= 5x, file < 30 MB.

Figures printed:
- real-time factor: simulated race seconds / wall seconds;
- the same race without recording, for comparison;
- the size of the ``.rrd`` file and the bytes per car-step.
"""

from __future__ import annotations

import argparse
import dataclasses
import platform
import tempfile
import time
from pathlib import Path

import numpy as np
from h2h_racing.policies import make_driver

import h2h_racing
from h2h_racing.config import RaceRules
from h2h_racing.viz import RaceRecorder, import_rerun

DRIVERS = ("racing_line", "pure_pursuit")
RTF_BUDGET = 5.0
SIZE_BUDGET_MB = 30.0


def race(track: str, laps: int, out: Path | None) -> tuple[float, float, int]:
    """Run the race, recorded to ``out`` when given: (simulated s, wall s, steps)."""
    rules = dataclasses.replace(RaceRules.preset("head_to_head"), laps=laps)
    env = h2h_racing.parallel_env(track=track, num_cars=len(DRIVERS), rules=rules)
    drivers = [make_driver(name) for name in DRIVERS]
    start = time.perf_counter()
    recorder = RaceRecorder(env, path=out) if out is not None else None
    obs, infos = env.reset(seed=0)
    if recorder is not None:
        recorder.log_reset(obs, infos)
    for driver in drivers:
        driver.reset(env.core)
    steps = 0
    while env.agents:
        actions = {agent: drivers[i].act(env.core, i)[0]
                   for i, agent in enumerate(env.possible_agents) if agent in env.agents}
        result = env.step(actions)
        steps += 1
        if recorder is not None:
            recorder.log_step(actions, *result)
    if recorder is not None:
        recorder.log_results(env.results())
        recorder.close()
    wall = time.perf_counter() - start
    return float(env.core.time[0]), wall, steps


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
