"""The rsl-rl VecEnv's training starts (round robin per copy) and its refusal to alternate."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.training.vec_env import RacingVecEnv
from h2h_racing.track.io import load_track

L = load_track("oval").length  # 19.999672 m


def config(**overrides: object) -> EnvConfig:
    base = dict(track="oval", num_cars=1, rules=RaceRules.preset("head_to_head", "training"),
                round_robin_starts=True)
    base.update(overrides)
    return EnvConfig(**base)


class TestRoundRobinStarts:
    """Auto-resets move each copy's start 0.05 L further; random starts give way."""

    def test_each_copy_advances_on_its_own_resets(self) -> None:
        env = RacingVecEnv(config(), num_envs=3, seed=0)  # random_starts=True is overridden
        assert env.core.start_distance[:, 0].tolist() == [0.0, 0.0, 0.0]
        # Copy 0 steers hard left at full speed (off the track within a second); copy 1
        # drives straight at mid speed (off at the first bend); copy 2 crawls straight on.
        actions = torch.tensor([[1.0, 1.0], [0.0, 0.0], [0.0, -1.0]])
        ends = np.zeros(3, dtype=int)
        for _ in range(60):
            _, _, dones, _ = env.step(actions)
            ends += dones.numpy().astype(int)
        assert ends[0] >= 2 and ends[0] > ends[2]
        # After k ended episodes a copy starts k * 0.05 L round (mod the lap).
        expected = np.mod(ends * 0.05, 1.0) * L
        np.testing.assert_allclose(env.core.start_distance[:, 0], expected, atol=1e-9)
        assert env.core.episodes.tolist() == (ends + 1).tolist()

    def test_random_starts_without_round_robin(self) -> None:
        env = RacingVecEnv(config(round_robin_starts=False), num_envs=3, seed=0)
        starts = env.core.start_distance[:, 0]
        assert len(set(starts.tolist())) == 3 and np.all((starts >= 0) & (starts < L))


class TestDirection:
    """Copies of one core share a direction but reset one at a time: no alternation."""

    def test_alternate_direction_is_refused_with_the_alternatives(self) -> None:
        with pytest.raises(ValueError, match=r"alternate_direction.*reversed\(\).*parallel_env"):
            RacingVecEnv(config(alternate_direction=True), num_envs=2)

    def test_reversed_track_trains(self) -> None:
        env = RacingVecEnv(config(), num_envs=2, track=load_track("oval").reversed())
        _, reward, _, _ = env.step(torch.zeros(2, 2))
        # Both copies drove off the line in the reversed direction: positive progress.
        assert torch.all(reward > 0)
