"""Throughput of DeepRacer reward calls (params building + copy + call); asserts nothing.

    python benchmarks/bench_deepracer.py           # about 10 s
    python benchmarks/bench_deepracer.py --quick

What is timed:
- ``ParamsBuilder.build`` + ``DeepRacerReward.__call__`` (deep copy, call, checks) for every
  car, with the follow-the-centre-line example, on car states taken from a running race
  (speedway, 2 cars + 6 obstacles, and the real reinvent_base route with 1 car when present);
  reported as reward calls per second (target >= 20,000).
- The full ``env.step`` with and without a reward function, for the end-to-end cost.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import h2h_racing
from h2h_racing.deepracer import DeepRacerReward, ParamsBuilder

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "deepracer" / "follow_centre_line.py"
ROUTE = ROOT / ".." / "shared" / "data" / "deepracer_tracks" / "reInvent2019_track.npy"


def states(env, steps: int, rng: np.random.Generator) -> list[dict]:
    """Snapshots of the core arrays the builder reads, from a random-ish drive."""
    env.reset(seed=0)
    out = []
    core = env.core
    for _ in range(steps):
        if not env.agents:
            env.reset(seed=int(rng.integers(1 << 30)))
        env.step({a: np.array([rng.uniform(-0.2, 0.2), -0.5], np.float32) for a in env.agents})
        out.append({"position": core.position[0].copy(), "yaw": core.yaw[0].copy(),
                    "speed_command": core.speed_command[0].copy(),
                    "steering_deg": np.degrees(core.steer_command[0]),
                    "start_distance": core.start_distance[0].copy(),
                    "steps": float(core.steps[0]), "sim_time": float(core.time[0]),
                    "speed": core.speed[0].copy(),
                    "obstacle_position": core.obstacle_position[0].copy(),
                    "obstacle_yaw": core.obstacle_yaw[0].copy()})
    return out


def bench_calls(name: str, env, seconds: float, rng: np.random.Generator) -> None:
    n = env.config.num_cars
    builder = ParamsBuilder(env.track, env.config.car, n)
    reward = DeepRacerReward(str(EXAMPLE), n)
    snaps = states(env, 200, rng)
    calls = 0
    start = time.perf_counter()
    while time.perf_counter() - start < seconds:
        for snap in snaps:
            for i, params in enumerate(builder.build(**snap)):
                reward(i, params)
            calls += n
    elapsed = time.perf_counter() - start
    print(f"{name}: {calls / elapsed:,.0f} reward calls/s "
          f"({1e6 * elapsed / calls:.1f} us per call incl. params; "
          f"{len(builder.waypoints)} waypoints, {n} cars, "
          f"{env.core.num_obstacles} obstacles)")


def bench_env(seconds: float) -> None:
    for label, kw in (("built-in reward", {}), ("DeepRacer reward", {"reward_function":
                                                                     str(EXAMPLE)})):
        env = h2h_racing.parallel_env(track="speedway", num_cars=2, rules="training", **kw)
        env.reset(seed=0)
        steps = 0
        start = time.perf_counter()
        while time.perf_counter() - start < seconds:
            if not env.agents:
                env.reset()
            env.step({a: np.array([0.0, -0.5], np.float32) for a in env.agents})
            steps += 1
        elapsed = time.perf_counter() - start
        print(f"env.step, speedway, 2 cars, {label}: {steps / elapsed:,.0f} steps/s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    seconds = 0.5 if args.quick else 2.5
    rng = np.random.default_rng(0)
    bench_calls("speedway", h2h_racing.parallel_env(track="speedway", num_cars=2,
                                                    race_type="object_avoidance"), seconds, rng)
    if ROUTE.is_file():
        bench_calls("reInvent2019_track", h2h_racing.parallel_env(track=str(ROUTE),
                                                                  num_cars=1), seconds, rng)
    bench_env(seconds)


if __name__ == "__main__":
    main()
