"""Throughput of the ParallelEnv and of the batched core; prints figures, asserts nothing.

    python benchmarks/bench_env.py            # about 60 s
    python benchmarks/bench_env.py --quick    # a few seconds, for a smoke run
    python benchmarks/bench_env.py --cpu-time # time with the thread's CPU time (a shared machine)

What is timed:
- ParallelEnv, 2 cars, state observations: the ``env.step(actions)`` calls only (dict in,
  five dicts out, with observations, rewards and infos), in a running race.
- The same with contacts: the car behind rams the car ahead (full speed, steering at it,
  dropping back for 4 steps of every 20) while that one crawls at 1 m/s, so they touch on
  most steps; crashes are not infractions
  here (no penalty freezes), so the pushing goes on. The row says how many steps had a new
  contact and how many ended with the two cars touching.
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
import os
import platform
import resource
import time

import numpy as np

import h2h_racing
from h2h_racing.sim import rewards
from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.sim.core import RaceCore
from h2h_racing.sensors.state import state_observation

ENDLESS = RaceRules(laps=0, time_limit=1e9)
"""A race that never ends by itself, so that the timed loop never hits a reset."""
clock = time.perf_counter
"""The timer of every figure (``--cpu-time``: the thread's CPU time)."""
BUMPING = RaceRules(laps=0, time_limit=1e9, crash_is_infraction=False)
"""The same where ramming is no infraction, so that the contact row keeps pushing."""


def centre_controller(core: RaceCore) -> tuple[np.ndarray, np.ndarray]:
    """Steer toward the centre line at a steady 2.5 m/s: (steer [rad], speed [m/s]), (E, N)."""
    heading = core.track.heading_at(core.s)
    error = np.remainder(core.yaw - heading + np.pi, 2 * np.pi) - np.pi
    steer = np.clip(-1.5 * core.d - 1.2 * error, -0.5, 0.5)
    return steer, np.full(core.s.shape, 2.5)


def ramming_controller(core: RaceCore) -> tuple[np.ndarray, np.ndarray]:
    """The car ahead crawls along the centre line; the car behind steers at it and rams it at
    full speed, dropping back for 4 steps of every 20 so that it hits it anew."""
    steer, speed = centre_controller(core)
    lead = int(np.argmax(core.distance[0]))
    chaser = 1 - lead
    dx, dy = core.position[0, lead] - core.position[0, chaser]
    bearing = np.remainder(np.arctan2(dy, dx) - core.yaw[0, chaser] + np.pi, 2 * np.pi) - np.pi
    steer[0, chaser] = np.clip(2.0 * bearing, -0.5, 0.5)
    speed[0, chaser] = 0.5 if core.steps[0] % 20 < 4 else 4.0
    speed[0, lead] = 1.0
    return steer, speed


def bench_parallel_env(track: str, seconds: float, num_bots: int = 0,
                       contact: bool = False) -> tuple[float, float, float]:
    """Return env-steps/s of the ParallelEnv with 2 cars and state observations, and the
    fractions of steps with a new contact and ending with the cars touching."""
    # The contact row starts from the fixed grid: the chaser right behind the car ahead.
    env = h2h_racing.parallel_env(track=track, num_cars=2, rules=BUMPING if contact else ENDLESS,
                                  max_cycles=10**9, num_bots=num_bots,
                                  grid="fixed" if contact else "random")
    env.reset(seed=0)
    controller = ramming_controller if contact else centre_controller
    max_steer = env.config.car.max_steer
    mid, half = 0.5 * (env.config.max_speed + env.config.min_speed), 0.5 * (
        env.config.max_speed - env.config.min_speed)
    steps, spent, new_contacts, touching = 0, 0.0, 0, 0
    deadline = clock() + seconds
    while clock() < deadline:
        steer, speed = controller(env.core)
        actions = {agent: np.array([steer[0, i] / max_steer, (speed[0, i] - mid) / half],
                                   dtype=np.float32)
                   for i, agent in enumerate(env.possible_agents)}
        start = clock()
        env.step(actions)
        spent += clock() - start
        steps += 1
        new_contacts += bool(env.last_events.collided.any())
        touching += cars_touching(env.core)
    return steps / spent, new_contacts / steps, touching / steps


def cars_touching(core: RaceCore) -> bool:
    """Whether the boxes of cars 0 and 1 (each grown by 1 cm) overlap (separating axes)."""
    car = core.config.car
    half = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]]) * [0.5 * car.length + 0.005,
                                                             0.5 * car.width + 0.005]
    boxes = []
    for i in range(2):
        c, s = np.cos(core.yaw[0, i]), np.sin(core.yaw[0, i])
        axes = np.array([[c, s], [-s, c]])
        boxes.append((axes, core.position[0, i] + half @ axes))
    for axes, _ in boxes:
        for axis in axes:
            (lo0, hi0), (lo1, hi1) = [((pts @ axis).min(), (pts @ axis).max()) for _, pts in boxes]
            if lo0 > hi1 or lo1 > hi0:
                return False
    return True


def bench_core(track: str, num_envs: int, seconds: float, num_bots: int = 0) -> float:
    """Return agent-steps/s of the batched core (step + observation + reward)."""
    config = EnvConfig(track=track, num_cars=2, rules=ENDLESS, max_cycles=10**9,
                       num_bots=num_bots)
    core = RaceCore(config, h2h_racing.load_track(track), num_envs=num_envs)
    core.reset(seed=0)
    weights = rewards.weights_of(config.reward)
    steps, spent = 0, 0.0
    deadline = clock() + seconds
    while clock() < deadline:
        steer, speed = centre_controller(core)
        start = clock()
        racing = core.racing
        events = core.step(steer, speed)
        state_observation(core)
        rewards.reward_terms(weights, events, core.speed, racing)
        spent += clock() - start
        steps += 1
    return steps * num_envs * 2 / spent


def main() -> None:
    """Run the benchmarks and print one line per figure."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short runs (smoke test)")
    parser.add_argument("--track", default="speedway")
    parser.add_argument("--cpu-time", action="store_true",
                        help="time with this thread's CPU time instead of the wall clock "
                             "(steadier where other processes share the CPU)")
    args = parser.parse_args()
    global clock
    clock = time.thread_time if args.cpu_time else time.perf_counter
    seconds = 1.0 if args.quick else 8.0
    # Warm up: compile the kernels (cached on disk after the first run) and build the track.
    bench_parallel_env(args.track, 0.2)
    bench_core(args.track, 8, 0.2)
    print(f"machine: {platform.machine()}, {platform.python_implementation()} "
          f"{platform.python_version()}, numpy {np.__version__}; "
          f"{'thread CPU time' if args.cpu_time else 'wall clock'}; h2h_racing from "
          f"{os.path.dirname(os.path.dirname(h2h_racing.__file__))}")
    env_rate, _, _ = bench_parallel_env(args.track, seconds)
    print(f"ParallelEnv, 2 cars, state obs:       {env_rate:>10,.0f} env-steps/s")
    env_rate, new, touching = bench_parallel_env(args.track, seconds, contact=True)
    print(f"  the same, ramming each other:       {env_rate:>10,.0f} env-steps/s "
          f"({100 * new:.0f} % of steps with a new contact, {100 * touching:.0f} % touching)")
    env_rate, _, _ = bench_parallel_env(args.track, seconds, num_bots=3)
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
