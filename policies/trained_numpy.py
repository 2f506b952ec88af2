"""A trained MLP actor evaluated in numpy float32, without torch.

The MLP of ``policies.trained_plain`` (``mlp_layout``: the observation groups concatenated,
normalised as ``(x - mean) / (std + eps)``, linear layers with an activation between them,
the Gaussian's mean out), computed with numpy's float32 matmul (its BLAS: OpenBLAS in the
wheels) and ufuncs. A command driving a state-observation policy then never imports torch,
2-3 s of its start.

It is not torch's computation to the bit: BLAS sums a dot product in another order than
torch's MKL, and the ELU's ``exp(x) - 1`` (numpy's SIMD ``exp``; its ``expm1`` is a scalar
loop, 8 times slower) is within about 1e-7 of torch's ``expm1`` near 0 instead of 1 ulp. The
actions differ from torch's by at most a few float32 ulps of their size
(``tests/policies/test_trained_numpy.py`` measures it on every shipped MLP policy), so a race
can differ in its last digits from one driven by torch; every command drives with this one.

Batch invariance. OpenBLAS gives a row of a float32 matmul bits that depend on where the row
sits in the batch (its ``sgemm`` kernel handles rows in groups, the last, partial group with
another kernel, and with two threads the groups shift), so a car's actions would change with
the number of cars beside it. Here every matmul is a stack of tiles of at most
``MAX_TILE_ROWS`` rows (``tiling``): a block of ``block`` rows (one run's copies) is padded
to whole tiles of a size fixed by ``block`` alone, and ``np.matmul`` calls one ``sgemm`` per
tile. So a row's bits depend only on its block size and its place in its block, never on the
other blocks of the batch; and a tile of 16 rows of the shipped networks' sizes stays under
OpenBLAS's threshold for threads (``M * N * K <= 4 * 65536``), so the thread count does not
change them either (both checked by the tests). Elementwise ufuncs give each element the same
bits wherever it sits.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from h2h_racing.policies.trained_plain import NORMALIZER_EPS, mlp_layout

Float32Array = npt.NDArray[np.float32]

MAX_TILE_ROWS = 16
"""Most rows of one ``sgemm`` call (see the module docstring): 16 x 128 x 128 is OpenBLAS's
single-thread limit, and 10-20 copies of a run fit one or two tiles."""
SELU_ALPHA = 1.6732632423543772848170429916717
SELU_SCALE = 1.0507009873554804934193349852946
"""``torch.nn.SELU``'s constants."""
LRELU_SLOPE = 0.01
"""``torch.nn.LeakyReLU``'s default negative slope (rsl-rl's ``lrelu``)."""
SOFTPLUS_THRESHOLD = 20.0
"""``torch.nn.Softplus``'s default threshold: above it, softplus(x) is x."""


def _elu(x: Float32Array) -> Float32Array:
    # max(x, 0) + (exp(min(x, 0)) - 1): the same numbers as where(x > 0, x, expm1(x)) up to
    # exp's rounding; exp(m) - 1 is exact for m in [-0.69, 0] (Sterbenz).
    negative = np.minimum(x, 0)
    np.exp(negative, out=negative)
    negative -= 1
    np.maximum(x, 0, out=x)
    x += negative
    return x


def _selu(x: Float32Array) -> Float32Array:
    negative = np.exp(np.minimum(x, 0))
    negative -= 1
    negative *= np.float32(SELU_ALPHA * SELU_SCALE)
    np.maximum(x, 0, out=x)
    x *= np.float32(SELU_SCALE)
    x += negative
    return x


def _sigmoid(x: Float32Array) -> Float32Array:
    with np.errstate(over="ignore"):  # exp(-x) of a very negative x: inf, giving 0
        out = np.exp(-x)
    out += 1
    return np.reciprocal(out, out=out)


def _softplus(x: Float32Array) -> Float32Array:
    with np.errstate(over="ignore"):  # exp of a large x: inf, replaced by x
        out = np.log1p(np.exp(x))
    return np.where(x > SOFTPLUS_THRESHOLD, x, out)


ACTIVATIONS: dict[str, Callable[[Float32Array], Float32Array]] = {
    "elu": _elu,
    "crelu": _elu,  # torch.nn.CELU with alpha 1 is the ELU
    "selu": _selu,
    "relu": lambda x: np.maximum(x, 0, out=x),
    "lrelu": lambda x: np.where(x > 0, x, x * np.float32(LRELU_SLOPE)),
    "tanh": lambda x: np.tanh(x, out=x),
    "sigmoid": _sigmoid,
    "softplus": _softplus,
    "swish": lambda x: x * _sigmoid(x.copy()),
    "mish": lambda x: x * np.tanh(_softplus(x)),
    "identity": lambda x: x,
}
"""rsl-rl's activations (``trained_plain.ACTIVATIONS``) in numpy float32, in place where they
can be; ``gelu`` (erf) has none and acts with torch."""


def tiling(block: int) -> tuple[int, int]:
    """``(tiles, rows)``: a block of ``block`` rows is multiplied as ``tiles`` tiles of
    ``rows`` rows each (at most ``MAX_TILE_ROWS``, the last padded), as evenly as may be."""
    tiles = max(1, -(-block // MAX_TILE_ROWS))
    return tiles, max(1, -(-block // tiles))


class NumpyActor:
    """A plain MLP actor (``mlp_layout``) in numpy float32; call it with the observation
    groups (``{group: (R, dim) float32}``) for the actions ((R, 2) float32, before clipping).

    Args:
        groups: The observation groups, concatenated in this order.
        layers: Each linear layer's weight as (in, out), contiguous float32, and bias.
        activation: A key of ``ACTIVATIONS``.
        normalizer: The input's mean and ``std + eps``, or None.
    """

    def __init__(self, groups: tuple[str, ...], layers: list[tuple[Float32Array, Float32Array]],
                 activation: str, normalizer: tuple[Float32Array, Float32Array] | None) -> None:
        self.groups = groups
        self.layers = layers
        self.activation = ACTIVATIONS[activation]
        self.normalizer = normalizer

    def __call__(self, obs: Mapping[str, Float32Array], block: int | None = None
                 ) -> Float32Array:
        """The actions of ``obs``'s rows, taken as blocks of ``block`` rows (default: all of
        them), each multiplied as its own tiles (``tiling``): a row's bits depend on its block
        size and its place in its block only.

        Raises:
            ValueError: ``block`` does not divide the rows.
        """
        groups = self.groups
        x = (np.asarray(obs[groups[0]], dtype=np.float32) if len(groups) == 1 else
             np.concatenate([np.asarray(obs[g], dtype=np.float32) for g in groups], axis=-1))
        rows, width = x.shape
        block = rows if block is None else block
        if rows == 0:
            return np.zeros((0, 2), dtype=np.float32)
        if block < 1 or rows % block:
            raise ValueError(f"block must divide the {rows} rows, got {block}")
        if self.normalizer is not None:
            x = (x - self.normalizer[0]) / self.normalizer[1]
        tiles, tile = tiling(block)
        blocks = rows // block
        if tiles * tile != block:
            padded = np.zeros((blocks, tiles * tile, width), dtype=np.float32)
            padded[:, :block] = x.reshape(blocks, block, width)
            x = padded
        x = np.ascontiguousarray(x).reshape(blocks * tiles, tile, width)
        last = len(self.layers) - 1
        for i, (weight, bias) in enumerate(self.layers):
            x = np.matmul(x, weight)
            x += bias
            if i < last:
                x = self.activation(x)
        return np.ascontiguousarray(x.reshape(blocks, tiles * tile, -1)[:, :block]).reshape(
            rows, -1)


def numpy_actor(payload: Mapping[str, Any],
                example: Mapping[str, Float32Array]) -> NumpyActor | None:
    """The actor of ``payload`` (a policy file's dict, its weights numpy arrays or torch
    tensors) in numpy, or None when it is no plain MLP fitting ``example``'s groups
    (``trained_plain.mlp_layout``) or its activation has no numpy twin here (``gelu``)."""
    layout = mlp_layout(payload, example)
    if layout is None or layout.activation not in ACTIVATIONS:
        return None
    state = payload["actor_state_dict"]

    def array(key: str) -> Float32Array:
        value = state[key]
        if not isinstance(value, np.ndarray):  # a torch tensor (a payload held in memory)
            value = value.detach().cpu().numpy()
        return np.array(value, dtype=np.float32, order="C", copy=True)

    layers = [(np.ascontiguousarray(array(f"mlp.{2 * i}.weight").T),
               array(f"mlp.{2 * i}.bias")) for i in range(len(layout.dims) - 1)]
    normalizer = None
    if layout.normalize:
        normalizer = (array("obs_normalizer._mean"),
                      array("obs_normalizer._std") + np.float32(NORMALIZER_EPS))
    return NumpyActor(layout.groups, layers, layout.activation, normalizer)
