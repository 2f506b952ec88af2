"""A trained MLP actor evaluated with plain torch, without rsl-rl.

A ``TrainedPolicy`` acts with its actor's deterministic output. For the common actor, rsl-rl's
``MLPModel`` with a ``GaussianDistribution`` (the state-observation policies), that output is
the MLP's: the observation groups concatenated, normalised (``(x - mean) / (std + eps)``),
then linear layers with an activation between them. ``plain_actor`` computes it from the
policy file's weights with the same torch operations, in the same order, on the same
float32 tensors, so its actions are rsl-rl's to the bit (``tests/policies/test_trained_plain.py``
checks every shipped policy). Importing rsl-rl costs a command about 3 s (its ``tensordict``
imports ``torch._dynamo``), and a model call's ``TensorDict`` and module hooks cost a few
copies' batch more than the arithmetic does.

Anything else (a CNN, another distribution, an unknown setting, weights that do not fit)
gets None, and the driver builds rsl-rl's model, which says what does not fit.

Drivers act with ``policies.trained_numpy``'s numpy version of the same MLP (no torch at
all); this torch one is its reference in the tests and acts only for the activations numpy
has no twin of (``gelu``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

NORMALIZER_EPS = 1e-2
"""The ``eps`` of rsl-rl's ``EmpiricalNormalization`` as ``MLPModel`` builds it (its default:
not in the weights)."""
ACTIVATIONS = ("elu", "selu", "relu", "crelu", "lrelu", "tanh", "sigmoid", "softplus", "gelu",
               "swish", "mish", "identity")
"""``rsl_rl.utils.resolve_nn_activation``'s names, as torch modules (``_activation``)."""
_MLP_KEYS = frozenset(("class_name", "hidden_dims", "activation", "obs_normalization",
                       "distribution_cfg"))
_GAUSSIAN_KEYS = frozenset(("class_name", "init_std", "std_range", "std_type", "learn_std"))

Forward = Callable[[Mapping[str, npt.NDArray[np.float32]]], Any]


@dataclass(frozen=True)
class MlpLayout:
    """The plain MLP of a policy file (``mlp_layout``)."""

    groups: tuple[str, ...]
    """Observation groups, concatenated in this order."""
    dims: tuple[int, ...]
    """Widths: the input, each hidden layer, the 2 actions."""
    activation: str
    """Between the linear layers (a name of ``ACTIVATIONS``)."""
    normalize: bool
    """Whether the input is normalised first (``obs_normalizer._mean``, ``_std``)."""


def mlp_layout(payload: Mapping[str, Any],
               example: Mapping[str, npt.NDArray[np.float32]]) -> MlpLayout | None:
    """The layout of ``payload``'s actor (a policy file's dict; its weights torch tensors or
    numpy arrays), or None when it is not an ``MLPModel`` with a Gaussian (or no)
    distribution whose weights fit ``example``'s groups (``{group: (E, dim) float32}``)."""
    cfg = payload["actor_cfg"]
    groups = list(payload["obs_groups"])
    dist = cfg.get("distribution_cfg")
    if (cfg.get("class_name") != "MLPModel" or not set(cfg) <= _MLP_KEYS
            or cfg.get("activation", "elu") not in ACTIVATIONS
            or not isinstance(cfg.get("obs_normalization", False), bool)
            or not all(g in example and np.ndim(example[g]) == 2 for g in groups)):
        return None
    if dist is not None and (not isinstance(dist, Mapping) or not set(dist) <= _GAUSSIAN_KEYS
                             or dist.get("class_name") != "GaussianDistribution"
                             or dist.get("std_type", "scalar") not in ("scalar", "log")):
        return None
    dims = [sum(int(example[g].shape[1]) for g in groups)]
    dims += [dims[0] if d == -1 else d for d in cfg.get("hidden_dims", (256, 256, 256))]
    dims.append(2)
    state = payload["actor_state_dict"]
    shapes = {f"mlp.{2 * i}.weight": (dims[i + 1], dims[i]) for i in range(len(dims) - 1)}
    shapes.update({f"mlp.{2 * i}.bias": (dims[i + 1],) for i in range(len(dims) - 1)})
    if cfg.get("obs_normalization", False):
        shapes.update({f"obs_normalizer.{k}": (1, dims[0]) for k in ("_mean", "_var", "_std")})
        shapes["obs_normalizer.count"] = ()
    if dist is not None:
        std = "std_param" if dist.get("std_type", "scalar") == "scalar" else "log_std_param"
        shapes[f"distribution.{std}"] = (2,)
    # A tensor or an array (policies.torch_archive reads a file's tensors as arrays).
    if set(state) != set(shapes) or any(
            not (hasattr(state[k], "shape") and hasattr(state[k], "dtype"))
            or tuple(state[k].shape) != shape for k, shape in shapes.items()):
        return None
    return MlpLayout(tuple(groups), tuple(dims), cfg.get("activation", "elu"),
                     cfg.get("obs_normalization", False))


def plain_actor(payload: Mapping[str, Any],
                example: Mapping[str, npt.NDArray[np.float32]]) -> Forward | None:
    """The actor of ``payload`` (a policy file's dict) as a function of the observation groups
    (``{group: (E, dim) float32}``, as ``example``) to its actions (a float32 tensor, (E, 2),
    before clipping), or None when it is not a plain MLP (``mlp_layout``). Call it under
    ``torch.inference_mode()``."""
    layout = mlp_layout(payload, example)
    if layout is None:
        return None
    import torch

    groups, dims = layout.groups, layout.dims
    state = payload["actor_state_dict"]

    def weight(key: str) -> Any:
        # What load_state_dict leaves in a float32 module: a contiguous float32 copy.
        value = state[key]
        if isinstance(value, np.ndarray):
            value = torch.from_numpy(value)
        return value.detach().to(torch.float32).clone(memory_format=torch.contiguous_format)

    layers = [(weight(f"mlp.{2 * i}.weight"), weight(f"mlp.{2 * i}.bias"))
              for i in range(len(dims) - 1)]
    activation = _activation(layout.activation)
    normalize = None
    if layout.normalize:
        normalize = (weight("obs_normalizer._mean"), weight("obs_normalizer._std"))
    linear = torch.nn.functional.linear

    def forward(obs: Mapping[str, npt.NDArray[np.float32]]) -> Any:
        # MLPModel.get_latent, its MLP and the Gaussian's mean: the same operations.
        x = torch.cat([torch.from_numpy(obs[g]) for g in groups], dim=-1)
        if normalize is not None:
            x = (x - normalize[0]) / (normalize[1] + NORMALIZER_EPS)
        for i, (w, b) in enumerate(layers):
            x = linear(x, w, b)
            if i < len(layers) - 1:
                x = activation(x)
        return x

    return forward


def _activation(name: str) -> Callable[[Any], Any]:
    """The activation ``rsl_rl.utils.resolve_nn_activation(name)`` gives, as a torch module."""
    import torch

    nn = torch.nn
    modules = {"elu": nn.ELU, "selu": nn.SELU, "relu": nn.ReLU, "crelu": nn.CELU,
               "lrelu": nn.LeakyReLU, "tanh": nn.Tanh, "sigmoid": nn.Sigmoid,
               "softplus": nn.Softplus, "gelu": nn.GELU, "swish": nn.SiLU, "mish": nn.Mish,
               "identity": nn.Identity}
    return modules[name]().forward
