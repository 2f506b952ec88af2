"""What a learner imitates: ``ImitationConfig``, the ``[imitation]`` table of a training run
(``TrainConfig.imitation``) and of a league (``LeagueConfig.imitation``).

Two ways, both labelled by a teacher's actions in the learner's own states: a ``teacher``
replaces PPO by rsl-rl's ``Distillation`` (``h2h_racing.training.teachers``); a ``driver``
with a ``coef`` adds a behaviour-cloning step to PPO (``ImitationPPO``). A scripted teacher's
or driver's actions reach the learner through the env's ``expert`` observation group.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from h2h_racing.policies.registry import parse_driver_spec
from h2h_racing.policies.scripted import TEACHERS

SCRIPTED_TEACHERS = TEACHERS
"""Scripted drivers a ``teacher`` or ``driver`` can name, with any of their settings
(``racing_line:grip_factor=0.7``; their actions reach the learner through the env's ``expert``
observation group)."""


def _driver_name(spec: Any, key: str) -> str:
    """The driver name of ``[imitation]``'s ``key`` (``racing_line:grip_factor=0.7`` ->
    ``racing_line``), its spec checked (``parse_driver_spec``)."""
    try:
        return parse_driver_spec(spec).name
    except ValueError as err:
        raise ValueError(f"[imitation] {key}: {err}") from None


@dataclass(frozen=True, kw_only=True)
class ImitationConfig:
    """``[imitation]``: what the learner imitates (nothing by default: plain PPO)."""

    teacher: str | None = None
    """What to imitate with rsl-rl's ``Distillation`` instead of training with PPO: a
    state-observation policy (shipped name or ``policy.pt``) distilled into a camera actor,
    or a scripted driver (``SCRIPTED_TEACHERS``, e.g. ``"racing_line"``, with any settings:
    ``"racing_line:grip_factor=0.7"``) imitated by any actor. The student drives (DAgger: it learns on the states its own driving reaches) and is
    regressed onto the teacher's actions there. The fast way to a camera policy on a CPU (no
    critic, one pass per rollout), and a scripted teacher brings what it knows of every track
    (``racing_line`` laps every shipped and generated track) to a state policy before PPO
    fine-tunes it (``init``), as AlphaStar's agents start from supervised learning. None
    trains with PPO."""
    options: dict[str, float] = field(default_factory=dict)
    """Constructor arguments of the scripted driver that labels actions (a scripted
    ``teacher`` or the ``driver``), e.g. ``{"grip_factor": 0.6, "margin": 0.2}`` for a
    ``RacingLine`` that corners at 60 % of the grip and keeps 0.2 m from the borders (the same
    as ``teacher = "racing_line:grip_factor=0.6:margin=0.2"``; a setting goes in one of the
    two, not both)."""
    pace: float = 1.0
    """Share of a policy ``teacher``'s commanded speed that its labels command
    (``ClippedTeacher``), in [0.5, 1]: 0.95 teaches the student to drive 5 % below the
    teacher's speed everywhere, off the limit of grip where its imitation errors put it off
    the track. 1 labels the teacher's own actions. In ``camera_generalist``'s last step 0.95
    took ``grand_loop`` from 45-55 % of laps to 95-100 % on three seeds, for laps 4-6 % slower
    (``experiments/camera/README.md``)."""
    driver: str | None = None
    """A scripted driver (``SCRIPTED_TEACHERS``, with any settings) that PPO's actor is kept
    near with ``coef``."""
    coef: float = 0.0
    """Weight of a behaviour-cloning term in PPO (``ImitationPPO``): after each PPO update the
    actor's mean actions in the rollout's states are regressed (MSE, one pass over the
    mini-batches) onto the ``driver``'s actions in those states, as AlphaStar's agents are
    kept near the supervised policy by a KL term (for Gaussians of equal std, a squared
    distance of the means): reinforcement learning improves on the driver without forgetting
    what it does well. 0 turns it off."""

    def __post_init__(self) -> None:
        for key in ("teacher", "driver"):
            if getattr(self, key) is not None:
                _driver_name(getattr(self, key), key)
        if not (isinstance(self.coef, (int, float)) and not isinstance(self.coef, bool)
                and self.coef >= 0):
            raise ValueError(f"[imitation] coef must be a number >= 0, got {self.coef!r}")
        if (isinstance(self.pace, bool) or not isinstance(self.pace, (int, float))
                or not 0.5 <= self.pace <= 1.0):
            raise ValueError(f"[imitation] pace must be a number in [0.5, 1] (the share of "
                             f"the teacher's commanded speed its labels command), got "
                             f"{self.pace!r}")
        if self.pace != 1.0 and (self.teacher is None or self.scripted_teacher):
            raise ValueError(f"[imitation] pace scales a policy teacher's speed labels, but "
                             f"teacher is {self.teacher!r}; name a policy (teacher = "
                             f"\"ppo_generalist\"), or slow a scripted driver with its options")
        if self.driver is not None and _driver_name(self.driver, "driver") not in TEACHERS:
            raise ValueError(f"[imitation] driver must be one of {SCRIPTED_TEACHERS} (with any "
                             f"settings, e.g. racing_line:grip_factor=0.7), got "
                             f"{self.driver!r}")
        if self.coef and (self.driver is None or self.teacher is not None):
            raise ValueError(f"[imitation] coef keeps PPO's actor near a scripted driver: name "
                             f"it in driver ({', '.join(SCRIPTED_TEACHERS)}) and leave teacher "
                             f"unset (a teacher replaces PPO by imitation)")
        if self.options:
            if not self.scripted_teacher and self.driver is None:
                raise ValueError(f"[imitation] options are arguments of a scripted teacher or "
                                 f"driver ({', '.join(SCRIPTED_TEACHERS)}), but teacher is "
                                 f"{self.teacher!r}")
            self.expert()

    @property
    def scripted_teacher(self) -> bool:
        """Whether ``teacher`` names a scripted driver (imitated through the ``expert`` group)."""
        return (self.teacher is not None
                and _driver_name(self.teacher, "teacher") in SCRIPTED_TEACHERS)

    def expert(self) -> Any:
        """The scripted driver that labels actions (the env's ``expert`` group): a scripted
        ``teacher``, else the ``driver``, with ``options``; or None."""
        name = self.teacher if self.scripted_teacher else self.driver
        if name is None:
            return None
        from h2h_racing.policies import make_driver

        try:
            return make_driver(name, **self.options)
        except TypeError as err:
            raise ValueError(f"[imitation] options {self.options!r} do not fit the {name!r} "
                             f"driver: {err}") from None
        except ValueError as err:
            raise ValueError(f"[imitation] {err}") from None
