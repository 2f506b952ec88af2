"""Throughput of the ParallelEnv and of the batched core; prints figures, asserts nothing.

    python benchmarks/bench_env.py            # about 60 s
    python benchmarks/bench_env.py --quick    # a few seconds, for a smoke run

What is timed:
- ParallelEnv, 2 cars, state observations: the ``env.step(actions)`` calls only (dict in,
  five dicts out, with observations, rewards and infos), in a running race.
- Batched core, 512 env copies x 2 cars: ``core.step`` + the state observation + the
  built-in reward, i.e. everything a training VecEnv needs per step, over all copies.
- The same two with 3 bot cars per env copy (``race_type="head_to_bot"``, lane changes on):
  the cost of the bots' scripted motion, their kinematic bodies and the larger sensor and
  observation candidate sets.
- Peak memory (max resident set size) of the process.

The cars are driven by a simple centre-line controller computed from the state (its cost is
excluded), so they race and do not sit in penalties; the race has no lap or step limit, so
the timed loop never resets.
"""

from __future__ import annotations

import argparse
import platform
import resource
import time

import numpy as np

import h2h_racing
from h2h_racing import rewards
from h2h_racing.config import EnvConfig, RaceRules
from h2h_racing.core import RaceCore
from h2h_racing.sensors.state import state_observation

ENDLESS = RaceRules(laps=0, time_limit=1e9)
"""A race that never ends by itself, so that the timed loop never hits a reset."""


def centre_controller(core: RaceCore) -> tuple[np.ndarray, np.ndarray]:
    """Steer toward the centre line at a steady 2.5 m/s: (steer [rad], speed [m/s]), (E, N)."""
    heading = core.track.heading_at(core.s)
    error = np.remainder(core.yaw - heading + np.pi, 2 * np.pi) - np.pi
    steer = np.clip(-1.5 * core.d - 1.2 * error, -0.5, 0.5)
    return steer, np.full(core.s.shape, 2.5)


def bench_parallel_env(track: str, seconds: float, num_bots: int = 0) -> float:
    """Return env-steps/s of the ParallelEnv with 2 cars and state observations."""
    env = h2h_racing.parallel_env(track=track, num_cars=2, rules=ENDLESS, max_cycles=10**9,
                                  num_bots=num_bots)
    env.reset(seed=0)
    max_steer = env.config.car.max_steer
    mid, half = 0.5 * (env.config.max_speed + env.config.min_speed), 0.5 * (
        env.config.max_speed - env.config.min_speed)
    steps, spent = 0, 0.0
    deadline = time.perf_counter() + seconds
    while time.perf_counter() < deadline:
        steer, speed = centre_controller(env.core)
        actions = {agent: np.array([steer[0, i] / max_steer, (speed[0, i] - mid) / half],
                                   dtype=np.float32)
                   for i, agent in enumerate(env.possible_agents)}
        start = time.perf_counter()
        env.step(actions)
        spent += time.perf_counter() - start
        steps += 1
    return steps / spent


def bench_core(track: str, num_envs: int, seconds: float, num_bots: int = 0) -> float:
    """Return agent-steps/s of the batched core (step + observation + reward)."""
    config = EnvConfig(track=track, num_cars=2, rules=ENDLESS, max_cycles=10**9,
                       num_bots=num_bots)
    core = RaceCore(config, h2h_racing.load_track(track), num_envs=num_envs)
    core.reset(seed=0)
    weights = rewards.weights_of(config.reward)
    steps, spent = 0, 0.0
    deadline = time.perf_counter() + seconds
    while time.perf_counter() < deadline:
        steer, speed = centre_controller(core)
        start = time.perf_counter()
        racing = core.racing
        events = core.step(steer, speed)
        state_observation(core)
        rewards.reward_terms(weights, events, core.speed, racing)
        spent += time.perf_counter() - start
        steps += 1
    return steps * num_envs * 2 / spent


def main() -> None:
    """Run the benchmarks and print one line per figure."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short runs (smoke test)")
    parser.add_argument("--track", default="speedway")
    args = parser.parse_args()
    seconds = 1.0 if args.quick else 8.0
    # Warm up: compile the kernels (cached on disk after the first run) and build the track.
    bench_parallel_env(args.track, 0.2)
    bench_core(args.track, 8, 0.2)
    print(f"machine: {platform.machine()}, {platform.python_implementation()} "
          f"{platform.python_version()}, numpy {np.__version__}")
    env_rate = bench_parallel_env(args.track, seconds)
    print(f"ParallelEnv, 2 cars, state obs:       {env_rate:>10,.0f} env-steps/s")
    env_rate = bench_parallel_env(args.track, seconds, num_bots=3)
    print(f"  the same with 3 bot cars:           {env_rate:>10,.0f} env-steps/s")
    for num_envs in (512,):
        rate = bench_core(args.track, num_envs, seconds)
        print(f"batched core, {num_envs} envs x 2 cars:     {rate:>10,.0f} agent-steps/s")
        rate = bench_core(args.track, num_envs, seconds, num_bots=3)
        print(f"  the same with 3 bot cars per copy:  {rate:>10,.0f} agent-steps/s")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak memory (max RSS):                {peak:>10,.0f} MiB")


if __name__ == "__main__":
    main()
