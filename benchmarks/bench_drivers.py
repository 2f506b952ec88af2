"""Cost of the scripted drivers' ``act`` per car-step; prints figures, asserts nothing.

    python benchmarks/bench_drivers.py              # about 2 minutes
    python benchmarks/bench_drivers.py --quick      # a few seconds, for a smoke run
    python benchmarks/bench_drivers.py --cpu-time   # the thread's CPU time (a shared machine)

What is timed: ``driver.act(core, car)`` for both cars of E = 1, 64 and 256 copies of a 2-car
race on one track (speedway by default), each car driven by its own instance of the driver
(``planner`` and ``racing_line``, in the same process, taking turns a round at a time so that
a changing load falls on both). ``core.step`` runs between the calls, untimed. Every copy
starts at its own point of the lap (spread evenly) with the two cars on the 0.75 m grid and
races with no lap or time limit, so the cars keep meeting each other: the planner's
candidates are checked against a car ahead or beside on many steps, its costly case.

The figure is microseconds of ``act`` per car-step: time in ``act`` / (steps x E x 2); the
median over rounds, with the min-max range. Building the lanes and the racing line
(``reset``) and numba's compilation are done before timing.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

import h2h_racing
from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.sim.core import RaceCore
from h2h_racing.policies import make_driver

ENDLESS = RaceRules(laps=0, time_limit=1e9)
"""A race that never ends by itself, so that the timed loop never hits a reset."""
DRIVERS = ("racing_line", "planner")
"""The drivers timed, side by side."""
clock = time.perf_counter
"""The timer of every figure (``--cpu-time``: the thread's CPU time)."""


def new_race(track: str, num_envs: int, spec: str) -> tuple[RaceCore, list]:
    """A reset 2-car core of ``num_envs`` copies (starts spread round the lap) and one driver
    per car, reset."""
    loaded = h2h_racing.load_track(track)
    config = EnvConfig(track=track, num_cars=2, grid="fixed", rules=ENDLESS,
                       max_cycles=10**9)
    core = RaceCore(config, loaded, num_envs=num_envs)
    core.reset(seed=0, start=np.arange(num_envs) * (loaded.length / num_envs))
    drivers = [make_driver(spec), make_driver(spec)]
    for driver in drivers:
        driver.reset(core)
    return core, drivers


def run(core: RaceCore, drivers: list, seconds: float) -> tuple[float, int]:
    """Step the race for about ``seconds`` of ``act`` time; return that time and the steps."""
    spent, steps = 0.0, 0
    while spent < seconds:
        start = clock()
        actions = np.stack([d.act(core, car) for car, d in enumerate(drivers)], axis=1)
        spent += clock() - start
        core.step(*core.config.commands(actions))
        steps += 1
    return spent, steps


def main() -> None:
    """Time every driver at every size and print one line each."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short runs (smoke test)")
    parser.add_argument("--track", default="speedway")
    parser.add_argument("--envs", default="1,64,256", help="env copies, comma-separated")
    parser.add_argument("--rounds", type=int, default=5, help="turns each driver takes")
    parser.add_argument("--cpu-time", action="store_true",
                        help="time with this thread's CPU time instead of the wall clock "
                             "(steadier where other processes share the CPU)")
    args = parser.parse_args()
    global clock
    clock = time.thread_time if args.cpu_time else time.perf_counter
    seconds = 0.3 if args.quick else 4.0
    rounds = 1 if args.quick else args.rounds
    sizes = [int(n) for n in args.envs.split(",")]
    print(f"machine: {platform.machine()}, {os.cpu_count()} CPUs, "
          f"{platform.python_implementation()} {platform.python_version()}, numpy "
          f"{np.__version__}; {'thread CPU time' if args.cpu_time else 'wall clock'}; load "
          f"average {os.getloadavg()[0]:.1f} at the start; track {args.track}; h2h_racing from "
          f"{os.path.dirname(os.path.dirname(h2h_racing.__file__))}")
    print(f"{'driver':<12} {'E':>5} {'us per car-step':>16} {'ratio':>7}  (median of "
          f"{rounds} rounds, min-max; steps timed)")
    for num_envs in sizes:
        races = {spec: new_race(args.track, num_envs, spec) for spec in DRIVERS}
        for core, drivers in races.values():
            run(core, drivers, 0.2 if num_envs < 64 else 0.5)  # warm-up: compile, caches
        rates: dict[str, list[float]] = {spec: [] for spec in DRIVERS}
        counted = dict.fromkeys(DRIVERS, 0)
        for _ in range(rounds):
            for spec, (core, drivers) in races.items():
                spent, steps = run(core, drivers, seconds)
                rates[spec].append(1e6 * spent / (steps * num_envs * 2))
                counted[spec] += steps
        base = float(np.median(rates[DRIVERS[0]]))
        for spec in DRIVERS:
            median = float(np.median(rates[spec]))
            print(f"{spec:<12} {num_envs:>5} {median:>16,.1f} {median / base:>7.2f}  "
                  f"({min(rates[spec]):,.1f}-{max(rates[spec]):,.1f}; {counted[spec]:,} steps)")
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
