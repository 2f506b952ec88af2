"""Camera-only observations and distilling a state policy into a camera policy."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import torch
from tensordict import TensorDict

import h2h_racing
from h2h_racing.config.env import CameraConfig
from h2h_racing.training.config import DistillConfig, TrainConfig
from h2h_racing.training.imitation import ImitationConfig
from h2h_racing.training.policy_file import policy_payload
from h2h_racing.training.train import train
from h2h_racing.training.vec_env import RacingVecEnv
from h2h_racing.policies.trained import TrainedPolicy
from h2h_racing.sensors.state import state_observation

# Small camera images keep the CNN cheap: 32 x 24 -> 4 x 3 x 16 after three stride-2 layers.
TEACHER_CONFIG = TrainConfig(track="oval", num_envs=8, num_steps_per_env=8, hidden_dims=(16, 16))
STUDENT_CONFIG = dataclasses.replace(TEACHER_CONFIG, observations="camera_only",
                                     camera_size=(32, 24))


@pytest.fixture(scope="module")
def teacher(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("teacher")
    train(TEACHER_CONFIG, iterations=1, out=out)
    return out / "policy.pt"


class TestCameraOnlyObservations:
    """observations="camera_only": the camera and the car's own speed and steering."""

    def test_motion_group_is_own_speed_and_steering_of_the_state_vector(self) -> None:
        env = RacingVecEnv(STUDENT_CONFIG.env_config(), num_envs=3, observations="camera_only")
        for _ in range(6):
            obs, *_ = env.step(torch.tensor([[0.8, 0.5]] * 3))
        motion = obs["motion"].numpy()
        state = state_observation(env.core)[:, 0]
        # Features 0 (forward speed / max speed) and 3 (steering angle / max steer).
        assert motion.shape == (3, 2)
        assert np.array_equal(motion, state[:, [0, 3]])
        # Six steps of steer +0.8 and throttle: turning left and moving.
        assert (motion[:, 0] > 0).all() and (motion[:, 1] > 0).all()
        assert obs["camera"].shape == (3, 1, 24, 32)

    def test_actor_reads_only_camera_and_motion(self) -> None:
        cfg = STUDENT_CONFIG.rsl_rl_dict()
        assert cfg["obs_groups"]["actor"] == ["camera", "motion"]
        assert cfg["actor"]["class_name"] == "CNNModel"
        # Its critic reads the privileged state only (an MLP: no CNN to update twice).
        assert cfg["obs_groups"]["critic"] == ["critic"]
        assert cfg["critic"]["class_name"] == "MLPModel"

    def test_ppo_runs_on_camera_only(self) -> None:
        runner = train(STUDENT_CONFIG, iterations=1)
        assert runner.current_learning_iteration == 1


@pytest.fixture(scope="module")
def distilled(teacher: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    out = tmp_path_factory.mktemp("student")
    config = dataclasses.replace(STUDENT_CONFIG, imitation=ImitationConfig(teacher=str(teacher)),
                                 distill=DistillConfig(gradient_length=4))
    runner = train(config, iterations=2, out=out)
    return out / "policy.pt", runner


class TestDistillation:
    """[imitation] teacher: rsl-rl's Distillation regresses the student onto the teacher."""

    def test_teacher_is_the_policy_file(self, teacher: Path,
                                        distilled: tuple[Path, object]) -> None:
        saved = torch.load(teacher, weights_only=True)["actor_state_dict"]
        loaded = distilled[1].alg.teacher.state_dict()  # type: ignore[attr-defined]
        assert saved.keys() == loaded.keys()
        assert all(torch.equal(saved[k], loaded[k]) for k in saved)

    def test_teacher_actions_are_clipped_to_the_action_range(
            self, distilled: tuple[Path, object]) -> None:
        from rsl_rl.models import MLPModel

        from h2h_racing.training.teachers import ClippedTeacher

        runner = distilled[1]
        obs = runner.env.get_observations()  # type: ignore[attr-defined]
        cfg = {k: v for k, v in runner.cfg["teacher"].items() if k != "class_name"}
        # The teacher's weights with the output layer scaled 100x, so that raw means leave
        # [-1, 1], in the teacher's class and in a plain MLPModel (the raw Gaussian means).
        state = {k: v.clone() for k, v in runner.alg.teacher.state_dict().items()}
        last = max(k for k in state if k.startswith("mlp.") and k.endswith(".weight"))
        state[last] *= 100.0
        clipped = ClippedTeacher(obs, {"teacher": ["policy"]}, "teacher", 2, **cfg)
        raw = MLPModel(obs, {"teacher": ["policy"]}, "teacher", 2, **cfg)
        for model in (clipped, raw):
            model.load_state_dict(state)
            model.eval()
        with torch.inference_mode():
            actions, means = clipped(obs), raw(obs)
        assert float(means.abs().max()) > 1.0
        assert torch.equal(actions, means.clamp(-1.0, 1.0))
        assert isinstance(runner.alg.teacher, ClippedTeacher)

    def test_pace_scales_the_commanded_speed_of_the_labels(
            self, distilled: tuple[Path, object]) -> None:
        from h2h_racing.training.teachers import ClippedTeacher

        runner = distilled[1]
        obs = runner.env.get_observations()  # type: ignore[attr-defined]
        cfg = {k: v for k, v in runner.cfg["teacher"].items() if k != "class_name"}
        assert "pace" not in cfg
        env = STUDENT_CONFIG.env_config()
        speed_mid, speed_half = env.action_affine[2:]
        # The labels of 0.9 of the teacher's speed command 0.9 x its speed in m/s, through the
        # env's own action map (EnvConfig.commands), and steer as the teacher does.
        slow = ClippedTeacher(obs, {"teacher": ["policy"]}, "teacher", 2, **cfg, pace=0.9,
                              speed_mid=speed_mid, speed_half=speed_half)
        slow.load_state_dict(runner.alg.teacher.state_dict())
        slow.eval()
        with torch.inference_mode():
            own, labels = runner.alg.teacher(obs), slow(obs)
        own_steer, own_speed = env.commands(own.numpy())
        steer, speed = env.commands(labels.numpy())
        assert np.allclose(speed, 0.9 * own_speed, atol=1e-5) and np.array_equal(steer, own_steer)
        # Every label is below the teacher's: 0.9 x speed < speed for speeds above 0.
        assert (speed < own_speed).all()
        # A run's pace reaches its teacher with the env's speed map: 0.5-4 m/s is 2.25 +- 1.75.
        paced = dataclasses.replace(STUDENT_CONFIG, imitation=ImitationConfig(
            teacher="ppo_generalist", pace=0.9))
        teacher = paced.rsl_rl_dict(teacher={"actor_cfg": {}})["teacher"]
        assert (teacher["pace"], teacher["speed_mid"], teacher["speed_half"]) == (0.9, 2.25, 1.75)
        with pytest.raises(ValueError, match=r"pace must be a number in \[0.5, 1\]"):
            ImitationConfig(teacher="ppo_generalist", pace=1.2)

    def test_student_file_is_a_camera_only_policy(self, distilled: tuple[Path, object]) -> None:
        payload = torch.load(distilled[0], weights_only=True)
        assert payload["observations"] == "camera_only"
        assert payload["obs_groups"] == ["camera", "motion"]
        assert payload["train_config"]["imitation"]["teacher"].endswith("policy.pt")
        # The student drives with the small fixed noise of DistillConfig.student_std.
        assert payload["actor_cfg"]["distribution_cfg"]["init_std"] == 0.1

    def test_reloaded_student_acts_like_the_trained_student(
            self, distilled: tuple[Path, object]) -> None:
        path, runner = distilled
        env = h2h_racing.parallel_env(track="oval", num_cars=1, race_type="time_trial",
                                      camera=CameraConfig(width=32, height=24))
        env.reset(seed=3)
        for _ in range(8):
            env.step({"car_0": np.array([0.2, 0.6], np.float32)})
        policy = TrainedPolicy(path)
        policy.reset(env.core)
        groups = policy._observe(env.core, 0)
        student = runner.alg.get_policy()  # type: ignore[attr-defined]
        student.eval()
        with torch.inference_mode():
            expected = student(TensorDict({k: torch.from_numpy(v) for k, v in groups.items()},
                                          batch_size=[1])).numpy()
        assert np.array_equal(policy.act(env.core, 0), np.clip(expected, -1, 1))

    def test_camera_policy_drives_in_an_env_with_another_camera(
            self, distilled: tuple[Path, object]) -> None:
        # The default env camera is 160 x 120; the policy renders its own 32 x 24 images.
        env = h2h_racing.parallel_env(track="oval", num_cars=1, race_type="time_trial")
        env.reset(seed=0)
        policy = TrainedPolicy(distilled[0])
        policy.reset(env.core)
        assert policy._observe(env.core, 0)["camera"].shape == (1, 1, 24, 32)
        assert policy.act(env.core, 0).shape == (1, 2)

    def test_student_learns_the_teachers_actions(self, teacher: Path) -> None:
        # A student given the state vector as well ("camera") can copy the teacher exactly, so
        # its imitation error must fall: compare the mean squared action error against the
        # teacher, untrained and after 16 iterations, on the states the trained student drives
        # into (the distribution distillation trains on).
        config = dataclasses.replace(STUDENT_CONFIG, observations="camera",
                                     imitation=ImitationConfig(teacher=str(teacher)),
                                     distill=DistillConfig(learning_rate=3e-3))
        untrained = train(config, iterations=0)
        trained = train(config, iterations=16)
        obs = trained.env.get_observations()

        def error(runner: object) -> float:
            alg = runner.alg  # type: ignore[attr-defined]
            alg.eval_mode()
            with torch.inference_mode():
                return float(((alg.get_policy()(obs) - trained.alg.teacher(obs)) ** 2).mean())

        assert error(trained) < 0.5 * error(untrained)


class TestScriptedTeacher:
    """A scripted driver as the teacher: the student imitates it through the expert group."""

    CONFIG = dataclasses.replace(TEACHER_CONFIG, imitation=ImitationConfig(teacher="racing_line"),
                                 distill=DistillConfig(learning_rate=3e-3))

    def test_state_student_of_a_scripted_teacher_is_allowed(self) -> None:
        assert self.CONFIG.scripted_teacher
        cfg = self.CONFIG.rsl_rl_dict()
        assert cfg["obs_groups"] == {"student": ["policy"], "teacher": ["expert"]}
        assert cfg["teacher"] == {"class_name": "h2h_racing.training.teachers:ScriptedTeacher"}

    def test_teacher_returns_the_expert_group(self) -> None:
        from h2h_racing.training.teachers import ScriptedTeacher

        runner = train(self.CONFIG, iterations=1)
        assert isinstance(runner.alg.teacher, ScriptedTeacher)
        obs = runner.env.get_observations()
        assert torch.equal(runner.alg.teacher(obs), obs["expert"])

    def test_options_make_the_expert(self) -> None:
        config = dataclasses.replace(self.CONFIG, imitation=ImitationConfig(
            teacher="racing_line", options={"margin": 0.2, "grip_factor": 0.6}))
        expert = config.make_env().expert
        assert (expert.margin, expert.grip_factor) == (0.2, 0.6)
        with pytest.raises(ValueError, match="do not fit the 'racing_line' driver"):
            ImitationConfig(teacher="racing_line", options={"grip": 0.6})
        with pytest.raises(ValueError, match="grip_factor must be in"):
            ImitationConfig(teacher="racing_line", options={"grip_factor": 1.5})
        with pytest.raises(ValueError, match="are arguments of a scripted teacher"):
            ImitationConfig(teacher="ppo_generalist", options={"margin": 0.2})

    def test_teacher_refuses_other_groups(self) -> None:
        from h2h_racing.training.teachers import ScriptedTeacher

        obs = TensorDict({"policy": torch.zeros(2, 3)}, batch_size=[2])
        with pytest.raises(ValueError, match="reads the env's 'expert' observation group"):
            ScriptedTeacher(obs, {"teacher": ["policy"]}, "teacher", 2)

    def test_student_learns_the_drivers_actions(self) -> None:
        # As for a policy teacher: the mean squared error of the student's actions against the
        # racing line's, on the states the trained student drives into, must fall to under
        # half of the untrained student's.
        untrained = train(self.CONFIG, iterations=0)
        trained = train(self.CONFIG, iterations=16)
        obs = trained.env.get_observations()

        def error(runner: object) -> float:
            policy = runner.alg.get_policy()  # type: ignore[attr-defined]
            policy.eval()
            with torch.inference_mode():
                return float(((policy(obs) - obs["expert"]) ** 2).mean())

        assert error(trained) < 0.5 * error(untrained)


class TestTeacherChecks:
    """A teacher that cannot teach is a clear error before any training."""

    def test_state_student_refused(self, teacher: Path) -> None:
        with pytest.raises(ValueError, match="set observations to 'camera_only'.*or imitate "
                                             "a scripted driver \\(racing_line"):
            TrainConfig(imitation=ImitationConfig(teacher=str(teacher)))

    def test_missing_teacher(self, tmp_path: Path) -> None:
        config = dataclasses.replace(STUDENT_CONFIG,
                                     imitation=ImitationConfig(teacher=str(tmp_path / "nope.pt")))
        with pytest.raises(FileNotFoundError, match="neither a shipped policy"):
            config.rsl_rl_dict()

    def test_camera_teacher_refused(self, tmp_path: Path) -> None:
        runner = train(STUDENT_CONFIG, iterations=0)
        path = tmp_path / "camera.pt"
        torch.save(policy_payload(runner, STUDENT_CONFIG), path)
        config = dataclasses.replace(STUDENT_CONFIG, imitation=ImitationConfig(teacher=str(path)))
        with pytest.raises(ValueError, match="must be a state-observation policy"):
            config.rsl_rl_dict()

    def test_teacher_with_other_slots_refused(self, tmp_path: Path) -> None:
        runner = train(TEACHER_CONFIG, iterations=0)
        payload = policy_payload(runner, TEACHER_CONFIG)
        payload["env_config"]["opponent_slots"] = 3
        path = tmp_path / "slots.pt"
        torch.save(payload, path)
        config = dataclasses.replace(STUDENT_CONFIG, imitation=ImitationConfig(teacher=str(path)))
        with pytest.raises(ValueError, match="opponent_slots=3, this run's env has "
                                             "opponent_slots=2"):
            config.rsl_rl_dict()

    def test_bad_distill_values(self) -> None:
        with pytest.raises(ValueError, match="DistillConfig.gradient_length must be"):
            DistillConfig(gradient_length=0)
        with pytest.raises(ValueError, match="DistillConfig.num_learning_epochs must be an int"):
            DistillConfig(num_learning_epochs=1.5)
