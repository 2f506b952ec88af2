"""The PettingZoo env's parked agents and DeepRacer reward calls, for one env copy.

With ``parked_agents`` a car whose race is over stays in ``env.agents`` (zero reward, actions
ignored) and reports its end only when the race ends, for trainers that need a fixed set of
agents. With a DeepRacer ``reward_function`` every car that raced during the step is rated
from its ``params``. ``RacingEnv`` (``h2h_racing.envs.parallel``) mixes ``EnvRewards`` in.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from h2h_racing.deepracer.params import ParamsBuilder


class EnvRewards:
    """Parked agents' rewards and ends, and DeepRacer reward calls, of ``RacingEnv`` (a
    mixin)."""

    def _park(self, active: list[str], terminations: dict[str, bool],
              truncations: dict[str, bool]) -> None:
        """Record how the cars that ended this step ended (parked_agents mode)."""
        for a in active:
            if terminations[a] or truncations[a]:
                self._ended[a] = terminations[a]

    def _parked_results(self, agents: list[str], active: list[str],
                        rewards_out: dict[str, float],
                        terminations: dict[str, bool], truncations: dict[str, bool],
                        ) -> tuple[dict[str, float], dict[str, bool], dict[str, bool]]:
        """Rewards and ends of a step with parked agents (parked_agents mode).

        A parked car gets 0.0 after the step that ended its race, and reports its end only
        when the race ends (no car racing): then every car is terminated or truncated as
        its own race ended.
        """
        over = not self._active
        ended = self._ended
        racing = set(active)
        for a in agents:
            if a not in racing:
                rewards_out[a] = 0.0
            if a in ended:
                if over:
                    terminations[a] = ended[a]
                    truncations[a] = not ended[a]
                else:
                    terminations[a] = truncations[a] = False
        if over:
            self.agents = []
        return rewards_out, terminations, truncations

    def _params_builder(self, reversed_: bool) -> ParamsBuilder:
        """The DeepRacer params builder of one driving direction (built once)."""
        builder = self._params_by_direction.get(reversed_)
        if builder is None:
            config = self.config
            builder = ParamsBuilder(
                self.core.track, config.car, config.num_cars,
                obstacle_size=(config.obstacle_length, config.obstacle_width),
                is_reversed=reversed_, camera_hfov_deg=config.camera.hfov_deg,
                camera_forward_m=config.camera.forward_m)
            self._params_by_direction[reversed_] = builder
        return builder

    def _deepracer_rewards(self, agents: list[str], racing: npt.NDArray[np.bool_],
                           steer: npt.NDArray[np.float64], events: Any,
                           ) -> tuple[list[float], list[dict[str, Any] | None]]:
        """Call the DeepRacer reward function of every car that raced during the step.

        Cars frozen by a penalty get 0.0 without a call (DeepRacer's PAUSE phase), and
        None as params.
        """
        assert self._deepracer is not None and self._params is not None
        n = self.config.num_cars
        if self.config.action_type == "discrete":
            # The action list's own numbers, not a round trip through radians.
            steering_deg = np.zeros(n)
            table = self.config.discrete_actions
            for a, choice in zip(agents, self._chosen):
                steering_deg[self._index[a]] = table[choice][0]
        else:
            steering_deg = np.degrees(steer)
        rated = [self._index[a] for a in agents if racing[self._index[a]]]
        params = self._params.from_core(self.core, steering_deg=steering_deg, events=events,
                                        cars=rated)
        reward = [0.0] * n
        for i in rated:
            reward[i] = self._deepracer(i, params[i])
        return reward, params
