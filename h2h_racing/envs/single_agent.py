"""A single-agent Gymnasium view of the race: one learner car, opponents driven inside.

>>> import gymnasium, h2h_racing
>>> env = gymnasium.make("h2h_racing/Race-v0", track="oval", opponents=["pure_pursuit"])
>>> obs, info = env.reset(seed=0)
>>> obs.shape
(33,)

The learner is ``car_0`` of a ``RacingEnv`` (the PettingZoo env) with ``1 + len(opponents)``
cars; the opponents are scripted drivers (``racing_line``, ``pure_pursuit``, ``blocker``,
``random``), shipped trained policies (``league_racer``, ...) or ``policy.pt`` paths, as
``h2h-racing race --drivers`` takes them, or driver objects (``reset(core)``,
``act(core, car)``). They read the simulation state, as in ``h2h-racing race``, and act on
every step while they race. The grid is drawn from the seed, so the learner starts in any
slot.

Spaces, reward and info are the learner's own in the PettingZoo env (see
``h2h_racing.envs.parallel``): ``Box(-1, 1, (2,))`` or ``Discrete(K)`` actions, the state vector
or a ``Dict`` of sensors, the built-in or DeepRacer reward, and ``info`` = the learner's per-car
info.

The episode ends for the learner as Gymnasium users expect: ``terminated`` when its car
finishes the lap target or retires (an infraction under ``rules="training"``), ``truncated``
when the race's time limit or ``max_cycles`` stops it. Opponents still racing then are
simply stopped by the next ``reset``. ``reset(seed=s)`` starts the race that
``parallel_env(...).reset(seed=s)`` starts (same grid, obstacles and bots), and seeds the
``random`` opponents, so the same seed gives the same episode for the same actions.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium
import numpy as np
import numpy.typing as npt

from h2h_racing.config.checks import check_seed
from h2h_racing.envs.parallel import RacingEnv
from h2h_racing.track.shape import Track

LEARNER = "car_0"
"""The learner's agent name in the wrapped PettingZoo env."""


class SingleAgentRaceEnv(gymnasium.Env):
    """One learner car against ``opponents`` (see the module docstring).

    Registered as ``"h2h_racing/Race-v0"``: ``gymnasium.make("h2h_racing/Race-v0", ...)``
    takes the same arguments.

    Args:
        track: Catalogue name, track file or ``Track``.
        opponents: Driver names or driver objects, one per opponent car; empty: alone.
        sensors: ``"state"`` or a sequence of ``"state"``, ``"camera"``, ``"lidar"`` (a
            ``Dict`` observation unless it is just ``("state",)``).
        race_type: ``"time_trial"``, ``"head_to_head"``, ``"object_avoidance"`` or
            ``"head_to_bot"``; None: ``time_trial`` alone, ``head_to_head`` with opponents.
        rules: None (the race type's preset), ``"race"``, ``"training"`` or a ``RaceRules``.
        render_mode: None or ``"rgb_array"`` (the top-down spectator frame).
        reward_function: A DeepRacer reward function (file path or callable), as in
            ``h2h_racing.parallel_env``.
        **config: Further ``EnvConfig`` fields (``action_type``, ``num_obstacles``, ...).

    Raises:
        ValueError: An unknown driver, sensor, race type or config value.
        TypeError: ``opponents`` is not a sequence of names or drivers.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": RacingEnv.metadata["render_fps"]}

    def __init__(self, track: str | Track = "speedway", opponents: Sequence[Any] = (),
                 sensors: str | Sequence[str] = ("state",), race_type: str | None = None,
                 rules: Any = None, render_mode: str | None = None,
                 reward_function: Any = None, **config: Any) -> None:
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be None or one of "
                             f"{self.metadata['render_modes']}, got {render_mode!r}")
        if isinstance(opponents, (str, bytes)) or not isinstance(opponents, Sequence):
            raise TypeError(f"opponents must be a list of driver names or drivers, e.g. "
                            f"['racing_line', 'pure_pursuit'], got {opponents!r}")
        if race_type is None:
            race_type = "head_to_head" if opponents else "time_trial"
        # JSON/YAML configs give lists, and a lone sensor name is a natural shorthand.
        sensors = (sensors,) if isinstance(sensors, str) else tuple(sensors)
        self.race = RacingEnv(track=track, num_cars=1 + len(opponents), race_type=race_type,
                              rules=rules, render_mode=render_mode,
                              reward_function=reward_function, sensors=sensors, **config)
        """The wrapped PettingZoo env (``race.core`` is the simulation)."""
        self.opponents = [_driver(d, car) for car, d in enumerate(opponents, start=1)]
        """The opponents' drivers; opponent i drives ``car_{i + 1}``."""
        self.observation_space = self.race.observation_space(LEARNER)
        self.action_space = self.race.action_space(LEARNER)
        self.render_mode = render_mode
        self._discrete = self.race.config.action_type == "discrete"

    @property
    def core(self) -> Any:
        """The simulation core of the race (E = 1)."""
        return self.race.core

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None,
              ) -> tuple[Any, dict[str, Any]]:
        """Start a new race (``options`` as in ``RacingEnv.reset``, e.g. ``{"grid": [...]}``).

        Returns:
            ``(observation, info)`` of the learner.
        """
        check_seed(seed)
        super().reset(seed=seed)
        obs, infos = self.race.reset(seed=seed, options=options)
        if seed is not None:
            # Drivers with a generator of their own (``random``) restart from the seed too.
            for driver in self.opponents:
                if isinstance(getattr(driver, "rng", None), np.random.Generator):
                    driver.rng = np.random.default_rng(self.np_random.integers(2**63))
        for driver in self.opponents:
            driver.reset(self.race.core)
        return obs[LEARNER], infos[LEARNER]

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Drive the learner with ``action`` and every racing opponent with its driver.

        Returns:
            ``(observation, reward, terminated, truncated, info)`` of the learner.

        Raises:
            RuntimeError: ``reset`` was not called, or the learner's episode is over.
            ValueError: An invalid action (NaN/inf, wrong shape, bad index).
        """
        race = self.race
        if LEARNER not in race.agents:
            raise RuntimeError("the learner's episode is over (or reset() was never called); "
                               "call reset()")
        actions = {LEARNER: action}
        live = race.agents
        for car, driver in enumerate(self.opponents, start=1):
            agent = race.possible_agents[car]
            if agent in live:
                actions[agent] = self._opponent_action(driver, car)
        obs, rewards, terminations, truncations, infos = race.step(actions)
        return (obs[LEARNER], float(rewards[LEARNER]), bool(terminations[LEARNER]),
                bool(truncations[LEARNER]), infos[LEARNER])

    def _opponent_action(self, driver: Any, car: int) -> Any:
        value = driver.act(self.race.core, car)[0]
        if not self._discrete:
            return value
        # Drivers output [-1, 1]^2; a discrete action space takes the nearest action.
        from h2h_racing.deepracer.metadata import nearest_discrete

        return int(nearest_discrete(self.race.config, value))

    def render(self) -> npt.NDArray[np.uint8] | None:
        """The top-down spectator frame (H, W, 3) uint8 with ``render_mode="rgb_array"``."""
        return self.race.render()

    def close(self) -> None:
        """Release the renderer."""
        self.race.close()

    def results(self) -> list[dict[str, Any]]:
        """The race results so far, in race order (``car_0`` is the learner)."""
        return self.race.results()


def _driver(driver: Any, car: int) -> Any:
    """A driver object for a name (``make_driver``, seeded by the car) or the object itself."""
    if isinstance(driver, str):
        from h2h_racing.policies import make_driver

        return make_driver(driver, seed=car)
    if callable(getattr(driver, "act", None)) and callable(getattr(driver, "reset", None)):
        return driver
    raise TypeError(f"opponent {car - 1} must be a driver name (e.g. 'racing_line', a shipped "
                    f"policy or a policy.pt path) or an object with reset(core) and "
                    f"act(core, car); got {driver!r}")
