"""A ``policy.pt`` whose student weights are the mean of several of a distillation run's
checkpoints (stochastic weight averaging, Izmailov et al. 2018).

    python experiments/camera/average_checkpoints.py CONFIG.toml OUT.pt runs/RUN/model_N.pt ...

Why: a procedural run trains on one track for ``[procedural] every`` iterations, and its
camera students' laps swing from checkpoint to checkpoint with the last tracks seen (a track
at 100 % at one checkpoint, 30 % 50 iterations later). The mean of checkpoints along the
run sits between those swings. Every floating-point tensor of ``student_state_dict`` is
averaged (the observation normaliser's running mean and variance too); integer ones, as the
normaliser's count, are the last checkpoint's. CONFIG is the run's config, as for
``experiments/checkpoint_policy.py``.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from checkpoint_policy import main as checkpoint_policy  # noqa: E402


def average(checkpoints: list[str]) -> dict:
    """The last checkpoint with its student's float tensors replaced by their mean."""
    states = [torch.load(path, weights_only=True) for path in checkpoints]
    merged = states[-1]
    for key, value in merged["student_state_dict"].items():
        if value.is_floating_point():
            merged["student_state_dict"][key] = torch.stack(
                [s["student_state_dict"][key] for s in states]).mean(dim=0)
    return merged


def main(config: str, out: str, *checkpoints: str) -> None:
    if len(checkpoints) < 2:
        raise SystemExit("give at least two checkpoints to average")
    with tempfile.TemporaryDirectory() as folder:
        path = str(Path(folder) / "model_mean.pt")
        torch.save(average(list(checkpoints)), path)
        checkpoint_policy(config, path, out)


if __name__ == "__main__":
    main(*sys.argv[1:])
