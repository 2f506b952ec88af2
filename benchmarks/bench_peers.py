"""This project's env beside its peers, on one machine; prints figures, asserts nothing.

    python benchmarks/bench_peers.py            # about 40 s
    python benchmarks/bench_peers.py --quick    # a few seconds, for a smoke run
    python benchmarks/bench_peers.py --cpu-time # the thread's CPU time (a shared machine)

The README's "Against peers" table. What is timed, each for ``--seconds`` of ``env.step`` calls
only (resets excluded), the figures the median of ``--repeats`` runs:

- this project's ParallelEnv, 2 cars, state observations (``bench_env.py``'s first row: the
  cars follow the centre line in an endless race);
- Gymnasium's ``CarRacing-v3`` (1 car, Box2D), continuous actions (steer 0, gas 0.3, brake 0),
  with its 96 x 96 pixel observation as shipped, and without pixels: its ``_render`` replaced
  by a stub, so a step is the car's and Box2D's step and the reward only. It needs Box2D and
  pygame: ``pip install box2d pygame`` (wheels on PyPI; ``gymnasium[box2d]`` builds
  ``box2d-py`` from source with swig instead);
- f1tenth_gym, 2 cars with its 1080-beam lidar, when it is installed (it is not on PyPI: its
  repository's ``gym/`` folder, ``pip install -e gym/``), through the API of its README
  (``gym.make('f110_gym:f110-v0', num_agents=2)``, ``reset(poses)``, 4-tuple ``step``).

AWS DeepRacer's simulator runs in real time, 15 steps/s, whatever the machine. racecar_gym (2
cars, lidar or a 128 x 128 camera) is not timed here: it is not on PyPI and needs its scenario
files and pybullet; its figures in the README's table came from a one-off run (the
development machine, 2026-11-22: 110 env-steps/s with lidar, 51 with the camera).
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

import bench_env  # benchmarks/ is on sys.path when run as a script
from bench_env import bench_parallel_env

clock = time.perf_counter
"""The timer of every figure (``--cpu-time``: the thread's CPU time, here and in bench_env)."""


def timed_steps(step: Callable[[], bool], reset: Callable[[], None], seconds: float) -> float:
    """Steps/s of ``step`` (returns True when the episode ended: ``reset`` runs, untimed)."""
    steps, spent = 0, 0.0
    deadline = clock() + seconds
    while clock() < deadline:
        start = clock()
        ended = step()
        spent += clock() - start
        steps += 1
        if ended:
            reset()
    return steps / spent


def bench_car_racing(seconds: float, pixels: bool) -> float:
    """Steps/s of ``CarRacing-v3``, with its pixel observation or without (see the docstring)."""
    import gymnasium

    env = gymnasium.make("CarRacing-v3").unwrapped  # no wrappers: the env's own step
    if not pixels:
        env._render = lambda mode: None  # a step without drawing the 96 x 96 observation
    env.reset(seed=0)
    action = np.array([0.0, 0.3, 0.0])

    def step() -> bool:
        _, _, terminated, truncated, _ = env.step(action)
        return terminated or truncated

    def reset() -> None:
        env.reset(seed=0)

    try:
        return timed_steps(step, reset, seconds)
    finally:
        env.close()


def bench_f1tenth(seconds: float) -> float:
    """Env-steps/s of f1tenth_gym with 2 cars (its README's API; see the docstring)."""
    import gym  # f1tenth_gym registers with the old gym package
    import f110_gym  # noqa: F401

    env = gym.make("f110_gym:f110-v0", num_agents=2)
    poses = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    env.reset(poses)
    actions = np.array([[0.0, 2.0], [0.0, 2.0]])

    def step() -> bool:
        return bool(env.step(actions)[2])

    def reset() -> None:
        env.reset(poses)

    return timed_steps(step, reset, seconds)


def median_of(runs: int, measure: Callable[[], float]) -> tuple[float, list[float]]:
    """The median of ``runs`` measurements, and the measurements."""
    figures = [measure() for _ in range(runs)]
    return statistics.median(figures), figures


def main() -> None:
    """Time each env and print one line per figure (a peer that is missing says so)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short runs (smoke test)")
    parser.add_argument("--seconds", type=float, default=4.0,
                        help="timed seconds of each run (default: 4; 0.5 with --quick)")
    parser.add_argument("--repeats", type=int, default=3,
                        help="runs of each figure, the median shown (default: 3; 1 with "
                             "--quick)")
    parser.add_argument("--track", default="speedway",
                        help="this project's track (default: speedway)")
    parser.add_argument("--cpu-time", action="store_true",
                        help="time with this thread's CPU time instead of the wall clock "
                             "(steadier where other processes share the CPU; default: off)")
    args = parser.parse_args()
    global clock
    clock = bench_env.clock = time.thread_time if args.cpu_time else time.perf_counter
    seconds = 0.5 if args.quick else args.seconds
    repeats = 1 if args.quick else args.repeats
    bench_parallel_env(args.track, 0.2)  # compile the kernels (cached on disk afterwards)
    print(f"machine: {platform.machine()}, {platform.python_implementation()} "
          f"{platform.python_version()}, numpy {np.__version__}; {repeats} run(s) of "
          f"{seconds:g} s each, the median (runs in brackets); "
          f"{'thread CPU time' if args.cpu_time else 'wall clock'}; {Path(__file__).name}")
    rows: list[tuple[str, Callable[[], float], str]] = [
        ("h2h-racing ParallelEnv, 2 cars, state obs", lambda: bench_parallel_env(
            args.track, seconds)[0], "env-steps/s"),
        ("CarRacing-v3, 96 x 96 pixels (1 car)", lambda: bench_car_racing(seconds, True),
         "steps/s"),
        ("CarRacing-v3 without pixels (1 car)", lambda: bench_car_racing(seconds, False),
         "steps/s"),
        ("f1tenth_gym, 2 cars, 1080-beam lidar", lambda: bench_f1tenth(seconds),
         "env-steps/s"),
    ]
    for name, measure, unit in rows:
        try:
            figure, runs = median_of(repeats, measure)
        except ImportError as error:
            print(f"{name + ':':44} not installed ({error}); see this script's docstring")
            continue
        except Exception as error:  # a peer's API changed: say so, time the others
            print(f"{name + ':':44} failed: {type(error).__name__}: {error}")
            continue
        shown = "; ".join(f"{r:,.0f}" for r in runs)
        print(f"{name + ':':44} {figure:>10,.0f} {unit} ({shown})")
    print(f"{'AWS DeepRacer, one simulator:':44} {15:>10,} steps/s (real time, any machine)")


if __name__ == "__main__":
    main()
