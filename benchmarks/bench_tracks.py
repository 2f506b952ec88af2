"""Training over several tracks: one core of K tracks against K cores (the old TrackGroups);
asserts nothing.

    python benchmarks/bench_tracks.py              # 8 tracks, 256 copies, about 10 minutes
    python benchmarks/bench_tracks.py --quick      # a smoke run
    python benchmarks/bench_tracks.py --cpu-time   # thread CPU time (a shared machine)

What is timed: rsl-rl PPO iterations as ``h2h-racing train`` runs a procedural config with
``[procedural] tracks = 8`` (``TrainConfig``'s defaults: 256 copies, 32 steps per iteration,
state observations, an MLP actor and critic of (128, 128), one torch thread), the loop of
``OnPolicyRunner.learn`` written out (``act``, ``env.step``, ``process_env_step``, then
``compute_returns`` and ``update``), in two ways over the same 8 random training tracks
(``ProceduralTracks().draw``, given with ``set_tracks``):

- *one core*: ``TrainConfig.make_env()``, one ``RacingVecEnv`` whose core races the 8 tracks
  (8 blocks of 32 copies), one step of every copy at once;
- *8 cores*: 8 ``RacingVecEnv`` of 32 copies, one track each, behind one ``VecEnv`` that steps
  them in turn (``TrackGroups``, which the multi-track core replaced, kept here as it was;
  each group seeded as ``TrainConfig.make_env`` seeded it).

Per way the bench prints the median over ``--rounds`` of samples/s of whole iterations, and
of the env's share alone (``env.step``'s time: the core, the sensors, the rewards, the
opponents), and the one core's ratio to the 8 cores'. Two layouts: time trials (one car, the
procedural recipes' layout) and head-to-head (two cars, the second driven by ``racing_line``:
``h2h-racing train``'s default). The two ways take turns one iteration at a time (the order
alternates every round), so both see the same machine load.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import os
import platform
import statistics
import time
from typing import Any, Sequence

os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")

import numpy as np  # noqa: E402
import torch  # noqa: E402
from rsl_rl.env import VecEnv  # noqa: E402

from h2h_racing.sim.core import RaceCore  # noqa: E402
from h2h_racing.track.io import load_track  # noqa: E402
from h2h_racing.training.config import TrainConfig  # noqa: E402
from h2h_racing.training.tracks import ProceduralTracks  # noqa: E402
from h2h_racing.training.train import make_runner  # noqa: E402
from h2h_racing.training.vec_env import RacingVecEnv  # noqa: E402

clock = time.perf_counter
"""The timer of every figure (``--cpu-time``: the thread's CPU time)."""


class TrackGroups(VecEnv):
    """K ``RacingVecEnv`` groups, each on its own track, as one ``VecEnv`` (the removed
    ``training/vec_env_tracks.py``, as it was: one Python call per group per step)."""

    def __init__(self, groups: Sequence[RacingVecEnv]) -> None:
        self.groups = list(groups)
        first = groups[0]
        self.num_envs = sum(group.num_envs for group in groups)
        self.num_actions = first.num_actions
        self.max_episode_length = max(group.max_episode_length for group in groups)
        self.device = first.device
        self._sizes = [group.num_envs for group in groups]
        self._gather()

    @property
    def cfg(self) -> dict[str, Any]:  # type: ignore[override]
        return self.groups[0].cfg

    def get_observations(self) -> Any:
        return self._obs

    def step(self, actions: torch.Tensor) -> tuple[Any, torch.Tensor, torch.Tensor,
                                                   dict[str, Any]]:
        results = [group.step(rows)
                   for group, rows in zip(self.groups, torch.split(actions, self._sizes))]
        self._gather()
        logs = [result[3]["log"] for result in results if result[3]["log"]]
        keys = dict.fromkeys(key for log in logs for key in log)
        log = {key: float(np.mean([entry[key] for entry in logs if key in entry]))
               for key in keys}
        extras = {"time_outs": torch.cat([result[3]["time_outs"] for result in results]),
                  "log": log}
        return (self._obs, torch.cat([result[1] for result in results]),
                torch.cat([result[2] for result in results]), extras)

    def set_tracks(self, tracks: Sequence[Any]) -> None:
        for group, track in zip(self.groups, tracks):
            group.set_track(track)
        self._gather()

    def _gather(self) -> None:
        self._obs = torch.cat([group.get_observations() for group in self.groups])
        self.episode_length_buf = torch.cat([group.episode_length_buf for group in self.groups])


def groups_env(config: TrainConfig) -> TrackGroups:
    """``config``'s VecEnv as ``TrainConfig.make_env`` built it before the multi-track core:
    one ``RacingVecEnv`` per track, each with its share of the copies and a seed of its own."""
    count = config.procedural.tracks
    size = config.num_envs // count
    env_config, track = config.env_config(), load_track(config.env_config().track)
    return TrackGroups([RacingVecEnv(env_config, num_envs=size, learners=config.learners,
                                     opponent=config.opponent, observations=config.observations,
                                     seed=seed, track=track)
                        for seed in RaceCore.track_seeds(config.seed, count)])


@dataclasses.dataclass
class Way:
    """One way of stepping the copies: its runner and its measurements."""

    name: str
    runner: Any
    obs: Any
    total: list[float] = dataclasses.field(default_factory=list)
    """Samples/s of whole iterations."""
    env: list[float] = dataclasses.field(default_factory=list)
    """Samples/s of ``env.step`` alone."""


def build(name: str, config: TrainConfig, env: Any, tracks: list[Any]) -> Way:
    torch.manual_seed(config.seed)
    env.set_tracks(tracks)
    with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl prints the models
        runner = make_runner(config, env)
    runner.alg.train_mode()
    return Way(name=name, runner=runner, obs=env.get_observations())


def iteration(way: Way) -> tuple[float, float]:
    """One training iteration; returns (iteration seconds, env.step seconds)."""
    runner = way.runner
    obs, env_time = way.obs, 0.0
    start = clock()
    with torch.inference_mode():
        for _ in range(runner.cfg["num_steps_per_env"]):
            actions = runner.alg.act(obs)
            before = clock()
            obs, rewards, dones, extras = runner.env.step(actions)
            env_time += clock() - before
            runner.alg.process_env_step(obs, rewards, dones, extras)
        runner.alg.compute_returns(obs)
    runner.alg.update()
    way.obs = obs
    return clock() - start, env_time


def compare(title: str, config: TrainConfig, rounds: int, warmup: int) -> None:
    rng = np.random.default_rng(config.seed + 1)
    tracks = [config.procedural.draw(rng) for _ in range(config.procedural.tracks)]
    ways = [build("one core", config, config.make_env(), tracks),
            build(f"{config.procedural.tracks} cores", config, groups_env(config), tracks)]
    for way in ways:
        for _ in range(warmup):
            iteration(way)
    for r in range(rounds):
        for way in ways if r % 2 == 0 else ways[::-1]:
            total, env_time = iteration(way)
            samples = way.runner.env.num_envs * way.runner.cfg["num_steps_per_env"]
            way.total.append(samples / total)
            way.env.append(samples / env_time)
    print(f"\n{title} ({rounds} rounds, load average {os.getloadavg()[0]:.1f} at the end)")
    print(f"{'way':<10} {'iteration samples/s':>20} {'ratio':>6} {'env.step samples/s':>19} "
          f"{'ratio':>6}  (median; min-max)")
    base = ways[1]
    for way in ways:
        total, env = statistics.median(way.total), statistics.median(way.env)
        print(f"{way.name:<10} {total:>20,.0f} {total / statistics.median(base.total):>6.2f} "
              f"{env:>19,.0f} {env / statistics.median(base.env):>6.2f}  "
              f"({min(way.total):,.0f}-{max(way.total):,.0f}; "
              f"{min(way.env):,.0f}-{max(way.env):,.0f})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tracks", type=int, default=8, help="tracks at once (default: 8)")
    parser.add_argument("--envs", type=int, default=256,
                        help="env copies, all tracks together (default: 256)")
    parser.add_argument("--rounds", type=int, default=7,
                        help="timed iterations per way and layout (default: 7)")
    parser.add_argument("--warmup", type=int, default=2,
                        help="untimed iterations per way first (default: 2)")
    parser.add_argument("--quick", action="store_true",
                        help="4 tracks, 32 copies, 2 rounds, 1 warm-up: a smoke run")
    parser.add_argument("--cpu-time", action="store_true",
                        help="time with this thread's CPU time instead of the wall clock "
                             "(steadier where other processes share the CPU)")
    args = parser.parse_args()
    global clock
    clock = time.thread_time if args.cpu_time else time.perf_counter
    if args.quick:
        args.tracks, args.envs, args.rounds, args.warmup = 4, 32, 2, 1
    torch.set_num_threads(1)
    print(f"torch {torch.__version__}, {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at the start, "
          f"{'thread CPU time' if args.cpu_time else 'wall clock'}")
    procedural = ProceduralTracks(tracks=args.tracks)
    trial = TrainConfig(track="procedural", num_envs=args.envs, procedural=procedural,
                        eval_every=0)
    compare(f"time trials: {args.envs} copies x 1 car, {args.tracks} tracks", trial,
            args.rounds, args.warmup)
    race = dataclasses.replace(trial, num_cars=2, learners=1, opponent="racing_line")
    compare(f"head-to-head: {args.envs} copies x 2 cars (racing_line drives the second), "
            f"{args.tracks} tracks", race, args.rounds, args.warmup)


if __name__ == "__main__":
    main()
