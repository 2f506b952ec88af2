"""Train every car of a race with TorchRL: multi-agent PPO (shared actor, centralised critic).

    python examples/torchrl_multi_agent.py                    # 2 cars on the oval, 4096 frames
    python examples/torchrl_multi_agent.py --cars 4 --frames 500000 --track speedway

TorchRL's ``PettingZooWrapper`` puts all cars in one group (``"car"``, the agents' common
prefix) with ``use_mask=True, done_on_any=False``: a car that finishes or retires is masked
(``("car", "mask")`` False) and the race goes on until every car is out. The wrapper sends an
action for every car on every step; the env ignores those of cars that have left. The
infos are flat numbers, so they arrive as ``("car", "info", <key>)`` tensors. The default
run is short (a smoke test of the stack, not a trained driver).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

import torch
from tensordict.nn import NormalParamExtractor, TensorDictModule
from torch import nn
from torchrl.collectors import Collector
from torchrl.envs import PettingZooWrapper
from torchrl.modules import MultiAgentMLP, ProbabilisticActor, TanhNormal
from torchrl.objectives import ClipPPOLoss, ValueEstimators

import h2h_racing


def make_env(track: str = "oval", cars: int = 2, seed: int = 0) -> PettingZooWrapper:
    """The race as a TorchRL env: one group ``"car"`` of ``cars`` agents, departures masked."""
    race = h2h_racing.parallel_env(track=track, num_cars=cars, rules="training",
                                   max_cycles=600)
    return PettingZooWrapper(race, use_mask=True, done_on_any=False, seed=seed)


def train(track: str = "oval", cars: int = 2, frames: int = 4096, frames_per_batch: int = 1024,
          seed: int = 0, lr: float = 3e-4, epochs: int = 4) -> dict[str, Any]:
    """Train for ``frames`` env steps; return the policy and the mean reward of each batch."""
    torch.manual_seed(seed)
    env = make_env(track, cars, seed)
    obs_size = env.observation_spec["car", "observation"].shape[-1]
    actor_net = nn.Sequential(
        MultiAgentMLP(n_agent_inputs=obs_size, n_agent_outputs=2 * 2, n_agents=cars,
                      centralised=False, share_params=True, depth=2, num_cells=64,
                      activation_class=nn.Tanh),
        NormalParamExtractor())
    actor = ProbabilisticActor(
        TensorDictModule(actor_net, in_keys=[("car", "observation")],
                         out_keys=[("car", "loc"), ("car", "scale")]),
        spec=env.full_action_spec["car", "action"], in_keys=[("car", "loc"), ("car", "scale")],
        out_keys=[("car", "action")], distribution_class=TanhNormal,
        distribution_kwargs={"low": -1.0, "high": 1.0}, return_log_prob=True,
        log_prob_key=("car", "action_log_prob"))
    # The critic sees every car (centralised); the actor only its own observation.
    critic = TensorDictModule(
        MultiAgentMLP(n_agent_inputs=obs_size, n_agent_outputs=1, n_agents=cars,
                      centralised=True, share_params=True, depth=2, num_cells=64,
                      activation_class=nn.Tanh),
        in_keys=[("car", "observation")], out_keys=[("car", "state_value")])
    loss = ClipPPOLoss(actor_network=actor, critic_network=critic, clip_epsilon=0.2,
                       entropy_coeff=1e-3, normalize_advantage=False)
    # Every car has its own reward and done flags (a car leaves the race on its own).
    loss.set_keys(reward=("car", "reward"), action=("car", "action"),
                  value=("car", "state_value"), done=("car", "done"),
                  terminated=("car", "terminated"), sample_log_prob=("car", "action_log_prob"))
    loss.make_value_estimator(ValueEstimators.GAE, gamma=0.99, lmbda=0.95)
    optimiser = torch.optim.Adam(loss.parameters(), lr)
    collector = Collector(env, actor, frames_per_batch=frames_per_batch, total_frames=frames,
                          auto_register_policy_transforms=False)
    batch_rewards = []
    for data in collector:
        with torch.no_grad():
            loss.value_estimator(data, params=loss.critic_network_params,
                                 target_params=loss.target_critic_network_params)
        for _ in range(epochs):  # passes over the batch
            parts = loss(data)
            total = parts["loss_objective"] + parts["loss_critic"] + parts["loss_entropy"]
            optimiser.zero_grad()
            total.backward()
            nn.utils.clip_grad_norm_(loss.parameters(), 1.0)
            optimiser.step()
        racing = data["next", "car", "mask"]
        batch_rewards.append(float(data["next", "car", "reward"].squeeze(-1)[racing].mean()))
    collector.shutdown()
    env.close()
    return {"policy": actor, "batch_rewards": batch_rewards}


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--track", default="oval", help="catalogue name or track file")
    parser.add_argument("--cars", type=int, default=2, help="cars in the race (agents)")
    parser.add_argument("--frames", type=int, default=4096, help="env steps to train")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    if args.frames < 1024:
        parser.error(f"--frames must be >= 1024 (one batch), got {args.frames}")
    result = train(args.track, args.cars, args.frames, seed=args.seed)
    for i, reward in enumerate(result["batch_rewards"]):
        print(f"batch {i}: mean reward per racing car-step {reward:.4f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
