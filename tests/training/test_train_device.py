"""``TrainConfig.device`` / ``h2h-racing train --device``: the learner on the named device, the
env on the CPU. CI has no GPU, so the CUDA path is checked with torch's CUDA check patched: the
device reaches the rsl-rl runner, the env stays on the CPU, and a missing GPU fails before any
work."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import torch

from h2h_racing.training import device as device_module
from h2h_racing.training.config import TrainConfig
from h2h_racing.training.train import train

TINY = TrainConfig(track="oval", num_envs=4, num_steps_per_env=4, hidden_dims=(8, 8),
                   eval_every=0)


@pytest.fixture
def no_gpu(monkeypatch: pytest.MonkeyPatch) -> None:
    """This machine as CI sees it, even where a GPU is present."""
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)


def test_default_is_cpu_and_names_are_checked(tmp_path: Path) -> None:
    assert TrainConfig().device == "cpu"
    for bad in ("gpu", "CUDA", "cuda:", "cuda:x", "mps", 0, None):
        with pytest.raises(ValueError, match="device must be 'cpu', 'cuda' or 'cuda:<index>'"):
            TrainConfig(device=bad)  # type: ignore[arg-type]
    path = tmp_path / "train.toml"
    path.write_text('device = "cuda:1"\n')
    assert TrainConfig.from_toml(path).device == "cuda:1"


def test_cuda_without_a_gpu_fails_before_any_work(no_gpu: None,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    def no_env(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("the env was built before the device check")

    monkeypatch.setattr(TrainConfig, "make_env", no_env)
    with pytest.raises(ValueError) as error:
        train(TrainConfig(device="cuda", eval_every=0), iterations=1)
    message = str(error.value)
    assert "\n" not in message
    assert message.startswith("--device cuda: torch.cuda.is_available() is False on this "
                              "machine")
    assert "--device cpu" in message


def test_cli_cuda_without_a_gpu_is_a_one_line_error(no_gpu: None, tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    from h2h_racing.cli.command import main

    out = tmp_path / "run"
    assert main(["train", "--device", "cuda", "--envs", "4", "--iterations", "1",
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith("h2h-racing: error: --device cuda: torch.cuda.is_available() is "
                          "False") and "--device cpu" in err
    assert not out.exists()


def test_cli_device_cpu_trains_on_the_cpu(tmp_path: Path) -> None:
    from h2h_racing.cli.command import main

    out = tmp_path / "run"
    assert main(["train", "--device", "cpu", "--track", "oval", "--opponents", "none",
                 "--envs", "4", "--iterations", "1", "--eval-every", "0", "--no-onnx",
                 "--no-progress", "--out", str(out)]) == 0
    payload = torch.load(out / "policy.pt", weights_only=True)
    assert payload["train_config"]["device"] == "cpu"
    assert all(t.device.type == "cpu" for t in payload["actor_state_dict"].values())


def test_cli_help_shows_the_default(capsys: pytest.CaptureFixture[str]) -> None:
    from h2h_racing.cli.command import main

    with pytest.raises(SystemExit):
        main(["train", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--device {cpu,cuda}" in text
    assert "(default: cpu, or the --config file's device)" in text


def test_a_missing_cuda_index_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    monkeypatch.setattr(torch.cuda, "device_count", lambda: 1)
    device_module.check_device_available("cuda:0")
    with pytest.raises(ValueError, match=r"--device cuda:1: this machine has 1 CUDA device"):
        device_module.check_device_available("cuda:1")


@pytest.mark.parametrize("teacher", [None, "racing_line"])
def test_the_device_reaches_the_runner_and_the_env_stays_on_the_cpu(
        teacher: str | None, monkeypatch: pytest.MonkeyPatch) -> None:
    # A GPU as far as the device check is concerned; the runner records the device it is asked
    # for, then builds on the CPU (this machine's only device), so that the run completes.
    import rsl_rl.runners as runners

    from h2h_racing.training.imitation import ImitationConfig

    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    monkeypatch.setattr(torch.cuda, "device_count", lambda: 1)
    asked: list[tuple[str, str]] = []
    for name in ("OnPolicyRunner", "DistillationRunner"):
        real = getattr(runners, name)

        class Recording(real):  # type: ignore[misc, valid-type]
            def __init__(self, env: Any, cfg: dict[str, Any], log_dir: str | None = None,
                         device: str = "cpu") -> None:
                asked.append((device, env.device))
                super().__init__(env, cfg, log_dir=log_dir, device="cpu")

        monkeypatch.setattr(runners, name, Recording)
    config = TrainConfig(track="oval", num_envs=4, num_steps_per_env=4, hidden_dims=(8, 8),
                         eval_every=0, device="cuda",
                         imitation=ImitationConfig(teacher=teacher))
    runner = train(config, iterations=1)
    assert asked == [("cuda", "cpu")]
    assert runner.env.device == "cpu"
    assert runner.current_learning_iteration == 1


def _tensors(value: Any) -> list[torch.Tensor]:
    """Every tensor in a nested dict/list ``value`` (a policy file's payload)."""
    if isinstance(value, torch.Tensor):
        return [value]
    if isinstance(value, dict):
        return [t for v in value.values() for t in _tensors(v)]
    if isinstance(value, (list, tuple)):
        return [t for v in value for t in _tensors(v)]
    return []


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU (CI has none)")
@pytest.mark.parametrize("teacher", [None, "racing_line"])
def test_on_a_gpu_the_learner_trains_there_and_the_policy_file_drives_on_the_cpu(
        teacher: str | None, tmp_path: Path) -> None:
    import numpy as np
    from tensordict import TensorDict

    import h2h_racing
    from h2h_racing.policies import make_driver
    from h2h_racing.policies.trained import load_policy_payload
    from h2h_racing.training.imitation import ImitationConfig

    config = TrainConfig(track="oval", num_envs=4, num_steps_per_env=4, hidden_dims=(8, 8),
                         observations="camera_only", camera_size=(24, 16),
                         camera_channels=(4, 8), channels_last=True, eval_every=0,
                         device="cuda", imitation=ImitationConfig(teacher=teacher))
    runner = train(config, iterations=2, out=tmp_path)
    student = runner.alg.get_policy()
    assert {p.device.type for p in student.parameters()} == {"cuda"}
    assert runner.env.device == "cpu"
    payload = load_policy_payload(tmp_path / "policy.pt")
    assert _tensors(payload) and {t.device.type for t in _tensors(payload)} == {"cpu"}

    env = h2h_racing.parallel_env(track="oval", num_cars=1, race_type="time_trial")
    env.reset(seed=3)
    for _ in range(6):
        env.step({"car_0": np.array([0.2, 0.6], np.float32)})
    driver = make_driver(str(tmp_path / "policy.pt"))
    driver.reset(env.core)
    groups = driver._observe(env.core, 0)
    # The trained weights, moved to the CPU, give the driver's action (to float32 rounding:
    # the student's weights are channels-last, the driver's need not be).
    on_cpu = student.cpu().eval()
    with torch.inference_mode():
        expected = on_cpu(TensorDict({k: torch.from_numpy(v) for k, v in groups.items()},
                                     batch_size=[1])).numpy()
    np.testing.assert_allclose(driver.act(env.core, 0), np.clip(expected, -1, 1), atol=1e-5)
