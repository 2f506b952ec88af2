"""Train several cars with RLlib's multi-agent PPO through its PettingZoo wrapper.

    python examples/rllib_multi_agent.py                      # 2 cars, 3 iterations
    python examples/rllib_multi_agent.py --cars 3 --iterations 200 --shared

The race is ``h2h_racing.parallel_env(...)`` wrapped in RLlib's ``ParallelPettingZooEnv``
(``ray.rllib.env.wrappers.pettingzoo_env``); each car ``car_i`` learns its own policy (an
RLModule per car), or with ``--shared`` one policy drives every car (parameter sharing).
Training rules end a car's episode at its first infraction or after one lap; RLlib stops
sending actions to a car once its episode has ended, and the race goes on for the others.

Ray runs locally, listening on 127.0.0.1 only and without its dashboard
(``h2h_racing.league.backends.local_ray_options``). The default run is short (a
smoke test of the whole stack, not trained drivers). Needs ``ray[rllib]`` (in the ``dev``
extra).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

ENV_NAME = "h2h_racing_rllib"
"""Name the race is registered under with RLlib (``ray.tune.registry.register_env``)."""


def make_env(env_config: dict[str, Any]) -> Any:
    """The RLlib env: ``ParallelPettingZooEnv(h2h_racing.parallel_env(**env_config))``."""
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv

    import h2h_racing

    return ParallelPettingZooEnv(h2h_racing.parallel_env(**env_config))


def build_config(track: str = "oval", cars: int = 2, shared: bool = False,
                 max_cycles: int = 300, batch: int = 600, seed: int = 0) -> Any:
    """The ``PPOConfig`` of the run: one RLModule per car (or one shared), local sampling."""
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig
    from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec
    from ray.tune.registry import register_env

    register_env(ENV_NAME, make_env)
    agents = [f"car_{i}" for i in range(cars)]
    modules = ["shared"] if shared else agents

    def policy_of(agent_id: str, episode: Any = None, **kwargs: Any) -> str:
        return "shared" if shared else agent_id

    return (
        PPOConfig()
        .environment(ENV_NAME, env_config={"track": track, "num_cars": cars,
                                           "rules": "training", "max_cycles": max_cycles})
        # Sampling in the driver process: no extra Ray workers on a small machine.
        .env_runners(num_env_runners=0, rollout_fragment_length="auto")
        .multi_agent(policies=set(modules), policy_mapping_fn=policy_of)
        .rl_module(rl_module_spec=MultiRLModuleSpec(
                       rl_module_specs={m: RLModuleSpec() for m in modules}),
                   model_config=DefaultModelConfig(fcnet_hiddens=[64, 64]))
        .training(train_batch_size_per_learner=batch, minibatch_size=min(128, batch),
                  num_epochs=2, lr=3e-4)
        .debugging(seed=seed)
    )


def train(iterations: int = 3, **config: Any) -> list[dict[str, Any]]:
    """Train for ``iterations`` PPO iterations; return one summary per iteration.

    Each summary holds ``iteration``, ``env_steps`` (lifetime env steps sampled) and
    ``returns`` (``{module: mean episode return}``, for the modules that ended an episode).
    """
    import ray

    from h2h_racing.league.backends import local_ray_options

    started = not ray.is_initialized()
    if started:
        # ray.init(_node_ip_address="127.0.0.1", include_dashboard=False), plus Ray's
        # single-machine mode, without which Ray on Linux listens on the network address.
        ray.init(log_to_driver=False, **local_ray_options(num_cpus=2))
    algo = build_config(**config).build_algo()
    summaries = []
    try:
        for _ in range(iterations):
            result = algo.train()
            env_runners = result.get("env_runners", {})
            returns = env_runners.get("module_episode_returns_mean", {})
            summaries.append({
                "iteration": int(result["training_iteration"]),
                "env_steps": int(env_runners.get("num_env_steps_sampled_lifetime", 0)),
                "returns": {str(k): float(v) for k, v in returns.items()},
            })
    finally:
        algo.stop()
        if started:
            ray.shutdown()
    return summaries


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--track", default="oval", help="catalogue name or track file")
    parser.add_argument("--cars", type=int, default=2, help="learning cars (1 to 16)")
    parser.add_argument("--iterations", type=int, default=3, help="PPO iterations")
    parser.add_argument("--shared", action="store_true",
                        help="one policy for every car (parameter sharing)")
    parser.add_argument("--batch", type=int, default=600,
                        help="env steps per iteration (train_batch_size_per_learner)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    if args.iterations < 1:
        parser.error(f"--iterations must be >= 1, got {args.iterations}")
    for summary in train(args.iterations, track=args.track, cars=args.cars,
                         shared=args.shared, batch=args.batch, seed=args.seed):
        returns = ", ".join(f"{m} {r:.2f}" for m, r in sorted(summary["returns"].items()))
        print(f"iteration {summary['iteration']}: {summary['env_steps']} env steps; mean "
              f"episode return {returns or '(no episode ended yet)'}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
