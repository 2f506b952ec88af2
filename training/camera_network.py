"""The camera actor's CNN: its rsl-rl config from ``TrainConfig.camera_channels``
(``cnn_config``), the checks of the camera settings (``check_camera``), and the channels-last
layout of ``TrainConfig.channels_last`` (``use_channels_last``).

A policy file stores the ``cnn_cfg`` it was trained with (``actor_cfg``) and its camera's
size (``env_config["camera"]``), so ``h2h_racing.policies.trained`` rebuilds any of these
networks, and renders images of the right size, without reading this module.
"""

from __future__ import annotations

from typing import Any

KERNELS = (5, 3, 3, 3)
"""Kernel size of each convolution (a 5 x 5 first, then 3 x 3): at most four layers."""
STRIDE = 2
"""Stride of every convolution: each halves the image (rounded up, zero padding)."""


def cnn_config(channels: tuple[int, ...]) -> dict[str, Any]:
    """rsl-rl's ``cnn_cfg`` for convolutions with ``channels`` output channels: stride 2 each,
    flattened at the end (no global pooling: where the lines and cars are in the image is what
    steers). ``(16, 32, 16)`` turns 64 x 48 into 8 x 6 x 16 = 768 features."""
    n = len(channels)
    return {"output_channels": [int(c) for c in channels], "kernel_size": list(KERNELS[:n]),
            "stride": [STRIDE] * n, "padding": "zeros"}


def check_camera(size: Any, channels: Any) -> None:
    """Raise ``ValueError`` unless ``size`` is (width, height) in pixels and ``channels`` 1-4
    channel counts, all positive ints."""
    if not (isinstance(size, (tuple, list)) and len(size) == 2
            and all(_positive_int(v) for v in size)):
        raise ValueError(f"TrainConfig.camera_size must be (width, height) in pixels, two ints "
                         f">= 1, got {size!r}")
    if not (isinstance(channels, (tuple, list)) and 1 <= len(channels) <= len(KERNELS)
            and all(_positive_int(c) for c in channels)):
        raise ValueError(f"TrainConfig.camera_channels must be 1 to {len(KERNELS)} channel "
                         f"counts (ints >= 1), one per convolution, e.g. [16, 32, 16] or "
                         f"[8, 16, 8]; got {channels!r}")


def _positive_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 1


def use_channels_last(model: Any) -> Any:
    """Convert ``model``'s 4-D weights (its convolutions') to channels-last in place and
    return it. Parameters keep their identity (``Module.to`` swaps their data), so an
    optimizer built on them still updates them. A greyscale image, (B, 1, H, W), is already
    channels-last in memory, so the convolutions' outputs follow the weights' layout."""
    import torch

    return model.to(memory_format=torch.channels_last)
