"""Trained policies as drivers: load a ``policy.pt`` written by ``h2h_racing.training``.

A policy file holds the actor's weights and the env and observation config it was trained
with, among them the settings of the camera and the lidar its actor reads (``env_config``'s
``camera`` and ``lidar``: the driver renders both itself, as in training). It loads
weights-only, its tensors as numpy arrays (``h2h_racing.policies.torch_archive``, or torch's
``weights_only`` load for what that reader leaves to torch: no pickled code runs either way),
and its keys and sensor settings are checked. A plain MLP actor (the state-observation
policies) acts in numpy (``trained_numpy``) and never imports torch; a CNN builds rsl-rl's
model. The driver checks that the env it drives gives the same observation
layout as training did, and that the weights fit the actor, and raises a clear ``ValueError``
when they do not.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from h2h_racing.common.extras import missing_extra
from h2h_racing.policies.torch_archive import load_arrays
from h2h_racing.policies.trained_numpy import NumpyActor, numpy_actor
from h2h_racing.policies.trained_plain import plain_actor
from h2h_racing.policies.weights import WeightsFileError, check_keys, load_weights
from h2h_racing.training.limits import check_hidden_dims

if TYPE_CHECKING:
    from h2h_racing.sim.core import RaceCore

POLICY_FORMAT = "h2h-racing-policy/1"
"""Value of the ``format`` key of a policy file (as ``training.policy_file.save_policy`` writes
it)."""
TRAINED_DIR = Path(__file__).resolve().parent / "trained"
"""Shipped policies: ``trained/<name>/policy.pt`` with a ``CARD.md`` beside it."""
_OBSERVATION_KEYS = ("opponent_slots", "obstacle_slots")
_EXPECTED = f"an h2h-racing policy file (format {POLICY_FORMAT!r}, as `h2h-racing train` writes)"
_PAYLOAD_KEYS: dict[str, type | tuple[type, ...]] = {
    "format": str, "actor_state_dict": dict, "actor_cfg": dict, "obs_groups": (list, tuple),
    "observations": str, "env_config": dict}
"""Keys a policy dict must hold, with their types (``train_config`` and ``training`` are
informative)."""
_ACTOR_CLASSES = ("MLPModel", "CNNModel")
_SENSOR_GROUPS = ("camera", "lidar")
"""Observation groups the driver renders with its own sensor, whose settings the policy file
holds in ``env_config[group]`` (a ``CameraConfig`` or ``LidarConfig`` dict)."""
LIDAR_NOISE_SEED = 0
"""Seed of a noisy lidar's generator, made afresh at every ``reset``, so that a policy trained
with ``LidarConfig.noise_std > 0`` drives the same race the same way."""


def shipped_policies() -> dict[str, Path]:
    """Return the policies shipped with the package, ``{name: path of policy.pt}``."""
    if not TRAINED_DIR.is_dir():
        return {}
    return {p.parent.name: p for p in sorted(TRAINED_DIR.glob("*/policy.pt"))}


def load_policy_payload(policy: str | Path, arrays: bool = False) -> dict[str, Any]:
    """Load the dict of a policy file: ``policy`` is a shipped policy's name or a ``policy.pt``
    path (loaded weights-only; the format and keys are checked). Its tensors are torch's, or
    with ``arrays`` numpy arrays, read without torch where ``policies.torch_archive`` can.

    Raises:
        FileNotFoundError: ``policy`` is neither a shipped name nor a file.
        ValueError: The file is not an h2h-racing policy file (``WeightsFileError``).
    """
    shipped = shipped_policies()
    path = shipped.get(str(policy), Path(policy))
    if not path.is_file():
        raise FileNotFoundError(f"policy {str(policy)!r} is neither a shipped policy "
                                f"({', '.join(shipped)}) nor a policy.pt file")
    return _checked((load_arrays if arrays else load_weights)(path, _EXPECTED), str(path))


def trained_alone(payload: dict[str, Any]) -> bool | None:
    """Whether the policy dict ``payload`` was trained with no other car on its track: its
    ``racing`` record, or for files written before it, its env config's ``num_cars`` of 1
    (None when neither says)."""
    racing = payload.get("racing")
    if isinstance(racing, dict) and isinstance(racing.get("alone"), bool):
        return racing["alone"]
    cars = payload.get("env_config", {}).get("num_cars")
    return cars == 1 if isinstance(cars, int) else None


def _checked(payload: Any, source: str) -> dict[str, Any]:
    """``payload`` if it is a policy dict (format ``POLICY_FORMAT``, every key of
    ``_PAYLOAD_KEYS``), else a ``WeightsFileError`` naming ``source``."""
    if not isinstance(payload, dict) or payload.get("format") != POLICY_FORMAT:
        found = payload.get("format") if isinstance(payload, dict) else type(payload).__name__
        raise WeightsFileError(f"{source}: not an h2h-racing policy file (expected format "
                               f"{POLICY_FORMAT!r}, got {found!r})")
    check_keys(payload, _PAYLOAD_KEYS, source, _EXPECTED)
    env_keys: dict[str, type] = dict.fromkeys(_OBSERVATION_KEYS, int)
    sensors = _sensors(payload)
    env_keys.update(dict.fromkeys(sensors, dict))
    check_keys(payload["env_config"], env_keys, f"{source}: env_config",
               "the env config the policy was trained with")
    for group in sensors:
        _sensor_config(payload, group, source)
    if payload["actor_cfg"].get("class_name") not in _ACTOR_CLASSES:
        raise WeightsFileError(f"{source}: actor_cfg's class_name is "
                               f"{payload['actor_cfg'].get('class_name')!r}, expected one of "
                               f"{_ACTOR_CLASSES}")
    # The network is built from hidden_dims: bound them before anything allocates (a crafted
    # [60000, 60000] asked for 14 GB).
    try:
        check_hidden_dims(payload["actor_cfg"].get("hidden_dims"), f"{source}: actor_cfg")
    except ValueError as error:
        raise WeightsFileError(str(error)) from None
    return payload


def _sensors(payload: dict[str, Any]) -> list[str]:
    """The sensor groups the policy's actor reads (``camera``, ``lidar``), which the driver
    renders itself."""
    return [group for group in _SENSOR_GROUPS if group in payload["obs_groups"]]


def _sensor_config(payload: dict[str, Any], group: str, source: str) -> Any:
    """The ``CameraConfig`` or ``LidarConfig`` the policy was trained with, from its
    ``env_config[group]``, or a ``WeightsFileError`` naming ``source`` and the bad setting."""
    from h2h_racing.config.env import CameraConfig, LidarConfig

    kind = {"camera": CameraConfig, "lidar": LidarConfig}[group]
    try:
        return kind(**payload["env_config"][group])
    except (TypeError, ValueError) as error:
        raise WeightsFileError(
            f"{source}: env_config[{group!r}] is not a valid {kind.__name__} ({error}); "
            f"expected the {group} settings the policy was trained with, as `h2h-racing "
            f"train` saves them: retrain or re-save the policy") from None


class TrainedPolicy:
    """A driver that acts with a trained actor (deterministically: the Gaussian's mean).

    Args:
        path: A ``policy.pt`` file.
        name: Driver name shown in results (default: the path as given; a run folder's name
            alone, ``runs/speedway/policy.pt`` -> ``speedway``, read as a track's).
    """

    def __init__(self, path: str | Path, name: str | None = None) -> None:
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"policy file not found: {path.resolve()}")
        payload = load_arrays(path, _EXPECTED)
        self._setup(payload, name or str(path), str(path))
        self.path: Path | None = path

    @classmethod
    def from_payload(cls, payload: dict[str, Any], name: str,
                     source: str = "<in-memory policy>") -> TrainedPolicy:
        """A driver from a policy payload held in memory (the dict a ``policy.pt`` file holds,
        as ``h2h_racing.training.policy_file.policy_payload`` builds it, or with numpy arrays
        for its tensors), without a file.

        Args:
            payload: The policy dict.
            name: Driver name shown in results.
            source: What error messages call the policy (e.g. the training run it came from).
        """
        policy = cls.__new__(cls)
        policy._setup(payload, name, source)
        policy.path = None
        return policy

    def _setup(self, payload: Any, name: str, source: str) -> None:
        self.source = source
        self.payload = _checked(payload, source)
        self.name = name
        self.observations = payload["observations"]
        self.env_config: dict[str, Any] = payload["env_config"]
        self._model: Any = None
        self._example: dict[str, npt.NDArray[np.float32]] | None = None
        self._forward: Any = None
        self._camera: Any = None
        self._lidar: Any = None
        self._lidar_rng: np.random.Generator | None = None

    def reset(self, core: RaceCore) -> None:
        """Check that ``core`` gives the observations this policy was trained on."""
        cfg = core.config
        trained = self.env_config
        for key in _OBSERVATION_KEYS:
            if getattr(cfg, key) != trained[key]:
                raise ValueError(
                    f"{self.source}: trained with {key}={trained[key]}, but the env has "
                    f"{key}={getattr(cfg, key)}; build the env with {key}={trained[key]}")
        # The policy renders its own camera and lidar with the settings it was trained with,
        # so it drives in any env (the env's own sensors, if any, are for its observations).
        sensors = _sensors(self.payload)
        obstacle_size = (cfg.obstacle_length, cfg.obstacle_width)
        if "camera" in sensors:
            from h2h_racing.sensors.camera import CameraSensor

            self._camera = CameraSensor(_sensor_config(self.payload, "camera", self.source),
                                        core.track, cfg.car, obstacle_size)
        if "lidar" in sensors:
            from h2h_racing.sensors.lidar import LidarSensor

            self._lidar = LidarSensor(_sensor_config(self.payload, "lidar", self.source),
                                      cfg.car, obstacle_size)
            self._lidar_rng = np.random.default_rng(LIDAR_NOISE_SEED)
        if self._forward is None and self._model is None:
            self._example = {k: v[:1] for k, v in self._observe(core, 0).items()}
            # numpy, else torch for an activation numpy has no twin of (gelu).
            self._forward = (numpy_actor(self.payload, self._example)
                             or plain_actor(self.payload, self._example))
            if self._forward is None:
                # Not a plain MLP, or weights that do not fit (rsl-rl's model says why, now).
                self._model = self._build_actor(self._example)

    @property
    def _actor(self) -> Any:
        """The actor as rsl-rl's model (``MLPModel`` or ``CNNModel``), built on first use
        after ``reset`` (export reads it; a plain MLP acts without it: ``numpy_actor``)."""
        if self._model is None:
            if self._example is None:
                raise RuntimeError(f"{self.source}: reset the driver on a core first")
            self._model = self._build_actor(self._example)
        return self._model

    def _build_actor(self, example: dict[str, npt.NDArray[np.float32]]) -> Any:
        try:
            import torch
            from rsl_rl.models import CNNModel, MLPModel
            from tensordict import TensorDict
        except ImportError as error:
            raise missing_extra("train", "trained drivers", error) from None

        actor_cfg = dict(self.payload["actor_cfg"])
        model_class = {"MLPModel": MLPModel, "CNNModel": CNNModel}[actor_cfg.pop("class_name")]
        example = TensorDict({key: torch.as_tensor(value[:1]) for key, value in example.items()},
                             batch_size=[1])
        # load_state_dict copies each value into the model's tensors: a numpy array read from
        # the file gives the same bits as torch's own tensor.
        state = {key: torch.from_numpy(value) if isinstance(value, np.ndarray) else value
                 for key, value in self.payload["actor_state_dict"].items()}
        try:
            model = model_class(example, {"actor": list(self.payload["obs_groups"])}, "actor",
                                2, **actor_cfg)
            model.load_state_dict(state)
        except (RuntimeError, TypeError, ValueError, KeyError) as error:
            # Weights of another size (or another actor config) than this env's observations
            # give: torch's message lists the tensors that differ.
            raise WeightsFileError(
                f"{self.source}: the policy's actor does not fit its own config and this env's "
                f"observations (observations={self.observations!r}, obs_groups="
                f"{list(self.payload['obs_groups'])}): {type(error).__name__}: "
                f"{' '.join(str(error).split())}") from None
        model.eval()
        return model

    def _observe(self, core: RaceCore, car: int) -> dict[str, npt.NDArray[np.float32]]:
        from h2h_racing.sensors.state import MOTION_FEATURES, state_observation

        # The groups of h2h_racing.training.vec_env, for one car; the actor reads the ones it
        # was trained on (payload["obs_groups"]).
        state = state_observation(core)[:, car]
        groups = {"policy": np.ascontiguousarray(state),
                  "motion": np.ascontiguousarray(state[:, list(MOTION_FEATURES)])}
        if self._camera is not None:
            frames = self._camera.observe(core)[:, car]
            groups["camera"] = (frames.transpose(0, 3, 1, 2).astype(np.float32) / 255.0)
        if self._lidar is not None:
            groups["lidar"] = np.ascontiguousarray(
                self._lidar.observe(core, self._lidar_rng)[:, car])
        return groups

    def act(self, core: RaceCore, car: int) -> npt.NDArray[np.float32]:
        """Return the actions of car ``car`` in every env copy, (E, 2) in [-1, 1]."""
        if self._forward is None and self._model is None:
            self.reset(core)
        obs = self._observe(core, car)
        if isinstance(self._forward, NumpyActor):
            return np.clip(self._forward(obs), -1.0, 1.0).astype(np.float32)
        import torch

        with torch.inference_mode():
            if self._forward is not None:
                action = self._forward(obs)
            else:
                from tensordict import TensorDict

                action = self._actor(TensorDict({k: torch.from_numpy(v) for k, v in obs.items()},
                                                batch_size=[core.num_envs]))
        return np.clip(action.numpy(), -1.0, 1.0).astype(np.float32)

