"""The rsl-rl VecEnv over the batched core: rows, auto-reset, time-outs, training runs."""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest
import torch

from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.training.vec_env import RacingVecEnv

TRAIN_CFG = {
    "num_steps_per_env": 8, "save_interval": 100,
    "obs_groups": {"actor": ["policy"], "critic": ["critic"]},
    "algorithm": {"class_name": "PPO", "learning_rate": 1e-3, "num_learning_epochs": 2,
                  "num_mini_batches": 2},
    "actor": {"class_name": "MLPModel", "hidden_dims": [16, 16], "obs_normalization": True,
              "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": 0.5}},
    "critic": {"class_name": "MLPModel", "hidden_dims": [16, 16], "obs_normalization": True},
}


def training_config(**overrides: object) -> EnvConfig:
    base = dict(track="oval", num_cars=2, rules=RaceRules.preset("head_to_head", "training"))
    base.update(overrides)
    return EnvConfig(**base)


class TestRows:
    """Rows are learner cars; opponents are driven inside step()."""

    def test_self_play_has_one_row_per_car(self) -> None:
        env = RacingVecEnv(training_config(num_cars=3), num_envs=4)
        obs = env.get_observations()
        # 4 copies x 3 learner cars = 12 rows; state 19 + 4*2 + 3*2 = 33 features; the critic
        # adds 4 features for each of the 2 other cars = 41.
        assert obs.batch_size == torch.Size([12])
        assert obs["policy"].shape == (12, 33) and obs["critic"].shape == (12, 41)
        assert obs["policy"].dtype == torch.float32

    def test_single_learner_against_a_scripted_opponent(self) -> None:
        env = RacingVecEnv(training_config(), num_envs=5, learners=1, opponent="pure_pursuit")
        assert env.num_envs == 5
        _, reward, dones, extras = env.step(torch.zeros(5, 2))
        assert reward.shape == (5,) and dones.shape == (5,)
        assert extras["time_outs"].shape == (5,)
        # The opponent (car 1) moved although no action was given for it.
        assert np.all(env.core.speed[:, 1] > 0.0)

    def test_bots_fill_the_opponent_slots(self) -> None:
        env = RacingVecEnv(training_config(num_cars=1, race_type="head_to_bot"), num_envs=2,
                           random_starts=False)
        obs = env.get_observations()
        # One car at the start; of the 3 bots the last starts L - 1.0 - 0.3235 m round, i.e.
        # 1.3235 m behind it (slot 0: gap -1.3235 / 5 = -0.2647), the first 2.0 m ahead
        # (slot 1: 2.0 / 5 = 0.4). The critic adds nothing for bots.
        assert obs["policy"][:, 19].tolist() == [1.0, 1.0]
        assert obs["policy"][:, 20].tolist() == pytest.approx([-0.2647] * 2, abs=1e-6)
        assert obs["policy"][:, 23].tolist() == [1.0, 1.0]
        assert obs["policy"][:, 24].tolist() == pytest.approx([0.4] * 2, abs=1e-6)
        assert obs["critic"].shape == (2, 33)
        env.step(torch.zeros(2, 2))
        assert env.core.bot_clock.tolist() == pytest.approx([1.0 / 15.0] * 2)

    def test_opponent_required_when_some_cars_are_not_learners(self) -> None:
        with pytest.raises(ValueError, match="opponent"):
            RacingVecEnv(training_config(), num_envs=2, learners=1)

    def test_expert_group_is_the_scripted_drivers_action_for_each_learner(self) -> None:
        from h2h_racing.policies import make_driver

        env = RacingVecEnv(training_config(num_cars=3), num_envs=4, learners=2,
                           opponent="pure_pursuit", expert="racing_line")
        for _ in range(5):
            obs, *_ = env.step(torch.full((8, 2), 0.5))
        # Rows are (copy, learner car) in copy-major order: row 2 e + c is car c of copy e.
        reference = make_driver("racing_line")
        reference.reset(env.core)
        expected = np.stack([reference.act(env.core, car) for car in range(2)], axis=1)
        assert obs["expert"].shape == (8, 2)
        assert np.array_equal(obs["expert"].numpy(), expected.reshape(8, 2).astype(np.float32))
        assert "expert" not in RacingVecEnv(training_config(), num_envs=1).get_observations()

    def test_expert_follows_a_track_change(self) -> None:
        from h2h_racing.policies import make_driver
        from h2h_racing.track.io import load_track

        env = RacingVecEnv(training_config(num_cars=1), num_envs=3, expert="racing_line")
        env.set_track(load_track("kidney"))
        reference = make_driver("racing_line")
        reference.reset(env.core)
        assert env.expert.line is not None and env.expert._track is env.core.track
        assert np.array_equal(env.get_observations()["expert"].numpy(),
                              reference.act(env.core, 0).astype(np.float32))

    def test_camera_group_is_channel_first_float(self) -> None:
        cfg = training_config(camera=dataclasses.replace(EnvConfig().camera, width=32,
                                                         height=24))
        env = RacingVecEnv(cfg, num_envs=2, observations="camera")
        camera = env.get_observations()["camera"]
        assert camera.shape == (4, 1, 24, 32) and camera.dtype == torch.float32
        assert 0.0 <= float(camera.min()) and float(camera.max()) <= 1.0


class TestAutoReset:
    """Finished copies reset inside step(); terminations vs time-outs are reported exactly."""

    def test_time_limit_gives_done_and_time_out_for_every_row(self) -> None:
        # 10 steps of 1/15 s: the training time limit of 2/3 s ends the episode on step 10.
        rules = dataclasses.replace(RaceRules.preset("head_to_head", "training"),
                                    time_limit=10 / 15)
        env = RacingVecEnv(training_config(rules=rules), num_envs=3)
        gentle = torch.tensor([[0.0, -1.0]]).repeat(6, 1)
        for step in range(1, 10):
            _, _, dones, extras = env.step(gentle)
            assert not dones.any(), f"[{step}]"
        obs, _, dones, extras = env.step(gentle)
        assert dones.all() and extras["time_outs"].all()
        # The returned observations are the next episode's first: every copy is back at step 0.
        assert np.all(env.core.steps == 0) and torch.all(env.episode_length_buf == 0)
        assert torch.equal(obs["policy"], env.get_observations()["policy"])
        assert "lap_completion" in extras["log"]

    def test_a_retired_learner_terminates_and_its_copy_mate_times_out(self) -> None:
        env = RacingVecEnv(training_config(), num_envs=1)
        # car_0 steers hard left at top speed and leaves the track (an infraction ends its
        # episode under training rules); car_1 drives gently. Rows are (copy 0: car_0, car_1).
        actions = torch.tensor([[1.0, 1.0], [0.0, -1.0]])
        for _ in range(200):
            _, _, dones, extras = env.step(actions)
            if dones.any():
                break
        else:
            pytest.fail("car_0 never left the track")
        assert dones.tolist() == [1, 1]
        # car_0 terminated (a true terminal); car_1's episode was only cut short.
        assert extras["time_outs"].tolist() == [0.0, 1.0]

    def test_copies_reset_independently(self) -> None:
        env = RacingVecEnv(training_config(num_cars=1), num_envs=2)
        actions = torch.tensor([[1.0, 1.0], [0.0, -1.0]])  # copy 0 crashes out, copy 1 cruises
        for _ in range(200):
            _, _, dones, _ = env.step(actions)
            if dones[0]:
                break
        assert dones.tolist() == [1, 0]
        assert env.core.steps[0] == 0 and env.core.steps[1] > 0


class TestTraining:
    """rsl-rl's OnPolicyRunner trains on the adapter, reproducibly under a seed."""

    @staticmethod
    def _train(seed: int, iterations: int, observations: str = "state") -> torch.nn.Module:
        from rsl_rl.runners import OnPolicyRunner

        torch.manual_seed(seed)
        cfg = training_config(num_cars=1, race_type="time_trial",
                              rules=RaceRules.preset("time_trial", "training"),
                              camera=dataclasses.replace(EnvConfig().camera, width=32, height=24))
        env = RacingVecEnv(cfg, num_envs=8, seed=seed, observations=observations)
        train = copy.deepcopy(TRAIN_CFG)
        if observations == "camera":
            train["obs_groups"] = {"actor": ["policy", "camera"], "critic": ["critic", "camera"]}
            for model in ("actor", "critic"):
                train[model]["class_name"] = "CNNModel"
                train[model]["cnn_cfg"] = {"output_channels": [4], "kernel_size": [3],
                                           "stride": [2], "global_pool": "avg"}
        runner = OnPolicyRunner(env, train, log_dir=None, device="cpu")
        runner.learn(iterations)
        return runner.alg.actor

    def test_two_iterations_with_state_observations(self) -> None:
        actor = self._train(seed=0, iterations=2)
        assert all(torch.isfinite(p).all() for p in actor.parameters())

    def test_two_iterations_with_camera_observations(self) -> None:
        actor = self._train(seed=0, iterations=2, observations="camera")
        assert all(torch.isfinite(p).all() for p in actor.parameters())

    def test_same_seed_same_parameters_and_different_seed_diverges(self) -> None:
        a = self._train(seed=1, iterations=3)
        b = self._train(seed=1, iterations=3)
        c = self._train(seed=2, iterations=3)
        pa, pb, pc = (torch.cat([p.detach().flatten() for p in m.parameters()]) for m in (a, b, c))
        assert torch.equal(pa, pb)
        assert not torch.equal(pa, pc)


class TestDeepRacerInputs:
    """DeepRacer reward files, discrete action lists and simtrace logs in the VecEnv."""

    def test_reward_file_state_is_per_row(self, tmp_path) -> None:
        # Each call returns how often this module instance was called: with one instance per
        # row, every row gets 1, 2, 3 on steps 1, 2, 3; one shared instance would give the
        # two rows different, larger counts (1 and 2, then 3 and 4, ...).
        reward = tmp_path / "count.py"
        reward.write_text("calls = 0\n\ndef reward_function(params):\n    global calls\n"
                          "    calls += 1\n    return calls\n")
        env = RacingVecEnv(training_config(num_cars=1, race_type="time_trial",
                                           rules=RaceRules.preset("time_trial", "training")),
                           num_envs=2, reward_function=str(reward))
        for step in (1, 2, 3):
            _, rewards, dones, _ = env.step(torch.tensor([[0.0, -1.0], [0.0, -1.0]]))
            assert not dones.any()
            assert rewards.tolist() == [float(step), float(step)]

    def test_bad_reward_names_file_car_and_step(self, tmp_path) -> None:
        from h2h_racing.deepracer import RewardFunctionError

        reward = tmp_path / "nan_at_3.py"
        reward.write_text("def reward_function(params):\n"
                          "    return float('nan') if params['steps'] == 3 else 1.0\n")
        env = RacingVecEnv(training_config(num_cars=1, race_type="time_trial",
                                           rules=RaceRules.preset("time_trial", "training")),
                           num_envs=2, reward_function=str(reward))
        env.step(torch.zeros(2, 2))
        env.step(torch.zeros(2, 2))
        with pytest.raises(RewardFunctionError, match=r"nan_at_3\.py returned nan") as err:
            env.step(torch.zeros(2, 2))
        assert "car_0 of env copy 0" in str(err.value) and "step 3.0" in str(err.value)

    def test_discrete_actions_take_the_nearest_of_the_list(self) -> None:
        from h2h_racing.deepracer.metadata import nearest_discrete

        # Steering -30..30 deg and speeds 1..3 m/s span [-1, 1]^2: (-30, 1) -> (-1, -1),
        # (0, 2) -> (0, 0), (30, 3) -> (1, 1).
        config = EnvConfig(action_type="discrete",
                           discrete_actions=((-30.0, 1.0), (0.0, 2.0), (30.0, 3.0)))
        actions = np.array([[-0.9, -0.8], [0.1, 0.2], [0.6, 0.7], [5.0, 5.0]])
        # (0.6, 0.7): to (0, 0) 0.36 + 0.49 = 0.85, to (1, 1) 0.16 + 0.09 = 0.25 -> 2;
        # (5, 5) is clipped to (1, 1) -> 2.
        assert nearest_discrete(config, actions).tolist() == [0, 1, 2, 2]
        env = RacingVecEnv(dataclasses.replace(
            config, track="oval", num_cars=1, race_type="time_trial",
            rules=RaceRules.preset("time_trial", "training")), num_envs=2)
        env.step(torch.tensor([[-1.0, -1.0], [1.0, 1.0]]))
        core = env.core
        assert np.degrees(core.steer_command[:, 0]).tolist() == pytest.approx([-30.0, 30.0])
        assert core.speed_command[:, 0].tolist() == [1.0, 3.0]

    def test_simtrace_logs_chosen_copies_as_workers(self, tmp_path) -> None:
        env = RacingVecEnv(training_config(), num_envs=4, simtrace=str(tmp_path),
                           simtrace_envs=2)
        for _ in range(5):
            env.step(torch.zeros(8, 2))
        env.close()
        for car in ("car_0", "car_1"):
            for worker in ("0", "1"):
                trace = tmp_path / car / worker / "training-simtrace" / "0-iteration.csv"
                lines = trace.read_text().splitlines()
                # Header, the prepare row and 5 steps (an episode on the oval lasts longer).
                assert len(lines) == 7 and lines[1].split(",")[15] == "prepare"
            assert not (tmp_path / car / "2").exists()
