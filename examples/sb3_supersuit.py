"""Train every car of a race with Stable-Baselines3 PPO through SuperSuit's vector env.

    python examples/sb3_supersuit.py                          # 2 cars, lidar + state, 4096 steps
    python examples/sb3_supersuit.py --copies 8 --timesteps 1000000 --out runs/sb3_pz

SuperSuit turns the PettingZoo env into a vector env with one row per car (all cars share one
policy: parameter sharing) and concatenates ``--copies`` races. It needs the same agents on
every step, so the env runs with ``parked_agents=True``: a car that finishes or retires stays
in the race as a parked agent (reward 0, actions ignored) until the race ends, and then every
car reports its end together and SuperSuit resets the race. ``Dict`` observations (here
``lidar`` and ``state``) go to SB3's ``MultiInputPolicy``. The default run is short (a smoke
test of the stack, not a trained driver).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

import supersuit as ss
from stable_baselines3 import PPO
from stable_baselines3.common.utils import set_random_seed
from stable_baselines3.common.vec_env import VecMonitor

import h2h_racing


def make_vec_env(track: str = "oval", cars: int = 2, copies: int = 2,
                 sensors: Sequence[str] = ("lidar", "state")) -> Any:
    """``copies`` races of ``cars`` cars as one SB3 vector env of ``copies * cars`` rows."""
    race = h2h_racing.parallel_env(track=track, num_cars=cars, rules="training",
                                   max_cycles=600, sensors=list(sensors), parked_agents=True)
    venv = ss.pettingzoo_env_to_vec_env_v1(race)
    venv = ss.concat_vec_envs_v1(venv, copies, num_cpus=0, base_class="stable_baselines3")
    return VecMonitor(venv)  # episode returns and lengths for SB3's logs


def train(track: str = "oval", cars: int = 2, copies: int = 2, timesteps: int = 4096,
          seed: int = 0, out: str | None = None, verbose: int = 0,
          epochs: int = 10) -> dict[str, Any]:
    """Train PPO for ``timesteps`` steps (summed over the rows); return the model."""
    venv = make_vec_env(track, cars, copies)
    # SuperSuit's vector env has no seed() for SB3 to call: seed SB3 (torch, numpy) here
    # instead of passing PPO(seed=...).
    set_random_seed(seed)
    model = PPO("MultiInputPolicy", venv, n_steps=max(64, min(512, timesteps // venv.num_envs)),
                batch_size=64, n_epochs=epochs, verbose=verbose)
    model.learn(total_timesteps=timesteps)
    if out is not None:
        model.save(out)
    obs = venv.reset()
    actions, _ = model.predict(obs, deterministic=True)
    venv.close()
    return {"model": model, "actions": actions,
            "episodes": [dict(e) for e in model.ep_info_buffer]}


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--track", default="oval", help="catalogue name or track file")
    parser.add_argument("--cars", type=int, default=2, help="cars in each race")
    parser.add_argument("--copies", type=int, default=2, help="races stepped together")
    parser.add_argument("--timesteps", type=int, default=4096, help="PPO training steps")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=None, help="save the model here (SB3 .zip)")
    args = parser.parse_args(argv)
    if args.timesteps < 1:
        parser.error(f"--timesteps must be >= 1, got {args.timesteps}")
    result = train(args.track, args.cars, args.copies, args.timesteps, seed=args.seed,
                   out=args.out, verbose=1)
    print(f"{len(result['episodes'])} car-episodes in the last 100 logged; actions of the "
          f"first reset: {result['actions'].round(2).tolist()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
