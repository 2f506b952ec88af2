"""DeepRacer's evaluation episodes between training iterations, for the simtrace's metrics.

DeepRacer's training alternates two phases on its first rollout worker: the iteration's
training episodes, then ``MIN_EVAL_TRIALS`` (5, DeepRacer-for-Cloud's
``DR_TRAIN_MIN_EVAL_TRIALS``) evaluation episodes of the same checkpoint (simapp
``rollout_worker.py``), which go into the same ``TrainingMetrics.json`` with ``phase:
"evaluation"``. The community's training-progress plot (deepracer-utils'
``TrainingMetrics.plotProgress()``) draws their mean completion per iteration beside the
training episodes', and fails on a metrics file without them.

``SimtraceEvaluations`` runs those episodes for ``train --simtrace N``, with DeepRacer's rules
for them:

- the first logged env copy (DRfC's worker 0) evaluates, once each of its training
  iterations (``SimtraceWriter.episodes_per_iteration`` episodes) ends, before its next
  training episode;
- ``trials`` episodes (5), under the training rules and in the training world (the same race
  type, boxes, bots, opponents and reward, which gives ``reward_score``): each ends at the
  first lap or infraction, as a training episode does;
- all from the start of the worker's next training episode (DeepRacer does not advance the
  start in the evaluation phase), with the same grid;
- the policy acts deterministically (its mean action; DeepRacer's evaluation takes the most
  likely action);
- DeepRacer keeps evaluating while it waits for the trainer's next checkpoint, so DRfC logs
  often hold more than 5; here the trainer does not run meanwhile, so there are exactly 5.

The episodes run at once, as the env copies of a small ``RacingVecEnv`` of their own (its
``restart`` puts every copy on the grid), and are measured by a ``SimtraceWriter`` that writes
no files, so that their ``completion_percentage``, ``episode_status`` and times are computed
as the training episodes' are. With a deterministic policy on a deterministic simulator the 5
episodes are the same episode unless boxes or bots are drawn at random per copy; DeepRacer's
differ a little through Gazebo's noise.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
import torch

from h2h_racing.deepracer.logs import SimtraceWriter
from h2h_racing.training.vec_env import RacingVecEnv

if TYPE_CHECKING:
    from h2h_racing.training.config import TrainConfig

MIN_EVAL_TRIALS = 5
"""DeepRacer's evaluation episodes per training iteration (simapp ``MIN_EVAL_TRIALS``)."""


class SimtraceEvaluations:
    """Run DeepRacer's evaluation episodes of a policy, all at once, from a given grid.

    Args:
        env: The training env (its config, track, learners, observations, reward function and
            ``random_starts`` are copied).
        policy: Returns the actor to evaluate, called at every evaluation (the actor maps
            an observation ``TensorDict`` to actions and returns its mean action when called
            without ``stochastic_output``, as rsl-rl's models do).
        trials: Evaluation episodes per iteration (DeepRacer's ``MIN_EVAL_TRIALS``).
        opponent: Driver of the cars that are not learners (a driver name or object; None
            when every car is a learner).
        seed: Seed of the evaluation env (boxes and bots drawn at random, start redraws).
        device: Torch device of the actor.

    Raises:
        ValueError: ``trials`` is not an int >= 1.
    """

    def __init__(self, env: RacingVecEnv, policy: Callable[[], Any],
                 trials: int = MIN_EVAL_TRIALS, opponent: str | Any | None = None,
                 seed: int = 0, device: str = "cpu") -> None:
        if not isinstance(trials, int) or isinstance(trials, bool) or trials < 1:
            raise ValueError(f"trials must be an int >= 1, got {trials!r}")
        self.trials = trials
        self.policy = policy
        self.device = device
        self.env = RacingVecEnv(
            env.config, num_envs=trials, learners=env.learners, opponent=opponent,
            observations=env.observation_kind, seed=seed, track=env.track,
            random_starts=env.random_starts, reward_function=env.reward_function,
            reward_time_limit=env.reward_time_limit)
        self.recorder = SimtraceWriter(None, env.config, env.track, envs=range(trials),
                                       cars=range(env.learners))
        self.env.simtrace = self.recorder

    @classmethod
    def for_run(cls, config: TrainConfig, env: RacingVecEnv, runner: Any) -> SimtraceEvaluations:
        """The evaluations of a ``train`` run: ``config.simtrace_eval_trials`` episodes of
        ``runner``'s actor (PPO's, or the distillation's student), against the opponent of
        env copy 0."""
        names = config.opponents()
        learners = config.num_cars if config.learners is None else config.learners
        opponent = names[0] if names and learners < config.num_cars else None
        # A seed of its own, so that the training env's draws stay as they were without it.
        seed = int(np.random.SeedSequence([config.seed, 39]).generate_state(1)[0])
        return cls(env, lambda: runner.alg.get_policy(), trials=config.simtrace_eval_trials,
                   opponent=opponent, seed=seed, device=config.device)

    def run(self, start: float, slots: npt.ArrayLike | None = None) -> list[list[dict[str, Any]]]:
        """Run the episodes from grid slot 0 at ``start`` [m] with the cars on ``slots`` (N,);
        return each episode's metrics entry per learner car, ``[trial][car]``
        (``SimtraceWriter.log_evaluation`` takes them)."""
        env, recorder = self.env, self.recorder
        env.restart(start, slots)
        recorder.clear()
        recorder.start(env.core)
        actor = self.policy()
        with torch.inference_mode():
            obs = env.get_observations()
            # Every copy's first episode ends within the episode's step limit.
            for _ in range(env.max_episode_length + 1):
                obs, _, _, _ = env.step(actor(obs.to(self.device)))
                done = recorder.first_episodes()
                if done is not None:
                    return done
        raise RuntimeError("an evaluation episode outlasted the episode's step limit")
