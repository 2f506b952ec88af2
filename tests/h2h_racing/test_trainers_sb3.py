"""SuperSuit's vector env + Stable-Baselines3 PPO on the multi-agent env, Dict observations."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

supersuit = pytest.importorskip("supersuit")
sb3 = pytest.importorskip("stable_baselines3")

from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.utils import set_random_seed  # noqa: E402
from stable_baselines3.common.vec_env import VecMonitor  # noqa: E402

import h2h_racing  # noqa: E402

# Training rules and a 150-step limit: cars leave the oval at different times, so races end
# (and the vector env resets them) several times within a few hundred steps.
RACE = {"track": "oval", "num_cars": 2, "rules": "training", "max_cycles": 150,
        "sensors": ["lidar", "state"]}


def vec_env(copies: int, **kw: Any) -> Any:
    env = h2h_racing.parallel_env(**{**RACE, **kw})
    venv = supersuit.pettingzoo_env_to_vec_env_v1(env)
    return supersuit.concat_vec_envs_v1(venv, copies, num_cpus=0, base_class="stable_baselines3")


def test_ppo_learns_and_predicts_with_parked_agents() -> None:
    venv = VecMonitor(vec_env(2, parked_agents=True))
    assert venv.num_envs == 4  # 2 race copies x 2 cars
    # SuperSuit's ConcatVecEnv has no seed() for SB3 to call: seed SB3 itself instead.
    set_random_seed(0)
    model = PPO("MultiInputPolicy", venv, n_steps=128, batch_size=128, n_epochs=1, verbose=0)
    model.learn(total_timesteps=1024)
    # Every car of a race reports its end on the race's last step: VecMonitor saw episodes.
    assert len(model.ep_info_buffer) >= 4
    obs = venv.reset()
    assert set(obs) == {"lidar", "state"} and obs["state"].shape == (4, 33)
    action, _ = model.predict(obs, deterministic=True)
    assert action.shape == (4, 2)
    assert np.all(np.abs(action) <= 1.0)
    venv.close()


def test_rewards_of_parked_cars_are_zero_until_the_race_resets() -> None:
    venv = vec_env(1, parked_agents=True)
    venv.reset()
    # car_0 crawls straight; car_1 steers hard at full speed and leaves the track early.
    actions = np.array([[0.0, -1.0], [1.0, 1.0]], dtype=np.float32)
    parked_rewards = []
    for _ in range(150):
        _, reward, done, infos = venv.step(actions)
        if done.any():
            # Both cars report the end together, on the step that ends the race.
            assert done.all()
            break
        if infos[1]["parked"]:
            parked_rewards.append(reward[1])
    assert len(parked_rewards) > 10 and all(r == 0.0 for r in parked_rewards[1:])
    assert done.all()
    venv.close()


def test_without_parked_agents_supersuit_refuses_departures() -> None:
    venv = vec_env(1)
    venv.reset()
    actions = np.array([[0.0, -1.0], [1.0, 1.0]], dtype=np.float32)
    with pytest.raises(AssertionError, match="varying numbers of active agents"):
        for _ in range(150):
            venv.step(actions)
    venv.close()
