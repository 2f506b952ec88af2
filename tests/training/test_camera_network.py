"""The camera network in the config (``TrainConfig.camera_channels``, ``camera_size``,
``channels_last``): what the actor is built with, and that a trained camera policy loads back
and drives with its own network and image size wherever policies are loaded."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import torch
from tensordict import TensorDict

import h2h_racing
from h2h_racing.policies import make_driver
from h2h_racing.policies.trained import TrainedPolicy, load_policy_payload
from h2h_racing.training.camera_network import cnn_config
from h2h_racing.training.config import TrainConfig
from h2h_racing.training.policy_file import policy_payload
from h2h_racing.training.train import make_runner, train

# Two layers of 4 and 8 channels on a 24 x 16 image: 6 x 4 x 8 = 192 features.
SMALL = TrainConfig(track="oval", num_envs=4, num_steps_per_env=4, hidden_dims=(8, 8),
                    observations="camera_only", camera_size=(24, 16), camera_channels=(4, 8),
                    eval_every=0)
RECIPES = Path(__file__).resolve().parents[2] / "experiments" / "camera"


def _convs(model: torch.nn.Module) -> list[torch.nn.Conv2d]:
    return [m for m in model.modules() if isinstance(m, torch.nn.Conv2d)]


def _env_after_a_few_steps() -> object:
    env = h2h_racing.parallel_env(track="oval", num_cars=1, race_type="time_trial")
    env.reset(seed=3)
    for _ in range(6):
        env.step({"car_0": np.array([0.2, 0.6], np.float32)})
    return env


class TestConfig:
    def test_default_network_is_the_one_camera_speedway_was_trained_with(self) -> None:
        shipped = load_policy_payload("camera_speedway")["actor_cfg"]["cnn_cfg"]
        assert TrainConfig().camera_channels == (16, 32, 16)
        assert cnn_config((16, 32, 16)) == shipped == {
            "output_channels": [16, 32, 16], "kernel_size": [5, 3, 3], "stride": [2, 2, 2],
            "padding": "zeros"}

    def test_channels_choose_the_layers_of_actor_and_critic(self) -> None:
        config = dataclasses.replace(SMALL, observations="camera", camera_channels=(8, 16, 8))
        cfg = config.rsl_rl_dict()
        for model in ("actor", "critic"):
            assert cfg[model]["cnn_cfg"]["output_channels"] == [8, 16, 8]
            assert cfg[model]["cnn_cfg"]["kernel_size"] == [5, 3, 3]
        four = dataclasses.replace(SMALL, camera_channels=(4, 4, 4, 4)).actor_dict()
        assert four["cnn_cfg"]["kernel_size"] == [5, 3, 3, 3]
        assert four["cnn_cfg"]["stride"] == [2, 2, 2, 2]

    @pytest.mark.parametrize("channels", [(), (0, 8), (8, -1), (4, 4, 4, 4, 4), (8.0, 16),
                                          (True, 8), "16"])
    def test_bad_channels_rejected(self, channels: object) -> None:
        with pytest.raises(ValueError, match="camera_channels must be 1 to 4 channel counts"):
            TrainConfig(camera_channels=channels)  # type: ignore[arg-type]

    @pytest.mark.parametrize("size", [(64,), (0, 48), (64, 48, 1), (64.0, 48)])
    def test_bad_image_size_rejected(self, size: object) -> None:
        with pytest.raises(ValueError, match="camera_size must be .width, height."):
            TrainConfig(camera_size=size)  # type: ignore[arg-type]

    def test_settable_from_toml(self, tmp_path: Path) -> None:
        path = tmp_path / "train.toml"
        path.write_text('observations = "camera_only"\ncamera_size = [32, 24]\n'
                        'camera_channels = [8, 16, 8]\nchannels_last = true\n')
        config = TrainConfig.from_toml(path)
        assert config.camera_size == (32, 24) and config.camera_channels == (8, 16, 8)
        assert config.channels_last is True
        assert config.env_config().camera.width == 32
        path.write_text("camera_channels = 8\n")
        with pytest.raises(ValueError, match="camera_channels"):
            TrainConfig.from_toml(path)

    def test_the_recipe_files_read(self) -> None:
        distill = TrainConfig.from_toml(RECIPES / "distill.toml")
        finetune = TrainConfig.from_toml(RECIPES / "ppo.toml")
        assert distill.imitation.teacher == "ppo_generalist"
        assert distill.observations == finetune.observations == "camera_only"
        # The fine-tune starts from the distilled student: the same image and network.
        for name in ("camera_size", "camera_channels", "hidden_dims"):
            assert getattr(distill, name) == getattr(finetune, name)


@pytest.fixture(scope="module")
def small_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    out = tmp_path_factory.mktemp("camera")
    runner = train(SMALL, iterations=1, out=out)
    return out / "policy.pt", runner


class TestLoading:
    def test_policy_file_rebuilds_its_network_and_image(
            self, small_run: tuple[Path, object]) -> None:
        path, runner = small_run
        env = _env_after_a_few_steps()  # the env's own camera is 160 x 120
        for driver in (TrainedPolicy(path), make_driver(str(path))):
            driver.reset(env.core)  # type: ignore[attr-defined]
            assert [c.out_channels for c in _convs(driver._actor)] == [4, 8]
            groups = driver._observe(env.core, 0)  # type: ignore[attr-defined]
            assert groups["camera"].shape == (1, 1, 16, 24)
            student = runner.alg.get_policy()  # type: ignore[attr-defined]
            student.eval()
            with torch.inference_mode():
                expected = student(TensorDict({k: torch.from_numpy(v) for k, v in
                                               groups.items()}, batch_size=[1])).numpy()
            assert np.array_equal(driver.act(env.core, 0), np.clip(expected, -1, 1))

    def test_camera_speedway_loads_and_drives_unchanged(self) -> None:
        driver = make_driver("camera_speedway")
        env = _env_after_a_few_steps()
        driver.reset(env.core)
        assert [c.out_channels for c in _convs(driver._actor)] == [16, 32, 16]
        assert driver._observe(env.core, 0)["camera"].shape == (1, 1, 48, 64)
        action = driver.act(env.core, 0)
        assert action.shape == (1, 2) and np.isfinite(action).all()


class TestChannelsLast:
    def test_weights_are_channels_last_and_still_learn(self) -> None:
        from h2h_racing.training.imitation import ImitationConfig

        config = dataclasses.replace(SMALL, channels_last=True,
                                     imitation=ImitationConfig(teacher="racing_line"))
        runner = make_runner(config, config.make_env())
        convs = _convs(runner.alg.get_policy())
        assert all(c.weight.is_contiguous(memory_format=torch.channels_last) for c in convs)
        # With one input channel both layouts are the same memory; the second layer's differ.
        assert not convs[1].weight.is_contiguous()
        before = [c.weight.detach().clone() for c in convs]
        runner.learn(1)
        # The optimizer updates the converted weights (the parameters kept their identity).
        assert all(not torch.equal(b, c.weight) for b, c in zip(before, convs))

    def test_policy_file_holds_default_layout_and_drives_the_same(self) -> None:
        config = dataclasses.replace(SMALL, channels_last=True)
        runner = train(config, iterations=1)
        payload = policy_payload(runner, config)
        weights = [v for v in payload["actor_state_dict"].values() if v.dim() == 4]
        assert weights and all(w.is_contiguous() for w in weights)
        driver = TrainedPolicy.from_payload(payload, name="cl")
        env = _env_after_a_few_steps()
        driver.reset(env.core)
        groups = driver._observe(env.core, 0)
        student = runner.alg.get_policy()
        student.eval()
        with torch.inference_mode():
            expected = student(TensorDict({k: torch.from_numpy(v) for k, v in groups.items()},
                                          batch_size=[1])).numpy()
        # Same weights; the two layouts may sum in another order (float rounding).
        assert np.allclose(driver.act(env.core, 0), np.clip(expected, -1, 1), atol=1e-5)


class TestFrames:
    """``camera_frames``: the camera's ``frame_stack``, oldest frame first, in training and in
    the trained driver."""

    @pytest.mark.parametrize("frames", [0, 33, 2.0, True, "3"])
    def test_bad_counts_rejected(self, frames: object) -> None:
        with pytest.raises(ValueError, match=r"camera_frames must be an int in \[1, 32\]"):
            TrainConfig(camera_frames=frames)  # type: ignore[arg-type]

    def test_training_observation_is_the_last_frames_oldest_first(self) -> None:
        config = dataclasses.replace(SMALL, camera_frames=3)
        assert config.env_config().camera.frame_stack == 3
        env = config.make_env()
        first = env.get_observations()["camera"]
        assert first.shape == (4, 3, 16, 24)
        # A new episode repeats its first frame in every slot.
        assert torch.equal(first[:, 0], first[:, 2]) and torch.equal(first[:, 1], first[:, 2])
        drive = torch.tensor([[0.0, 1.0]]).repeat(4, 1)
        second = env.step(drive)[0]["camera"]
        third = env.step(drive)[0]["camera"]
        # Each step shifts the history by one: the newest frame becomes the middle one, ...
        assert torch.equal(third[:, 1], second[:, 2]) and torch.equal(third[:, 0], second[:, 1])
        # ... and the car moved, so the newest frame is a new image.
        assert not torch.equal(third[:, 2], second[:, 2])

    def test_trained_driver_stacks_its_own_frames(self) -> None:
        config = dataclasses.replace(SMALL, camera_frames=2)
        runner = train(config, iterations=1)
        driver = TrainedPolicy.from_payload(policy_payload(runner, config), name="frames")
        env = h2h_racing.parallel_env(track="oval", num_cars=1, race_type="time_trial")
        env.reset(seed=3)
        driver.reset(env.core)
        before = driver._observe(env.core, 0)["camera"]
        assert before.shape == (1, 2, 16, 24) and np.array_equal(before[:, 0], before[:, 1])
        action = driver.act(env.core, 0)
        assert np.isfinite(action).all()
        previous = before
        for _ in range(3):
            env.step({"car_0": np.array([0.0, 1.0], np.float32)})
            now = driver._observe(env.core, 0)["camera"]
            # The older slot holds the frame the driver saw one step before.
            assert np.array_equal(now[:, 0], previous[:, 1])
            assert not np.array_equal(now[:, 0], now[:, 1])
            previous = now


class TestStereo:
    """``camera_stereo``: DeepRacer's two cameras, a channel each, in training and driving."""

    def test_bad_value_rejected(self) -> None:
        with pytest.raises(ValueError, match="camera_stereo must be true or false"):
            TrainConfig(camera_stereo=1)  # type: ignore[arg-type]

    def test_two_views_a_baseline_apart(self) -> None:
        config = dataclasses.replace(SMALL, camera_stereo=True, camera_frames=2)
        assert config.env_config().camera.stereo
        frames = config.make_env().get_observations()["camera"]
        # Two frames of two cameras, oldest first: (left, right, left, right).
        assert frames.shape == (4, 4, 16, 24)
        assert torch.equal(frames[:, 0], frames[:, 2]) and torch.equal(frames[:, 1], frames[:, 3])
        # The cameras stand 6 cm apart: their images differ.
        assert not torch.equal(frames[:, 0], frames[:, 1])

    def test_trained_driver_sees_both(self) -> None:
        config = dataclasses.replace(SMALL, camera_stereo=True)
        runner = train(config, iterations=1)
        driver = TrainedPolicy.from_payload(policy_payload(runner, config), name="stereo")
        env = _env_after_a_few_steps()
        driver.reset(env.core)
        assert driver._observe(env.core, 0)["camera"].shape == (1, 2, 16, 24)
        assert np.isfinite(driver.act(env.core, 0)).all()


class TestFieldOfView:
    """``camera_hfov``: the camera's horizontal field of view, in training and driving."""

    @pytest.mark.parametrize("hfov", [0.5, 171.0, True, "120"])
    def test_bad_values_rejected(self, hfov: object) -> None:
        with pytest.raises(ValueError, match=r"camera_hfov must be a number in \[1, 170\]"):
            TrainConfig(camera_hfov=hfov)  # type: ignore[arg-type]

    def test_default_is_deepracers_simulated_camera(self) -> None:
        assert TrainConfig().env_config().camera.hfov_deg == 64.7

    def test_trained_driver_renders_its_own_view(self) -> None:
        config = dataclasses.replace(SMALL, camera_hfov=120.0)
        runner = train(config, iterations=1)
        driver = TrainedPolicy.from_payload(policy_payload(runner, config), name="wide")
        env = _env_after_a_few_steps()
        driver.reset(env.core)
        # fx = (W / 2) / tan(hfov / 2) = 12 / tan(60 deg) = 6.928 px on a 24 px wide image.
        assert driver._camera.config.focal_px == pytest.approx(12.0 / 3.0 ** 0.5)
        narrow = TrainedPolicy.from_payload(policy_payload(train(SMALL, iterations=1), SMALL),
                                            name="narrow")
        narrow.reset(env.core)
        assert not np.array_equal(driver._observe(env.core, 0)["camera"],
                                  narrow._observe(env.core, 0)["camera"])
