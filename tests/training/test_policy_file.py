"""Starting training from a policy (``TrainConfig.init``), and ``init_fresh_slots``: a policy
that raced alone, made ready to meet boxes, bots and cars."""

from __future__ import annotations

import dataclasses

import pytest
import torch
from tensordict import TensorDict

from h2h_racing.policies.trained import load_policy_payload
from h2h_racing.sensors.state import BASE_FEATURES
from h2h_racing.training.config import TrainConfig
from h2h_racing.training.policy_file import FRESH_SLOTS_COUNT
from h2h_racing.training.race_settings import RaceSettings
from h2h_racing.training.train import make_runner

# One car among 6 boxes: the state vector has its opponent and obstacle slots.
BOXES = TrainConfig(track="oval", num_envs=2, num_steps_per_env=4, eval_every=0,
                    rules="race", race=RaceSettings(race_type="object_avoidance"),
                    init="ppo_generalist")


def _actor(config: TrainConfig) -> torch.nn.Module:
    return make_runner(config, config.make_env()).alg.get_policy()


class TestFreshSlots:
    def test_slot_weights_start_at_zero_and_the_rest_is_the_policy(self) -> None:
        shipped = load_policy_payload("ppo_generalist")["actor_state_dict"]
        weights = _actor(dataclasses.replace(BOXES, init_fresh_slots=True)).state_dict()
        first = weights["mlp.0.weight"]
        assert first.shape[1] == 33 and BASE_FEATURES == 19
        assert torch.equal(first[:, BASE_FEATURES:], torch.zeros(128, 33 - BASE_FEATURES))
        assert torch.equal(first[:, :BASE_FEATURES], shipped["mlp.0.weight"][:, :BASE_FEATURES])
        assert weights["obs_normalizer.count"].item() == FRESH_SLOTS_COUNT == 32768
        for key in ("obs_normalizer._mean", "obs_normalizer._std", "mlp.2.weight"):
            assert torch.equal(weights[key], shipped[key])
        # Without it the slots keep their untrained weights.
        plain = _actor(BOXES).state_dict()["mlp.0.weight"]
        assert plain[:, BASE_FEATURES:].abs().sum() > 1.0

    def test_a_box_in_view_changes_nothing_until_trained(self) -> None:
        actor = _actor(dataclasses.replace(BOXES, init_fresh_slots=True))
        actor.eval()
        state = torch.rand(1, 33)
        boxed = state.clone()
        state[:, BASE_FEATURES:] = 0.0
        with torch.inference_mode():
            a = actor(TensorDict({"policy": state}, batch_size=[1]))
            b = actor(TensorDict({"policy": boxed}, batch_size=[1]))
        assert torch.equal(a, b)

    def test_needs_a_state_policy_as_init(self) -> None:
        with pytest.raises(ValueError, match="init_fresh_slots must be true or false, and "
                                             "true only with an init policy"):
            TrainConfig(init_fresh_slots=True)
        camera = TrainConfig(track="oval", num_envs=2, eval_every=0, observations="camera_only",
                             init="camera_speedway", init_fresh_slots=True)
        with pytest.raises(ValueError, match="init_fresh_slots needs a state-observation"):
            _actor(camera)
