"""The ``[ppo]`` and ``[distill]`` tables of a training config (``TrainConfig.ppo`` and
``.distill``): rsl-rl's ``algorithm`` sections for PPO and for distillation, checked.
``h2h_racing.training.config`` gives both names too."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass


@dataclass(frozen=True, kw_only=True)
class PPOConfig:
    """PPO hyper-parameters (rsl-rl's ``algorithm`` section)."""

    learning_rate: float = 1e-3
    """Adam learning rate (adapted by the KL schedule)."""
    num_learning_epochs: int = 4
    """Passes over each rollout."""
    num_mini_batches: int = 4
    """Mini-batches per pass."""
    clip_param: float = 0.2
    """PPO ratio clip."""
    gamma: float = 0.995
    """Discount per step (1/15 s): a horizon of about 13 s."""
    lam: float = 0.95
    """GAE lambda."""
    entropy_coef: float = 0.003
    """Entropy bonus (0 turns it off)."""
    desired_kl: float = 0.01
    """Target KL of the adaptive learning-rate schedule."""
    max_grad_norm: float = 1.0
    """Gradient clipping."""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name == "entropy_coef":
                if not isinstance(value, (int, float)) or value < 0:
                    raise ValueError(f"PPOConfig.entropy_coef must be a number >= 0, got "
                                     f"{value!r}")
            elif not isinstance(value, (int, float)) or value <= 0:
                raise ValueError(f"PPOConfig.{f.name} must be a number > 0, got {value!r}")


@dataclass(frozen=True, kw_only=True)
class DistillConfig:
    """Distillation hyper-parameters (rsl-rl's ``Distillation`` ``algorithm`` section)."""

    learning_rate: float = 1e-3
    """Adam learning rate (fixed)."""
    num_learning_epochs: int = 1
    """Passes over each rollout."""
    gradient_length: int = 1
    """Rollout steps whose losses are summed per gradient step (a divisor of
    ``num_steps_per_env``, or the last steps of each pass are never learned from). Summing
    only matters for recurrent students (backpropagation through time); for these
    feed-forward ones 1 gives a gradient step per rollout step (a batch of ``num_envs``
    samples) for the same compute."""
    max_grad_norm: float = 1.0
    """Gradient clipping."""
    student_std: float = 0.1
    """Standard deviation of the student's driving noise during rollouts (actions in
    [-1, 1]; not learned): it visits states a little off the teacher's line, so that the
    student learns to come back."""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if not isinstance(value, (int, float)) or value <= 0:
                raise ValueError(f"DistillConfig.{f.name} must be a number > 0, got {value!r}")
        for name in ("num_learning_epochs", "gradient_length"):
            if not isinstance(getattr(self, name), int):
                raise ValueError(f"DistillConfig.{name} must be an int, got "
                                 f"{getattr(self, name)!r}")
