"""Export a trained policy to ONNX and TorchScript, checked against the original.

    h2h-racing export ppo_generalist --format onnx,torchscript --out exports/ppo_generalist

``export_policy`` loads a policy (a shipped name or a ``policy.pt``) as the driver that races
with it (``h2h_racing.policies.trained.TrainedPolicy``), exports its actor with rsl-rl's own
export modules (``as_onnx()``; the TorchScript file is traced from the same module), and
writes into ``out``:

- ``policy.onnx``: inputs ``obs`` (B, F) float32 and, for camera policies, ``camera``
  (B, C, H, W) float32; output ``actions`` (B, 2) float32. The batch size B is free.
- ``policy.torchscript.pt``: the same function for ``torch.jit.load``; call it with the
  inputs in that order.
- ``policy.export.json``: what each input holds, how to build it from the env, and the env
  config the policy was trained with.

The exported function is the driver's: the deterministic action (the Gaussian's mean),
clipped to [-1, 1], i.e. ``[steer, speed]`` in the env's continuous action space. ``obs`` is
the concatenation of the actor's vector groups: ``policy`` is the state observation
(``h2h_racing.sensors.state``, F = 19 + 4 x opponent_slots + 3 x obstacle_slots), ``lidar``
the car's lidar ranges with the policy's own lidar settings (``env_config["lidar"]``, for
``camera_lidar`` policies), ``motion`` the state's entries ``MOTION_FEATURES`` (own speed and
steering, for ``camera_only`` and ``camera_lidar`` policies), in the actor's group order (the
sidecar lists it). ``camera`` is the car's camera with the policy's own camera settings,
uint8 (H, W, C) transposed to (C, H, W) and divided by 255. The observation normaliser is
inside the export.

Every export is checked before it is reported: it is loaded back (ONNX with onnxruntime, or
onnx's reference evaluator when onnxruntime is not installed; TorchScript with
``torch.jit.load``) and run on sample observations of races on the policy's track, and its
actions are compared with the driver's (``max_abs_diff``). A difference above ``tolerance``
raises.
"""

from __future__ import annotations

import json
import logging
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

FORMATS = ("onnx", "torchscript")
"""Export formats, in the order they are written."""
FILES = {"onnx": "policy.onnx", "torchscript": "policy.torchscript.pt"}
"""File name of each format in the output folder."""
SIDECAR = "policy.export.json"
"""File name of the description of the inputs and outputs."""
TOLERANCE = 1e-4
"""Largest allowed difference between an export's actions and the driver's (float32 maths
in another runtime differs by ~1e-6)."""


@dataclass(frozen=True)
class ExportResult:
    """What ``export_policy`` wrote and how closely the exports match the original."""

    policy: str
    """The policy exported, as given."""
    files: dict[str, Path]
    """Format -> file written."""
    max_abs_diff: dict[str, float]
    """Format -> largest |export action - driver action| over the samples."""
    runtimes: dict[str, str]
    """Format -> what ran the export back (``onnxruntime``, ``onnx.reference``, ``torch.jit``)."""
    samples: int
    """Sample observations compared."""
    inputs: list[dict[str, Any]] = field(default_factory=list)
    """The exported inputs: name, shape (batch first) and meaning."""

    def summary(self) -> str:
        """One line per format: file, runtime and max abs diff."""
        return "\n".join(
            f"{fmt}: {self.files[fmt]} (loaded back with {self.runtimes[fmt]}; max abs diff "
            f"{self.max_abs_diff[fmt]:.2e} over {self.samples} observations)"
            for fmt in self.files)


def parse_formats(text: str | Sequence[str]) -> tuple[str, ...]:
    """``"onnx,torchscript"`` (or a sequence of names) -> checked format names, no repeats."""
    names = text.split(",") if isinstance(text, str) else list(text)
    formats = tuple(dict.fromkeys(n.strip() for n in names if n.strip()))
    unknown = [f for f in formats if f not in FORMATS]
    if unknown or not formats:
        raise ValueError(f"unknown export format(s) {unknown or formats!r}; choose from "
                         f"{', '.join(FORMATS)} (comma-separated)")
    return formats


def export_policy(policy: str | Path, out: str | Path,
                  formats: str | Sequence[str] = FORMATS, samples: int = 64, seed: int = 0,
                  tolerance: float = TOLERANCE) -> ExportResult:
    """Export ``policy`` to ``formats`` in folder ``out`` and check every export.

    Args:
        policy: A shipped policy's name or a ``policy.pt`` path.
        out: Output folder (created).
        formats: ``"onnx"``, ``"torchscript"`` or both (a comma list or a sequence).
        samples: Sample observations the exports are checked on (rounded up to whole
            batches of 16).
        seed: Seed of the sample races.
        tolerance: Largest allowed max abs difference from the driver's actions.

    Raises:
        FileNotFoundError: ``policy`` is neither a shipped name nor a file.
        ValueError: Not a policy file, an unknown format, an actor that cannot be exported,
            or an export whose actions differ from the original's by more than ``tolerance``.
    """
    from h2h_racing.policies.trained import TrainedPolicy, load_policy_payload

    os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")  # rsl-rl imports GitPython
    import torch

    formats = parse_formats(formats)
    if samples < 1:
        raise ValueError(f"samples must be >= 1, got {samples}")
    payload = load_policy_payload(policy)
    driver = TrainedPolicy.from_payload(payload, name=Path(str(policy)).stem, source=str(policy))
    observations, actions = _samples(driver, payload, samples, seed)
    module, names = _exportable(driver, torch)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    example = tuple(torch.from_numpy(observations[n][:2]) for n in names)
    files, diffs, runtimes = {}, {}, {}
    for fmt in formats:
        path = out / FILES[fmt]
        if fmt == "onnx":
            _write_onnx(module, example, names, path, torch)
            exported, runtimes[fmt] = _run_onnx(path, observations, names)
        else:
            with warnings.catch_warnings():
                # TorchScript is deprecated in favour of torch.export, but it is what C++
                # (libtorch) deployments load; the request for it is explicit.
                warnings.filterwarnings("ignore", message=r".*torch\.jit\.\w+` is deprecated")
                torch.jit.trace(module, example).save(str(path))
                loaded = torch.jit.load(str(path))
            with torch.inference_mode():
                exported = loaded(*(torch.from_numpy(observations[n]) for n in names)).numpy()
            runtimes[fmt] = "torch.jit"
        diff = float(np.abs(exported - actions).max())
        if not diff <= tolerance:
            raise ValueError(f"{path}: the exported policy's actions differ from {policy}'s by "
                             f"up to {diff:.3g} (allowed {tolerance:g}); the export is wrong, "
                             f"do not use it")
        files[fmt], diffs[fmt] = path, diff
    inputs = _describe_inputs(driver, names, observations)
    (out / SIDECAR).write_text(json.dumps({
        "policy": str(policy), "observations": payload["observations"], "inputs": inputs,
        "outputs": [{"name": "actions", "shape": ["batch", 2], "dtype": "float32",
                     "meaning": "[steer, speed] in [-1, 1]: the env's continuous action "
                                "(deterministic, clipped)"}],
        "files": {fmt: path.name for fmt, path in files.items()},
        "max_abs_diff": diffs, "env_config": payload["env_config"]}, indent=2) + "\n")
    return ExportResult(policy=str(policy), files=files, max_abs_diff=diffs, runtimes=runtimes,
                        samples=len(actions), inputs=inputs)


def _samples(driver: Any, payload: dict[str, Any], samples: int, seed: int,
             ) -> tuple[dict[str, npt.NDArray[np.float32]], npt.NDArray[np.float32]]:
    """Observations of car 0 in races on the policy's track, and the driver's actions on them.

    Batches of 16 env copies start spread round the lap with a second car and the boxes of
    ``object_avoidance`` (so the opponent and obstacle features vary too), and drive random
    actions for a few steps between samples (speeds, offsets and headings vary).
    """
    from h2h_racing.config.env import EnvConfig
    from h2h_racing.sim.core import RaceCore
    from h2h_racing.track.io import catalogue, load_track

    trained = payload["env_config"]
    track = trained["track"] if trained["track"] in catalogue() else "speedway"
    config = EnvConfig(track=track, num_cars=2, race_type="object_avoidance",
                       opponent_slots=trained["opponent_slots"],
                       obstacle_slots=trained["obstacle_slots"])
    copies = 16
    core = RaceCore(config, load_track(track), num_envs=copies)
    rng = np.random.default_rng(seed)
    core.reset(seed=seed, start=np.linspace(0.0, core.track.length, copies, endpoint=False))
    driver.reset(core)
    groups: dict[str, list[npt.NDArray[np.float32]]] = {}
    actions = []
    for batch in range(-(-samples // copies)):
        for _ in range(3 + batch):
            random = rng.uniform(-1.0, 1.0, (copies, core.num_cars, 2)).astype(np.float32)
            core.step(*config.commands(random))
        for key, value in driver._observe(core, 0).items():
            groups.setdefault(key, []).append(value)
        actions.append(driver.act(core, 0))
    observed = {key: np.concatenate(values) for key, values in groups.items()}
    actor = driver._actor
    inputs = {"obs": np.ascontiguousarray(
        np.concatenate([observed[g] for g in actor.obs_groups], axis=1), dtype=np.float32)}
    for group in getattr(actor, "obs_groups_2d", []):
        inputs[group] = np.ascontiguousarray(observed[group], dtype=np.float32)
    return inputs, np.concatenate(actions)


def _exportable(driver: Any, torch: Any) -> tuple[Any, list[str]]:
    """The driver's actor as rsl-rl's ONNX export module with the driver's clipping, and its
    input names (one positional argument each, so export and tracing see named tensors)."""
    inner = driver._actor.as_onnx(verbose=False)
    inner.eval()
    names = list(inner.input_names)

    class Vector(torch.nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.actor = inner

        def forward(self, obs: Any) -> Any:
            return torch.clamp(self.actor(obs), -1.0, 1.0)

    class VectorAndImage(Vector):
        def forward(self, obs: Any, image: Any) -> Any:  # type: ignore[override]
            return torch.clamp(self.actor(obs, image), -1.0, 1.0)

    if len(names) == 1:
        return Vector().eval(), names
    if len(names) == 2:
        return VectorAndImage().eval(), names
    raise ValueError(f"{driver.source}: the actor takes inputs {names}; export handles a "
                     f"vector and at most one image group")


def _write_onnx(module: Any, example: tuple[Any, ...], names: list[str], path: Path,
                torch: Any) -> None:
    batch = torch.export.Dim("batch")
    arguments = ["obs", "image"][:len(names)]
    # torch.export's internal deprecation notices, its note that the inputs share one batch
    # axis, and the log lines about torchvision operators say nothing about this export.
    registration = logging.getLogger("torch.onnx._internal.exporter._registration")
    level = registration.level
    registration.setLevel(logging.ERROR)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FutureWarning)
            warnings.filterwarnings("ignore", message=r".*axis name: batch will not be used")
            torch.onnx.export(module, example, str(path), input_names=names,
                              output_names=["actions"], opset_version=18, dynamo=True,
                              external_data=False, verbose=False,
                              dynamic_shapes={a: {0: batch} for a in arguments})
    finally:
        registration.setLevel(level)


def _run_onnx(path: Path, observations: dict[str, npt.NDArray[np.float32]],
              names: list[str]) -> tuple[npt.NDArray[np.float32], str]:
    feeds = {n: observations[n] for n in names}
    try:
        import onnxruntime
    except ImportError:
        # onnx comes with the train extra (rsl-rl needs it); its reference evaluator is slow
        # but exact enough for a check.
        from onnx.reference import ReferenceEvaluator

        return ReferenceEvaluator(str(path)).run(None, feeds)[0], "onnx.reference"
    session = onnxruntime.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    return session.run(None, feeds)[0], "onnxruntime"


def _describe_inputs(driver: Any, names: list[str],
                     observations: dict[str, npt.NDArray[np.float32]]) -> list[dict[str, Any]]:
    actor = driver._actor
    meaning = {"policy": "the state observation (h2h_racing.sensors.state)",
               "lidar": "the car's lidar ranges [m] (env_config['lidar'] settings, "
                        "h2h_racing.sensors.lidar)",
               "motion": "state observation entries MOTION_FEATURES (own speed, steering)"}
    groups = " + ".join(f"{g} ({meaning.get(g, g)})" for g in actor.obs_groups)
    inputs = [{"name": "obs", "shape": ["batch", int(observations["obs"].shape[1])],
               "dtype": "float32", "meaning": f"concatenation of {groups}"}]
    for name in names[1:]:
        inputs.append({"name": name, "shape": ["batch", *observations[name].shape[1:]],
                       "dtype": "float32",
                       "meaning": "the car's camera (env_config['camera'] settings), uint8 "
                                  "(H, W, C) transposed to (C, H, W), divided by 255"})
    return inputs
