"""AWS DeepRacer compatibility: reward-function ``params``, reward loading, model metadata.

- ``params.ParamsBuilder`` builds DeepRacer's 27-key ``params`` dict for each car from the
  core's arrays, with the semantics of the DeepRacer simulator's code (simapp).
- ``reward.DeepRacerReward`` loads a ``reward_function(params)`` once per car and checks
  what it returns.
- ``metadata.load_model_metadata`` turns a ``model_metadata.json`` into ``EnvConfig``
  overrides (action space, sensors, lidar).

The exact contract is recorded in the project's DeepRacer reference (§1 params, §2 actions).
"""

from __future__ import annotations

from h2h_racing.deepracer.metadata import load_model_metadata
from h2h_racing.deepracer.params import PARAM_KEYS, ParamsBuilder
from h2h_racing.deepracer.reward import DeepRacerReward, RewardFunctionError

__all__ = ["PARAM_KEYS", "DeepRacerReward", "ParamsBuilder", "RewardFunctionError",
           "load_model_metadata"]
