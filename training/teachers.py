"""Distillation teachers (``[imitation] teacher``): a policy file's actor with its actions
clipped (``ClippedTeacher``), a scripted driver read from the env's ``expert`` observation
group (``ScriptedTeacher``), and the check that a teacher's policy file fits a run
(``load_teacher``). rsl-rl builds the teachers from their ``class_name``
(``TrainConfig.rsl_rl_dict``).
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")  # rsl-rl imports GitPython

from h2h_racing.common.extras import missing_extra  # noqa: E402

try:
    import torch  # noqa: E402
    from rsl_rl.models import MLPModel  # noqa: E402
except ImportError as _error:
    raise missing_extra("train", "training", _error) from None

if TYPE_CHECKING:
    from h2h_racing.training.config import TrainConfig


class ClippedTeacher(MLPModel):  # type: ignore[misc]
    """A distillation teacher: the policy file's MLP actor with its actions clipped to [-1, 1].

    The env clips actions to [-1, 1], so PPO's Gaussian means drift past the bounds at no cost
    (a trained actor's raw steering can read 30 where the env applies 1). Regressing a student
    onto the raw means would spend its loss on those excursions; the clipped actions are what
    the teacher drives.

    With ``pace`` < 1 the speed label commands ``pace`` times the teacher's commanded speed:
    with the action's affine map ``speed = mid + a * half`` [m/s] (``EnvConfig.action_affine``),
    ``a' = (pace * (mid + a * half) - mid) / half``. The student then learns to drive below the
    teacher's limit of grip, where its imitation errors cost less (``[imitation] pace``).
    """

    def __init__(self, *args: Any, pace: float = 1.0, speed_mid: float = 0.0,
                 speed_half: float = 1.0, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.pace, self.speed_mid, self.speed_half = pace, speed_mid, speed_half

    def forward(self, *args: Any, **kwargs: Any) -> torch.Tensor:
        actions = super().forward(*args, **kwargs).clamp(-1.0, 1.0)
        if self.pace == 1.0:
            return actions
        speed = self.speed_mid + actions[..., 1:] * self.speed_half
        label = (self.pace * speed - self.speed_mid) / self.speed_half
        return torch.cat([actions[..., :1], label.clamp(-1.0, 1.0)], dim=-1)


class ScriptedTeacher(torch.nn.Module):
    """A distillation teacher that is a scripted driver: it returns the ``expert`` observation
    group (``RacingVecEnv(expert=...)``: the driver's action in the learner's state), so
    rsl-rl's ``Distillation`` regresses the student onto the driver's actions. No weights.

    Built by rsl-rl as ``ScriptedTeacher(obs, obs_groups, "teacher", num_actions)``; the
    ``teacher`` observation set must be exactly ``["expert"]``.
    """

    is_recurrent = False

    def __init__(self, obs: Any, obs_groups: dict[str, list[str]], obs_set: str,
                 output_dim: int, **unused: Any) -> None:
        super().__init__()
        if obs_groups.get(obs_set) != ["expert"] or "expert" not in obs.keys():
            raise ValueError(f"ScriptedTeacher reads the env's 'expert' observation group "
                             f"(RacingVecEnv(expert=...)); got obs_groups[{obs_set!r}] = "
                             f"{obs_groups.get(obs_set)!r} and groups {list(obs.keys())}")
        if obs["expert"].shape[-1] != output_dim:
            raise ValueError(f"the expert group has {obs['expert'].shape[-1]} actions, the "
                             f"student {output_dim}")

    def forward(self, obs: Any, *args: Any, **kwargs: Any) -> torch.Tensor:
        return obs["expert"]

    def reset(self, dones: Any = None, hidden_state: Any = None) -> None:
        """Stateless (rsl-rl resets recurrent models through this)."""

    def get_hidden_state(self) -> None:
        return None

    def detach_hidden_state(self, dones: Any = None) -> None:
        """Stateless."""


def load_teacher(config: TrainConfig) -> dict[str, Any]:
    """Load ``config.imitation.teacher``'s policy dict and check that it can teach in
    ``config``'s env: a state-observation policy whose state vector has this env's layout.

    Raises:
        FileNotFoundError, ValueError: With what is wrong and what to do.
    """
    from h2h_racing.policies.trained import load_policy_payload

    teacher = config.imitation.teacher
    payload = load_policy_payload(teacher)  # type: ignore[arg-type]
    if payload["observations"] != "state":
        raise ValueError(f"teacher {teacher!r} drives from {payload['observations']!r} "
                         "observations; a teacher must be a state-observation policy")
    env = config.env_config()
    for key in ("opponent_slots", "obstacle_slots"):
        if payload["env_config"][key] != getattr(env, key):
            raise ValueError(f"teacher {teacher!r} was trained with {key}="
                             f"{payload['env_config'][key]}, this run's env has {key}="
                             f"{getattr(env, key)}: its state vector would not fit")
    return payload
