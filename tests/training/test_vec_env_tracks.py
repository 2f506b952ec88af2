"""TrackGroups: several RacingVecEnv groups, each on its own track, as one rsl-rl VecEnv."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from h2h_racing.config import EnvConfig, RaceRules
from h2h_racing.track_io import load_track
from h2h_racing.training.config import TrainConfig
from h2h_racing.training.tracks import ProceduralTracks, random_training_track
from h2h_racing.training.train import train
from h2h_racing.training.vec_env import RacingVecEnv
from h2h_racing.training.vec_env_tracks import TrackGroups

CONFIG = EnvConfig(track="oval", num_cars=1, rules=RaceRules.preset("time_trial", "training"))


def pair(seed_a: int = 3, seed_b: int = 4) -> list[RacingVecEnv]:
    """Two groups of 2 and 3 copies on oval and kidney."""
    return [RacingVecEnv(CONFIG, num_envs=2, seed=seed_a, track=load_track("oval")),
            RacingVecEnv(CONFIG, num_envs=3, seed=seed_b, track=load_track("kidney"))]


class TestRows:
    def test_rows_are_each_groups_rows_in_group_order(self) -> None:
        groups, alone = TrackGroups(pair()), pair()
        assert groups.num_envs == 5 and [t.name for t in groups.tracks] == ["oval", "kidney"]
        # Steering left, right and straight in turn, at three speeds: some copies leave the
        # track and reset, so the auto-reset rows are compared too.
        actions = torch.tensor([[1.0, 1.0], [-1.0, 0.5], [0.0, 0.0], [0.5, 1.0], [-0.3, -1.0]])
        ended = 0
        for _ in range(40):
            obs, reward, dones, extras = groups.step(actions)
            parts = [env.step(rows) for env, rows in zip(alone, (actions[:2], actions[2:]))]
            for key in ("policy", "critic"):
                assert torch.equal(obs[key], torch.cat([p[0][key] for p in parts]))
            assert torch.equal(reward, torch.cat([p[1] for p in parts]))
            assert torch.equal(dones, torch.cat([p[2] for p in parts]))
            assert torch.equal(extras["time_outs"], torch.cat([p[3]["time_outs"] for p in parts]))
            assert torch.equal(groups.episode_length_buf,
                               torch.cat([env.episode_length_buf for env in alone]))
            ended += int(dones.sum())
        assert ended > 0

    def test_log_is_the_mean_over_the_groups_that_report(self) -> None:
        groups = TrackGroups(pair())
        # Group 0's two copies steer off at once (an infraction ends the episode under
        # training rules); group 1 drives straight and slow, so only group 0 reports.
        actions = torch.tensor([[1.0, 1.0], [1.0, 1.0], [0.0, -1.0], [0.0, -1.0], [0.0, -1.0]])
        for _ in range(200):
            _, _, dones, extras = groups.step(actions)
            if dones[:2].all():
                break
        assert not dones[2:].any()
        assert extras["log"]["off_tracks"] == 1.0 and extras["log"]["lap_completion"] == 0.0

    def test_set_tracks_gives_each_group_its_track(self) -> None:
        groups = TrackGroups(pair())
        groups.set_tracks([load_track("speedway"), load_track("technical")])
        assert [env.core.track.name for env in groups.groups] == ["speedway", "technical"]
        assert torch.equal(groups.get_observations()["policy"],
                           torch.cat([env.get_observations()["policy"] for env in groups.groups]))
        with pytest.raises(ValueError, match=r"one track per group \(2\), got 1"):
            groups.set_tracks([load_track("oval")])

    def test_bad_groups_and_actions_are_refused(self) -> None:
        with pytest.raises(ValueError, match="at least one"):
            TrackGroups([])
        camera = RacingVecEnv(CONFIG, num_envs=1, observations="camera_only")
        with pytest.raises(ValueError, match=r"group 1 has \(observations, actions, device\) "
                                             r"\('camera_only'"):
            TrackGroups([RacingVecEnv(CONFIG, num_envs=1), camera])
        with pytest.raises(ValueError, match=r"actions must have 5 rows .* got shape \(4, 2\)"):
            TrackGroups(pair()).step(torch.zeros(4, 2))


class TestTrainConfig:
    SMALL = TrainConfig(track="procedural", num_envs=8, num_steps_per_env=8,
                        hidden_dims=(16, 16), procedural=ProceduralTracks(tracks=2, every=1))

    def test_tracks_split_the_copies_with_seeds_of_their_own(self) -> None:
        env = self.SMALL.make_env()
        assert isinstance(env, TrackGroups) and [g.core.num_envs for g in env.groups] == [4, 4]
        # Each group's generator is seeded apart, so its random starts differ.
        assert not np.allclose(env.groups[0].core.s, env.groups[1].core.s)
        single = dataclasses.replace(self.SMALL, procedural=ProceduralTracks())
        assert isinstance(single.make_env(), RacingVecEnv)

    def test_training_draws_a_track_per_group_in_turn(self) -> None:
        runner = train(self.SMALL, iterations=2)
        # Every iteration (every=1) draws 2 tracks from the run's track generator: the second
        # iteration's are the third and fourth draws.
        rng = np.random.default_rng(self.SMALL.seed + 1)
        drawn = [random_training_track(rng).name for _ in range(4)]
        assert [t.name for t in runner.env.tracks] == drawn[2:]

    def test_bad_tracks_are_refused(self) -> None:
        with pytest.raises(ValueError, match=r"\[procedural\] tracks must be an integer >= 1"):
            ProceduralTracks(tracks=0)
        with pytest.raises(ValueError, match=r"must split evenly into \[procedural\] tracks "
                                             r"\(3\)"):
            dataclasses.replace(self.SMALL, procedural=ProceduralTracks(tracks=3))
        with pytest.raises(ValueError, match="set track = 'procedural'"):
            dataclasses.replace(self.SMALL, track="oval")
