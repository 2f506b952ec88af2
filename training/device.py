"""The learner's torch device (``TrainConfig.device``): which names are allowed
(``check_device_name``) and whether this machine has it (``check_device_available``).

The env never runs on a GPU: it is numpy and numba on the CPU, and rsl-rl's runner moves its
observations to the learner's device once per step (``OnPolicyRunner.learn``).
"""

from __future__ import annotations

import re

DEVICES = ("cpu", "cuda")
"""Device names ``h2h-racing train --device`` takes (a config may also name ``cuda:<index>``)."""
_PATTERN = re.compile(r"cpu|cuda(:\d+)?")


def check_device_name(device: object) -> None:
    """Raise ``ValueError`` unless ``device`` is ``"cpu"``, ``"cuda"`` or ``"cuda:<index>"``."""
    if not (isinstance(device, str) and _PATTERN.fullmatch(device)):
        raise ValueError(f"TrainConfig.device must be 'cpu', 'cuda' or 'cuda:<index>', got "
                         f"{device!r}")


def check_device_available(device: str) -> None:
    """Raise ``ValueError`` (one line: what was asked, why it cannot run, what to do) when
    ``device`` is a CUDA device that torch cannot use on this machine."""
    check_device_name(device)
    if device == "cpu":
        return
    import torch

    if not torch.cuda.is_available():
        raise ValueError(f"--device {device}: torch.cuda.is_available() is False on this "
                         f"machine (torch {torch.__version__}, no usable CUDA GPU or a CPU-only "
                         f"build); train on the CPU with --device cpu (device = \"cpu\" in a "
                         f"config)")
    index = int(device.partition(":")[2] or 0)
    if index >= torch.cuda.device_count():
        raise ValueError(f"--device {device}: this machine has {torch.cuda.device_count()} "
                         f"CUDA device(s) (indices 0-{torch.cuda.device_count() - 1}); name one "
                         f"of those, or train on the CPU with --device cpu")
