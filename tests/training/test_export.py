"""h2h-racing export: ONNX and TorchScript exports act as the original policy does."""

from __future__ import annotations

import dataclasses
import json
import warnings
from pathlib import Path

import numpy as np
import pytest
import torch

import h2h_racing
from h2h_racing.cli.command import main
from h2h_racing.config.env import CameraConfig
from h2h_racing.training import export as export_module
from h2h_racing.training.export import export_policy
from h2h_racing.training.config import TrainConfig
from h2h_racing.training.train import train
from h2h_racing.policies import make_driver
from h2h_racing.policies.trained import shipped_policies
from h2h_racing.sensors.state import MOTION_FEATURES

onnxruntime = pytest.importorskip("onnxruntime")

SMALL = TrainConfig(track="oval", num_envs=8, num_steps_per_env=8, hidden_dims=(16, 16))
CAMERA = dataclasses.replace(SMALL, observations="camera_only", camera_size=(32, 24))


@pytest.fixture(scope="module")
def state_policy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("state")
    train(SMALL, iterations=1, out=out)
    return out / "policy.pt"


@pytest.fixture(scope="module")
def camera_policy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("camera")
    train(CAMERA, iterations=1, out=out)
    return out / "policy.pt"


def _race(sensors, camera=None, steps=12):
    """A 2-car race on the oval driven a few steps, and the observations of car_0."""
    extra = {"camera": camera} if camera is not None else {}
    env = h2h_racing.parallel_env(track="oval", num_cars=2, sensors=sensors, **extra)
    obs, _ = env.reset(seed=5)
    drivers = [make_driver("pure_pursuit"), make_driver("racing_line")]
    for driver in drivers:
        driver.reset(env.core)
    samples = [obs["car_0"]]
    for _ in range(steps):
        obs, *_ = env.step({a: drivers[i].act(env.core, i)[0]
                            for i, a in enumerate(env.possible_agents) if a in env.agents})
        samples.append(obs["car_0"])
    return env, samples


def test_state_policy_exports_act_as_the_policy(state_policy: Path, tmp_path: Path) -> None:
    result = export_policy(state_policy, tmp_path)
    assert set(result.files) == {"onnx", "torchscript"}
    assert result.runtimes == {"onnx": "onnxruntime", "torchscript": "torch.jit"}
    assert all(diff <= 1e-5 for diff in result.max_abs_diff.values())
    assert result.samples == 64
    # Independently of the export's own check: feed the env's observation, as the sidecar
    # says (obs = the state vector), and compare with the driver racing in that env.
    env, samples = _race(("state",))
    obs = samples[-1][None].astype(np.float32)
    driver = make_driver(str(state_policy))
    driver.reset(env.core)
    expected = driver.act(env.core, 0)
    session = onnxruntime.InferenceSession(str(result.files["onnx"]),
                                           providers=["CPUExecutionProvider"])
    np.testing.assert_allclose(session.run(None, {"obs": obs})[0], expected, atol=1e-5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # torch.jit is deprecated
        scripted = torch.jit.load(str(result.files["torchscript"]))
    np.testing.assert_allclose(scripted(torch.from_numpy(obs)).detach().numpy(), expected,
                               atol=1e-5)
    # The batch size is free: the 64 samples at once, then one.
    batch = np.random.default_rng(0).uniform(-1, 1, (64, obs.shape[1])).astype(np.float32)
    actions = session.run(None, {"obs": batch})[0]
    assert actions.shape == (64, 2) and np.abs(actions).max() <= 1.0


def test_camera_policy_exports_take_the_camera_image(camera_policy: Path,
                                                     tmp_path: Path) -> None:
    result = export_policy(camera_policy, tmp_path, formats="onnx")
    assert set(result.files) == {"onnx"} and result.max_abs_diff["onnx"] <= 1e-5
    sidecar = json.loads((tmp_path / "policy.export.json").read_text())
    assert [i["name"] for i in sidecar["inputs"]] == ["obs", "camera"]
    assert sidecar["inputs"][1]["shape"] == ["batch", 1, 24, 32]
    # Build the inputs from the env's own Dict observation, as the sidecar describes them.
    camera = CameraConfig(**sidecar["env_config"]["camera"])
    env, samples = _race(("camera", "state"), camera=camera, steps=5)
    last = samples[-1]
    feeds = {"obs": last["state"][list(MOTION_FEATURES)][None].astype(np.float32),
             "camera": (last["camera"].transpose(2, 0, 1)[None] / 255.0).astype(np.float32)}
    driver = make_driver(str(camera_policy))
    driver.reset(env.core)
    session = onnxruntime.InferenceSession(str(result.files["onnx"]),
                                           providers=["CPUExecutionProvider"])
    np.testing.assert_allclose(session.run(None, feeds)[0], driver.act(env.core, 0), atol=1e-5)


def test_an_export_that_acts_differently_is_refused(state_policy: Path, tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    real = export_module._run_onnx

    def off_by_a_bit(*args):
        actions, runtime = real(*args)
        return actions + 1e-3, runtime

    monkeypatch.setattr(export_module, "_run_onnx", off_by_a_bit)
    with pytest.raises(ValueError, match="differ .* by up to 0.001"):
        export_policy(state_policy, tmp_path, formats="onnx")


def test_cli_exports_the_formats_asked_for(state_policy: Path, tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "exported"
    assert main(["export", str(state_policy), "--format", "torchscript", "--out", str(out),
                 "--samples", "16"]) == 0
    printed = capsys.readouterr().out
    assert "torchscript:" in printed and "max abs diff" in printed and "onnx:" not in printed
    assert sorted(p.name for p in out.iterdir()) == ["policy.export.json",
                                                     "policy.torchscript.pt"]


def test_cli_refuses_an_unknown_format(state_policy: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["export", str(state_policy), "--format", "onnx,tflite"]) == 2
    assert "unknown export format(s) ['tflite']" in capsys.readouterr().err


def test_a_shipped_policy_exports_by_name(tmp_path: Path) -> None:
    shipped = [name for name in shipped_policies()
               if torch.load(shipped_policies()[name], weights_only=True)["observations"]
               == "state"]
    if not shipped:
        pytest.skip("no shipped state policy")
    result = export_policy(shipped[0], tmp_path, formats="onnx", samples=16)
    assert result.max_abs_diff["onnx"] <= 1e-5
    assert json.loads((tmp_path / "policy.export.json").read_text())["policy"] == shipped[0]
