"""observations="camera_lidar" (issue 21's ``camera_racer``): DeepRacer's head-to-head sensor
set, the camera and the lidar, plus the car's own speed and steering. The groups the VecEnv
gives, a lidar range worked by hand, a distillation from a state teacher, and the policy file
driving in races and exporting with its own camera and lidar."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
import torch
from tensordict import TensorDict

import h2h_racing
from h2h_racing.cli.command import build_parser
from h2h_racing.training.cli import _train_config
from h2h_racing.config.env import CameraConfig, EnvConfig, LidarConfig
from h2h_racing.match import run_race
from h2h_racing.policies.trained import TrainedPolicy
from h2h_racing.sensors.lidar import LidarSensor
from h2h_racing.sensors.state import MOTION_FEATURES, state_observation
from h2h_racing.training.config import DistillConfig, TrainConfig
from h2h_racing.training.imitation import ImitationConfig
from h2h_racing.training.train import train
from h2h_racing.training.vec_env import RacingVecEnv

# Two small convolutions on a 24 x 16 image keep the CNN cheap; one learner races
# pure_pursuit, so the lidar has a car to see.
STUDENT = TrainConfig(track="oval", num_cars=2, learners=1, opponent="pure_pursuit",
                      observations="camera_lidar", camera_size=(24, 16), camera_channels=(4, 8),
                      hidden_dims=(8, 8), num_envs=4, num_steps_per_env=4, eval_every=0)
EGO = (-2.0, 0.0)  # [m] the car on the oval's bottom straight, heading +x
RECIPE = Path(__file__).resolve().parents[2] / "experiments" / "camera" / "distill.toml"


@pytest.fixture(scope="module")
def distilled(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    """Two iterations of distilling the shipped state policy league_racer into a camera_lidar
    student; its policy.pt and the runner."""
    out = tmp_path_factory.mktemp("camera_lidar")
    config = dataclasses.replace(STUDENT, imitation=ImitationConfig(teacher="league_racer"),
                                 distill=DistillConfig(gradient_length=4))
    runner = train(config, iterations=2, out=out)
    return out / "policy.pt", runner


class TestGroups:
    """The VecEnv's groups with observations="camera_lidar", and what the actor reads."""

    def test_shapes_and_dtypes(self) -> None:
        env = STUDENT.make_env()
        for _ in range(3):
            obs, *_ = env.step(torch.tensor([[0.3, 0.6]] * 4))
        assert obs["camera"].shape == (4, 1, 16, 24)
        assert obs["lidar"].shape == (4, 64)
        assert obs["motion"].shape == (4, 2)
        assert all(obs[g].dtype == torch.float32 for g in ("camera", "lidar", "motion"))
        # DeepRacer's lidar clips to [0.15, 1.0] m.
        assert float(obs["lidar"].min()) >= 0.15 and float(obs["lidar"].max()) <= 1.0
        state = state_observation(env.core)[:, 0]
        assert np.array_equal(obs["motion"].numpy(), state[:, list(MOTION_FEATURES)])

    def test_rows_are_each_learners_own_scan(self) -> None:
        # Self-play: row e * L + car is car `car` of copy `e`, as for every other group.
        config = dataclasses.replace(STUDENT, learners=None, opponent=None)
        env = config.make_env()
        core = env.core
        expected = LidarSensor(LidarConfig(), core.config.car,
                               (core.config.obstacle_length, core.config.obstacle_width)
                               ).observe(core)
        assert np.array_equal(env.get_observations()["lidar"].numpy(),
                              expected.reshape(4 * 2, 64))

    def test_actor_reads_camera_lidar_and_motion_only(self) -> None:
        cfg = STUDENT.rsl_rl_dict()
        assert cfg["obs_groups"]["actor"] == ["camera", "lidar", "motion"]
        assert cfg["actor"]["class_name"] == "CNNModel"
        # The critic reads the privileged state only, as a camera_only actor's.
        assert cfg["obs_groups"]["critic"] == ["critic"]
        assert cfg["critic"]["class_name"] == "MLPModel"

    def test_noise_leaves_the_race_unchanged(self) -> None:
        # The lidar's noise has its own generator: the same seed gives the same starts and
        # race with and without noise, only the ranges of beams that hit something differ.
        clean = RacingVecEnv(EnvConfig(track="oval", num_cars=2), num_envs=4,
                             observations="camera_lidar")
        noisy = RacingVecEnv(EnvConfig(track="oval", num_cars=2,
                                       lidar=LidarConfig(noise_std=0.01)), num_envs=4,
                             observations="camera_lidar")
        for _ in range(3):
            actions = torch.tensor([[0.2, 0.5]] * 8)
            a, *_ = clean.step(actions)
            b, *_ = noisy.step(actions)
        assert np.array_equal(clean.core.position, noisy.core.position)
        hits = a["lidar"] < 1.0
        assert hits.any() and torch.equal(a["lidar"][~hits], b["lidar"][~hits])
        assert not torch.equal(a["lidar"][hits], b["lidar"][hits])

    def test_other_modes_have_no_lidar(self) -> None:
        for observations in ("state", "camera", "camera_only"):
            config = dataclasses.replace(STUDENT, observations=observations, num_envs=1)
            assert "lidar" not in config.make_env().get_observations().keys()

    def test_unknown_mode_lists_camera_lidar(self) -> None:
        with pytest.raises(ValueError, match="'camera_only', 'camera_lidar'\\), got 'lidar'"):
            TrainConfig(observations="lidar")  # type: ignore[arg-type]


class TestLidarByHand:
    """A box at a known distance ahead of the learner, through the VecEnv's lidar group."""

    def test_box_ahead_and_to_the_left(self) -> None:
        config = EnvConfig(track="oval", num_cars=1, race_type="object_avoidance",
                           num_obstacles=1)
        env = RacingVecEnv(config, num_envs=2, observations="camera_lidar", random_starts=False)
        core = env.core
        core.position[:, 0] = EGO
        core.yaw[:, 0] = 0.0
        # Copy 0: the 0.5 x 0.4 m box square to the car, centred 1.0 m ahead and 0.2 m to the
        # left, so it spans 0 .. 0.4 m left of the car's axis; copy 1: the box far away.
        core.obstacle_position[0, 0] = (EGO[0] + 1.0, 0.2)
        core.obstacle_position[1, 0] = (50.0, 50.0)
        core.obstacle_yaw[:] = 0.0
        lidar = env._observe()["lidar"].numpy()
        # The box's rear face is 1.0 - 0.25 = 0.75 m ahead. Beam k points at
        # -150 + 4.762 k deg (counter-clockwise, to the left, positive) and meets that face
        # 0.75 tan(angle) left of the axis, a hit while that is in [0, 0.4] m: angles up to
        # atan(0.4 / 0.75) = 28.07 deg, beams 32 (2.381 deg) to 37 (26.190 deg).
        # Beam 32: 0.75 / cos(2.381 deg) = 0.75065 m; beam 37: 0.75 / cos(26.190 deg) =
        # 0.83581 m. Beam 31 (-2.381 deg) passes right of the box and beam 38 (30.952 deg)
        # crosses y = 0.4 m at x = 0.4 / tan(30.952 deg) = 0.667 m, short of it: both read
        # 1.0 m, max_range, as every beam of copy 1 does.
        assert lidar[0, 32] == pytest.approx(0.75065, abs=1e-4)
        assert lidar[0, 37] == pytest.approx(0.83581, abs=1e-4)
        assert np.flatnonzero(lidar[0] < 1.0).tolist() == [32, 33, 34, 35, 36, 37]
        assert (lidar[1] == 1.0).all()


class TestDistillation:
    """A camera_lidar student of the shipped state policy league_racer."""

    def test_the_cli_command_builds_this_run(self) -> None:
        # The command of the report: the fast camera recipe's image and CNN, with the lidar,
        # distilled from league_racer against a pool of scripted opponents.
        args = build_parser().parse_args([
            "train", "--config", str(RECIPE), "--obs", "camera_lidar", "--teacher",
            "league_racer", "--opponents", "pure_pursuit,racing_line", "--race-type",
            "head_to_head", "--out", "runs/camera_racer"])
        config = _train_config(args)
        assert config.observations == "camera_lidar"
        assert (config.camera_size, config.camera_channels) == ((32, 24), (8, 16, 8))
        assert config.channels_last and config.track == "procedural"
        assert config.opponents() == ["pure_pursuit", "racing_line"]
        assert (config.num_cars, config.learners) == (2, 1)
        cfg = config.rsl_rl_dict()  # loads league_racer and checks its state layout fits
        assert cfg["obs_groups"] == {"student": ["camera", "lidar", "motion"],
                                     "teacher": ["policy"]}
        assert cfg["teacher"]["class_name"] == "h2h_racing.training.teachers:ClippedTeacher"

    def test_two_iterations_train_the_student(self, distilled: tuple[Path, object]) -> None:
        path, runner = distilled
        assert runner.current_learning_iteration == 2  # type: ignore[attr-defined]
        payload = torch.load(path, weights_only=True)
        assert payload["observations"] == "camera_lidar"
        assert payload["obs_groups"] == ["camera", "lidar", "motion"]
        # The lidar settings it was trained with travel in the file, as the camera's do.
        assert payload["env_config"]["lidar"] == LidarConfig().to_dict()
        assert payload["env_config"]["camera"]["width"] == 24


class TestPolicyFile:
    """The saved camera_lidar policy drives with its own camera and lidar."""

    def test_reloaded_student_sees_and_acts_as_in_training(
            self, distilled: tuple[Path, object]) -> None:
        path, runner = distilled
        env = runner.env  # type: ignore[attr-defined]
        obs = env.get_observations()
        policy = TrainedPolicy(path)
        policy.reset(env.core)
        groups = policy._observe(env.core, 0)
        for group in ("camera", "lidar", "motion"):
            assert np.array_equal(groups[group], obs[group].numpy()), group
        student = runner.alg.get_policy()  # type: ignore[attr-defined]
        student.eval()
        with torch.inference_mode():
            expected = student(TensorDict({g: obs[g] for g in ("camera", "lidar", "motion")},
                                          batch_size=[4])).numpy()
        # Same weights and inputs; float32 convolutions may sum in another order (1e-8).
        np.testing.assert_allclose(policy.act(env.core, 0), np.clip(expected, -1, 1),
                                   atol=1e-6)

    def test_races_against_a_scripted_driver(self, distilled: tuple[Path, object]) -> None:
        result = run_race("oval", [str(distilled[0]), "racing_line"], laps=1, seed=0,
                          max_cycles=3)
        assert {row["agent"] for row in result.rows} == {"car_0", "car_1"}

    def test_its_lidar_sees_the_other_car(self, distilled: tuple[Path, object]) -> None:
        # Car 1 centred 1.0 m ahead of car 0: its rear face 1.0 - 0.3235 / 2 = 0.83825 m
        # ahead, beam 31 at 0.83825 / cos(2.381 deg) = 0.83897 m.
        env = h2h_racing.parallel_env(track="oval", num_cars=2)
        env.reset(seed=0)
        core = env.core
        core.position[0] = (EGO, (EGO[0] + 1.0, 0.0))
        core.yaw[0] = 0.0
        policy = TrainedPolicy(distilled[0])
        policy.reset(core)
        assert policy._observe(core, 0)["lidar"][0, 31] == pytest.approx(0.83897, abs=1e-4)

    def test_exports_to_onnx_with_the_lidar_in_obs(self, distilled: tuple[Path, object],
                                                   tmp_path: Path) -> None:
        onnxruntime = pytest.importorskip("onnxruntime")
        from h2h_racing.policies import make_driver
        from h2h_racing.training.export import export_policy

        result = export_policy(distilled[0], tmp_path, formats="onnx", samples=16)
        assert result.max_abs_diff["onnx"] <= 1e-5
        sidecar = json.loads((tmp_path / "policy.export.json").read_text())
        assert [i["name"] for i in sidecar["inputs"]] == ["obs", "camera"]
        # 64 lidar ranges then the 2 motion features, in the actor's group order.
        assert sidecar["inputs"][0]["shape"] == ["batch", 66]
        assert sidecar["inputs"][0]["meaning"].index("lidar") < sidecar["inputs"][0][
            "meaning"].index("motion")
        # Built from the env's own Dict observation, as the sidecar describes the inputs.
        camera = CameraConfig(**sidecar["env_config"]["camera"])
        env = h2h_racing.parallel_env(track="oval", num_cars=2,
                                      sensors=("camera", "lidar", "state"), camera=camera)
        env.reset(seed=5)
        core = env.core
        core.position[0, 1] = (core.position[0, 0, 0] + 0.9 * math.cos(core.yaw[0, 0]),
                               core.position[0, 0, 1] + 0.9 * math.sin(core.yaw[0, 0]))
        core.yaw[0, 1] = core.yaw[0, 0]
        obs = env._observations()  # the scan with car 1 moved 0.9 m ahead of car 0
        car = obs["car_0"]
        assert (car["lidar"] < 1.0).any()
        feeds = {"obs": np.concatenate([car["lidar"], car["state"][list(MOTION_FEATURES)]]
                                       )[None].astype(np.float32),
                 "camera": (car["camera"].transpose(2, 0, 1)[None] / 255.0).astype(np.float32)}
        driver = make_driver(str(distilled[0]))
        driver.reset(core)
        session = onnxruntime.InferenceSession(str(result.files["onnx"]),
                                               providers=["CPUExecutionProvider"])
        np.testing.assert_allclose(session.run(None, feeds)[0], driver.act(core, 0), atol=1e-5)
