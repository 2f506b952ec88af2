"""Tests for :mod:`h2h_racing.policies.trained_plain`: a plain MLP actor computed without
rsl-rl gives rsl-rl's actions to the bit, and anything else is left to rsl-rl."""

from __future__ import annotations

import copy
import subprocess
import sys

import numpy as np
import pytest
import torch
from tensordict import TensorDict

from h2h_racing.config.env import EnvConfig
from h2h_racing.policies.trained import TrainedPolicy, load_policy_payload, shipped_policies
from h2h_racing.policies.trained_plain import plain_actor
from h2h_racing.sim.core import RaceCore
from h2h_racing.track.io import load_track

MLP_POLICIES = [name for name, path in shipped_policies().items()
                if load_policy_payload(path)["actor_cfg"]["class_name"] == "MLPModel"]


def observations(driver: TrainedPolicy, copies: int, steps: int) -> dict[str, np.ndarray]:
    """The driver's observation groups after ``steps`` steps of its own driving on speedway."""
    config = EnvConfig(num_cars=1)
    core = RaceCore(config, load_track("speedway"), num_envs=copies)
    core.reset(seed=3)
    driver.reset(core)
    for _ in range(steps):
        core.step(*config.commands(driver.act(core, 0)[:, None, :]))
    return driver._observe(core, 0)


def rsl_rl_actions(driver: TrainedPolicy, obs: dict[str, np.ndarray]) -> torch.Tensor:
    rows = len(next(iter(obs.values())))
    with torch.inference_mode():
        return driver._actor(TensorDict({k: torch.from_numpy(v) for k, v in obs.items()},
                                        batch_size=[rows]))


@pytest.mark.parametrize("name", MLP_POLICIES)
def test_plain_actor_is_rsl_rl_to_the_bit(name: str) -> None:
    driver = TrainedPolicy(shipped_policies()[name])
    real = observations(driver, copies=7, steps=20)
    forward = plain_actor(driver.payload, real)
    assert forward is not None
    rng = np.random.default_rng(0)
    for obs in (real, {k: rng.normal(0.0, 3.0, (rows, v.shape[1])).astype(np.float32)
                       for k, v in real.items() for rows in (1, 3, 10, 64)}):
        with torch.inference_mode():
            plain = forward(obs)
        assert torch.equal(plain, rsl_rl_actions(driver, obs))


def test_a_plain_driver_does_not_import_rsl_rl() -> None:
    """Evaluating a state-observation policy imports neither rsl-rl nor tensordict (about
    3 s of a command's start: tensordict imports torch._dynamo)."""
    code = ("import sys; from h2h_racing.training.evaluate import evaluate; "
            "evaluate('ppo_generalist', 'oval', episodes=2); "
            "print(sorted(m for m in ('rsl_rl', 'tensordict') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip().splitlines()[-1] == "[]"


def test_other_actors_are_left_to_rsl_rl() -> None:
    payload = load_policy_payload(shipped_policies()["ppo_generalist"])
    obs = {"policy": np.zeros((2, payload["actor_state_dict"]["mlp.0.weight"].shape[1]),
                              dtype=np.float32)}
    assert plain_actor(payload, obs) is not None
    odd = copy.deepcopy(payload)
    odd["actor_cfg"]["class_name"] = "CNNModel"
    assert plain_actor(odd, obs) is None
    odd = copy.deepcopy(payload)
    odd["actor_cfg"]["distribution_cfg"]["class_name"] = "BetaDistribution"
    assert plain_actor(odd, obs) is None
    odd = copy.deepcopy(payload)
    odd["actor_cfg"]["unknown_setting"] = 1
    assert plain_actor(odd, obs) is None
    # Weights of another observation size: rsl-rl's model tells the user what does not fit.
    assert plain_actor(payload, {"policy": obs["policy"][:, :-1]}) is None
    odd = copy.deepcopy(payload)
    del odd["actor_state_dict"]["mlp.4.bias"]
    assert plain_actor(odd, obs) is None
