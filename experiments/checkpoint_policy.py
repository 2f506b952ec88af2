"""A ``policy.pt`` from one of a run's rsl-rl checkpoints, to evaluate a run before it ends.

    python experiments/checkpoint_policy.py CONFIG.toml runs/RUN/model_N.pt OUT.pt

CONFIG is the run's config (the policy file keeps it, as ``train`` writes it).
"""

from __future__ import annotations

import dataclasses
import sys

from h2h_racing.training.config import TrainConfig
import torch

from h2h_racing.training.policy_file import load_runner_state, save_policy
from h2h_racing.training.train import make_runner


def main(config_path: str, checkpoint: str, out: str) -> None:
    config = TrainConfig.from_toml(config_path)
    # A few env copies: the runner only needs the shapes.
    small = dataclasses.replace(config, num_envs=4, init=None, init_fresh_slots=False)
    runner = make_runner(small, small.make_env())
    state = torch.load(checkpoint, weights_only=True)
    if "student_state_dict" in state:  # a distillation: rsl-rl's Distillation.load
        runner.alg.load(state, None, True)
    else:
        load_runner_state(runner, checkpoint)
    save_policy(runner, config, out)
    print(f"{checkpoint} -> {out}")


if __name__ == "__main__":
    main(*sys.argv[1:])
