"""rsl-rl's PPO with the policy's standard deviation held in bounds (``BoundedStdPPO``,
``TrainConfig.max_std``) and with a behaviour-cloning step towards a scripted driver
(``ImitationPPO``, ``[imitation] coef``). rsl-rl builds them from the
``algorithm`` section's ``class_name`` (``TrainConfig.rsl_rl_dict``).
"""

from __future__ import annotations

import os
from typing import Any

os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")  # rsl-rl imports GitPython

from h2h_racing.common.extras import missing_extra  # noqa: E402

try:
    import torch  # noqa: E402
    from rsl_rl.algorithms import PPO  # noqa: E402
    from rsl_rl.modules.distribution import GaussianDistribution  # noqa: E402
except ImportError as _error:
    raise missing_extra("train", "training", _error) from None


class BoundedStdPPO(PPO):  # type: ignore[misc]
    """rsl-rl's PPO, with the actor's standard deviation projected into its distribution's
    ``std_range`` after every update (``TrainConfig.max_std``).

    rsl-rl's ``GaussianDistribution`` clamps the std it samples with, but not the parameter:
    the gradient is zero past the clamp, so a parameter that steps over the bound stays there
    (Adam's momentum carries it further) and the std can never shrink again. Projecting the
    parameter back keeps it on the bound, where the gradient flows.
    """

    def update(self) -> dict[str, float]:
        losses = super().update()
        project_std(self.get_policy())
        return losses


class ImitationPPO(BoundedStdPPO):
    """rsl-rl's PPO (with ``BoundedStdPPO``'s std projection) plus a behaviour-cloning step
    (``[imitation] coef``): after each PPO update, one pass over the rollout in
    ``num_mini_batches`` mini-batches of the loss ``imitation_coef * mean((mu(o) - a*)^2)``,
    where ``mu(o)`` is the actor's mean action and ``a*`` the scripted driver's action in the
    same state (the ``expert`` observation group the env adds). With equal standard
    deviations sigma, KL(N(a*, sigma) || N(mu, sigma)) = |mu - a*|^2 / (2 sigma^2), so this is
    AlphaStar's KL to a fixed teacher up to scale. It uses PPO's optimizer and learning rate
    (critic gradients stay None, so Adam leaves the critic alone).
    """

    def __init__(self, *args: Any, imitation_coef: float = 0.0, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.imitation_coef = imitation_coef

    def update(self) -> dict[str, float]:
        losses = super().update()
        losses["imitation"] = self.imitate()
        project_std(self.get_policy())
        return losses

    def imitate(self) -> float:
        """One behaviour-cloning pass over the last rollout; return its mean loss."""
        if self.imitation_coef == 0:
            return 0.0  # a step on a zero loss would still move the weights (Adam's momentum)
        # storage.clear() (at the end of PPO's update) only rewinds the write cursor: the
        # rollout's observations are still there.
        obs = self.storage.observations.flatten(0, 1)
        if "expert" not in obs.keys():
            raise ValueError("ImitationPPO needs the env's 'expert' observation group "
                             "(RacingVecEnv(expert=...); [imitation] driver)")
        actor = self.get_policy()
        rows = obs.batch_size[0]
        size = max(1, rows // self.num_mini_batches)
        order = torch.randperm(rows, device=self.device)
        total = 0.0
        for start in range(0, size * self.num_mini_batches, size):
            batch = obs[order[start:start + size]]
            loss = self.imitation_coef * (actor(batch) - batch["expert"]).pow(2).mean()
            self.optimizer.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(actor.parameters(), self.max_grad_norm)
            self.optimizer.step()
            total += loss.item()
        return total / self.num_mini_batches


def project_std(actor: Any) -> None:
    """Clamp ``actor``'s Gaussian std parameter into its distribution's ``std_range``."""
    dist = getattr(actor, "distribution", None)
    if not isinstance(dist, GaussianDistribution):
        return
    with torch.no_grad():
        if dist.std_type == "scalar":
            dist.std_param.clamp_(*dist.std_range)
        else:
            dist.log_std_param.clamp_(*dist.log_std_range)
