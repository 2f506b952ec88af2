"""Several tracks in one RacingVecEnv: K blocks of copies in one core, each racing its track.

The rows of each block are the rows a RacingVecEnv of that track alone gives, seeded with the
track's seed (``RaceCore.track_seeds``), its copies placed where the block's copies are in the
shared pymunk Space (pymunk works in world coordinates: the last bits of a copy's motion
depend on where it is).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.sim.core import RaceCore
from h2h_racing.track.io import load_track
from h2h_racing.training.config import TrainConfig
from h2h_racing.training.tracks import ProceduralTracks, random_training_track
from h2h_racing.training.train import train
from h2h_racing.training.vec_env import PoolOpponent, RacingVecEnv

CONFIG = EnvConfig(track="oval", num_cars=1, rules=RaceRules.preset("time_trial", "training"))
OVAL, KIDNEY = load_track("oval"), load_track("kidney")


def alone_like(env: RacingVecEnv, config: EnvConfig, sizes: list[int],
               **kwargs: object) -> list[RacingVecEnv]:
    """A VecEnv of each of ``env``'s tracks alone, seeded with its track's seed, its copies
    placed where that block's copies are in ``env``'s Space."""
    seeds = RaceCore.track_seeds(3, len(sizes))
    out, first = [], 0
    for track, size, seed in zip(env.tracks, sizes, seeds):
        alone = RacingVecEnv(config, num_envs=size, seed=seed, track=track, **kwargs)
        alone.core.env_offset = env.core.env_offset[first:first + size].copy()
        alone.core._sync_physics()  # the same copies, moved to the block's place
        out.append(alone)
        first += size
    return out


class TestRows:
    def test_each_block_s_rows_are_those_of_its_track_alone(self) -> None:
        env = RacingVecEnv(CONFIG, num_envs=4, seed=3, track=[OVAL, KIDNEY])
        assert env.num_envs == 4 and [t.name for t in env.tracks] == ["oval", "kidney"]
        assert env.core.num_tracks == 2 and env.core.track_index.tolist() == [0, 0, 1, 1]
        alone = alone_like(env, CONFIG, [2, 2])
        # Steering left, right and straight in turn, at three speeds: some copies leave the
        # track and reset, so the auto-reset rows are compared too.
        actions = torch.tensor([[1.0, 1.0], [-1.0, 0.5], [0.0, 0.0], [0.5, 1.0]])
        ended = 0
        for _ in range(40):
            obs, reward, dones, extras = env.step(actions)
            parts = [one.step(rows) for one, rows in zip(alone, (actions[:2], actions[2:]))]
            for key in ("policy", "critic"):
                assert torch.equal(obs[key], torch.cat([p[0][key] for p in parts]))
            assert torch.equal(reward, torch.cat([p[1] for p in parts]))
            assert torch.equal(dones, torch.cat([p[2] for p in parts]))
            assert torch.equal(extras["time_outs"], torch.cat([p[3]["time_outs"] for p in parts]))
            assert torch.equal(env.episode_length_buf,
                               torch.cat([one.episode_length_buf for one in alone]))
            ended += int(dones.sum())
        assert ended > 0

    def test_each_track_has_its_own_opponents_and_experts(self) -> None:
        # 32 copies of 2 cars a track: 64 bodies in every core, so all of them sort contacts
        # with pymunk's spatial hash, in the order the bodies were made (test_core_tracks).
        config = EnvConfig(track="oval", num_cars=2,
                           rules=RaceRules.preset("head_to_head", "training"))
        kwargs = dict(learners=1, opponent="racing_line", expert="pure_pursuit")
        env = RacingVecEnv(config, num_envs=64, seed=3, track=[OVAL, KIDNEY], **kwargs)
        alone = alone_like(env, config, [32, 32], **kwargs)
        drivers = env._opponents.drivers
        assert [d._track for d in drivers] == [OVAL, KIDNEY]  # each its track's racing line
        actions = torch.tensor(np.random.default_rng(0).uniform(-0.6, 1.0, (30, 64, 2)),
                               dtype=torch.float32)
        for step in range(30):
            obs = env.step(actions[step])[0]
            parts = [one.step(rows) for one, rows in zip(alone, actions[step].split(32))]
            for key in ("policy", "critic", "expert"):
                assert torch.equal(obs[key], torch.cat([p[0][key] for p in parts])), key

    def test_log_is_the_mean_over_the_copies_that_ended(self) -> None:
        env = RacingVecEnv(CONFIG, num_envs=4, seed=3, track=[OVAL, KIDNEY])
        # Block 0's two copies steer off at once (an infraction ends the episode under
        # training rules); block 1 drives straight and slow, so only block 0 reports.
        actions = torch.tensor([[1.0, 1.0], [1.0, 1.0], [0.0, -1.0], [0.0, -1.0]])
        for _ in range(200):
            _, _, dones, extras = env.step(actions)
            if dones[:2].all():
                break
        assert not dones[2:].any()
        assert extras["log"]["off_tracks"] == 1.0 and extras["log"]["lap_completion"] == 0.0

    def test_set_tracks_gives_each_block_its_track(self) -> None:
        env = RacingVecEnv(CONFIG, num_envs=4, seed=3, track=[OVAL, KIDNEY], learners=1,
                           opponent=None)
        speedway, technical = load_track("speedway"), load_track("technical")
        env.set_tracks([speedway, technical])
        assert env.tracks == (speedway, technical) and env.core.tracks == (speedway, technical)
        assert all(env.core.steps == 0)
        with pytest.raises(ValueError, match=r"set_tracks needs one track per block of copies "
                                             r"\(2\), got 1"):
            env.set_tracks([OVAL])
        with pytest.raises(ValueError, match=r"set_tracks needs one track per block of copies "
                                             r"\(2\), got 1"):
            env.set_track(OVAL)
        with pytest.raises(AttributeError, match="races 2 tracks, so it has no single track: "
                                                 "see tracks"):
            _ = env.track

    def test_a_pool_of_opponents_splits_with_the_blocks(self) -> None:
        config = EnvConfig(track="oval", num_cars=2,
                           rules=RaceRules.preset("head_to_head", "training"))
        pool = PoolOpponent(("racing_line", "pure_pursuit", "blocker", "racing_line"))
        env = RacingVecEnv(config, num_envs=4, learners=1, opponent=pool, track=[OVAL, KIDNEY])
        assert env.opponent is pool
        assert [d.specs for d in env._opponents.drivers] == [("racing_line", "pure_pursuit"),
                                                             ("blocker", "racing_line")]
        env.step(torch.zeros(4, 2))

    def test_bad_tracks_and_actions_are_refused(self) -> None:
        with pytest.raises(ValueError, match="5 env copies do not split evenly into 2 tracks"):
            RacingVecEnv(CONFIG, num_envs=5, track=[OVAL, KIDNEY])
        with pytest.raises(ValueError, match="a DeepRacer reward function or simtrace logs "
                                             "need one track"):
            RacingVecEnv(CONFIG, num_envs=2, track=[OVAL, KIDNEY], simtrace="unused")
        env = RacingVecEnv(CONFIG, num_envs=4, track=[OVAL, KIDNEY])
        with pytest.raises(ValueError, match=r"actions must have shape \(4, 2\) \(one row per "
                                             r"learner car of every copy\), got \(5, 2\)"):
            env.step(torch.zeros(5, 2))


class TestTrainConfig:
    SMALL = TrainConfig(track="procedural", num_envs=8, num_steps_per_env=8,
                        hidden_dims=(16, 16), procedural=ProceduralTracks(tracks=2, every=1))

    def test_tracks_split_the_copies_with_seeds_of_their_own(self) -> None:
        env = self.SMALL.make_env()
        assert env.core.num_tracks == 2 and env.core.track_index.tolist() == [0] * 4 + [1] * 4
        # Each block's generator is seeded apart, so its random starts differ.
        assert not np.allclose(env.core.s[:4], env.core.s[4:])
        single = dataclasses.replace(self.SMALL, procedural=ProceduralTracks())
        assert single.make_env().core.num_tracks == 1

    def test_training_draws_a_track_per_block_in_turn(self) -> None:
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
