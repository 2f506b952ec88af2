"""SuperSuit's vector env + Stable-Baselines3 PPO on the multi-agent env, Dict observations."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Any

import numpy as np
import pytest

supersuit = pytest.importorskip("supersuit")
sb3 = pytest.importorskip("stable_baselines3")

import h2h_racing  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]

# Training rules and a 150-step limit: cars leave the oval at different times, so races end
# (and the vector env resets them) several times within a few hundred steps.
RACE = {"track": "oval", "num_cars": 2, "rules": "training", "max_cycles": 150,
        "sensors": ["lidar", "state"]}


def vec_env(copies: int, **kw: Any) -> Any:
    env = h2h_racing.parallel_env(**{**RACE, **kw})
    venv = supersuit.pettingzoo_env_to_vec_env_v1(env)
    return supersuit.concat_vec_envs_v1(venv, copies, num_cpus=0, base_class="stable_baselines3")


def test_example_ppo_learns_and_predicts_with_parked_agents(tmp_path: Path) -> None:
    spec = importlib.util.spec_from_file_location("sb3_supersuit",
                                                  ROOT / "examples" / "sb3_supersuit.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    result = example.train(copies=2, timesteps=1024, seed=0, out=str(tmp_path / "model"),
                           epochs=1)
    model = result["model"]
    assert model.num_timesteps >= 1024 and (tmp_path / "model.zip").is_file()
    assert set(model.observation_space.spaces) == {"lidar", "state"}
    # Every car of a race reports its end on the race's last step: VecMonitor saw episodes.
    assert len(result["episodes"]) >= 4
    assert result["actions"].shape == (4, 2)  # 2 races x 2 cars
    assert np.all(np.abs(result["actions"]) <= 1.0)


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
