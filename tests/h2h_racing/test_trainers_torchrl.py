"""TorchRL's PettingZooWrapper around the env: specs, masks of departed cars, groupings, SerialEnv."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Any

import pytest

torch = pytest.importorskip("torch")
torchrl_envs = pytest.importorskip("torchrl.envs")

from torchrl.envs import PettingZooWrapper, SerialEnv  # noqa: E402
from torchrl.envs.utils import MarlGroupMapType, check_env_specs  # noqa: E402

import h2h_racing  # noqa: E402
from h2h_racing.envs.infos import INFO_KEYS  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]

# TorchRL 0.14 names the PettingZoo version it was tested with (1.24.3); ours is 1.27.0.
pytestmark = pytest.mark.filterwarnings("ignore:PettingZoo in TorchRL is tested")

# Training rules and random actions: cars leave the oval (and the race) one at a time, well
# before the 150-step time limit ends the race of the others.
RACE = {"track": "oval", "num_cars": 2, "rules": "training", "max_cycles": 150}


def wrap(group_map: Any = None, **kw: Any) -> PettingZooWrapper:
    env = h2h_racing.parallel_env(**{**RACE, **kw})
    return PettingZooWrapper(env, use_mask=True, done_on_any=False, group_map=group_map,
                             seed=0)


def check_departures(td: Any, group: str, cars: int) -> None:
    """Cars leave the race one by one (masked) while the episode goes on, and episodes end."""
    mask = td["next", group, "mask"]
    assert mask.shape[-1] == cars
    partly = (mask.any(-1) & ~mask.all(-1))
    assert partly.any(), "no step had one car out of the race and another still racing"
    # A car's done flag is set where it has left, and the env's done only when all have.
    done = td["next", group, "done"].squeeze(-1)
    assert (done | mask).all()
    assert torch.equal(td["next", "done"].squeeze(-1), done.all(-1))
    assert td["next", "done"].any(), "no race ended within the rollout"


def test_all_cars_in_one_group() -> None:
    env = wrap()
    assert env.group_map == {"car": ["car_0", "car_1"]}
    check_env_specs(env, seed=0)
    info_spec = env.observation_spec["car", "info"]
    assert set(info_spec.keys()) == set(INFO_KEYS)
    td = env.rollout(400, break_when_any_done=False)
    check_departures(td, "car", 2)
    # Infos arrive as numbers: lap times are the documented -1.0 before any lap, never inf.
    info = td["next", "car", "info"]
    assert torch.isfinite(info["last_lap_time"]).all()
    assert (info["last_lap_time"] == -1.0).any()
    reward_sum = sum(info[k] for k in INFO_KEYS if k.startswith("reward_"))
    racing = td["next", "car", "mask"]
    assert torch.allclose(reward_sum[racing], td["next", "car", "reward"].squeeze(-1)[racing],
                          atol=1e-5)


def test_one_group_per_car() -> None:
    env = wrap(group_map=MarlGroupMapType.ONE_GROUP_PER_AGENT)
    assert env.group_map == {"car_0": ["car_0"], "car_1": ["car_1"]}
    check_env_specs(env, seed=0)
    td = env.rollout(400, break_when_any_done=False)
    mask = torch.cat([td["next", g, "mask"] for g in ("car_0", "car_1")], dim=-1)
    assert (mask.any(-1) & ~mask.all(-1)).any()
    assert td["next", "done"].any()


def test_dict_observations() -> None:
    env = wrap(sensors=["lidar", "state"])
    check_env_specs(env, seed=0)
    td = env.rollout(200, break_when_any_done=False)
    assert td["next", "car", "observation", "lidar"].shape == (200, 2, 64)
    check_departures(td, "car", 2)


def test_serial_env_of_two() -> None:
    env = SerialEnv(2, [wrap, wrap])
    try:
        check_env_specs(env, seed=0)
        td = env.rollout(300, break_when_any_done=False)
        assert td.batch_size == (2, 300)
        for copy in range(2):
            check_departures(td[copy], "car", 2)
    finally:
        env.close()


def test_example_trains_and_acts() -> None:
    spec = importlib.util.spec_from_file_location(
        "torchrl_multi_agent", ROOT / "examples" / "torchrl_multi_agent.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    make_env, train = example.make_env, example.train
    result = train(frames=256, frames_per_batch=128, seed=0, epochs=1)
    assert len(result["batch_rewards"]) == 2
    assert all(torch.isfinite(torch.tensor(result["batch_rewards"])))
    env = make_env(seed=1)
    td = env.rollout(50, policy=result["policy"], break_when_any_done=False)
    action = td["car", "action"]
    assert action.shape == (50, 2, 2) and (action.abs() <= 1.0).all()
