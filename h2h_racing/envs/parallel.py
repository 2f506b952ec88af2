"""# h2h_racing_v4: head-to-head racing of 1/18-scale cars

| | |
|---|---|
| Import | `import h2h_racing; env = h2h_racing.parallel_env(track="speedway", num_cars=2)` |
| API | PettingZoo `ParallelEnv` (`h2h_racing.env(...)` gives the AEC view) |
| Agents | `car_0` ... `car_{N-1}` (N = `num_cars`, 1 to 16) |
| Action space (continuous) | `Box(-1, 1, (2,), float32)`: `[steer, speed]` |
| Action space (discrete) | `Discrete(K)`: index into `discrete_actions` (steering deg, speed m/s) |
| Observation space | `Box(-5, 5, (F,), float32)`, F = 19 + 4 x opponent_slots + 3 x obstacle_slots (33 by default); with `sensors=(...)` a `Dict` of `state`, `camera` `Box(0, 255, (120, 160, 1), uint8)` and `lidar` `Box(0.15, 1.0, (64,), float32)` |
| Step | 1/15 s of simulated time (DeepRacer's rate), 4 physics sub-steps |
| Render modes | `rgb_array` (top-down spectator frame; observations never read it) |

Several cars race on a DeepRacer-style track (no walls; a car is off track when all four
wheels leave the surface). Cars are boxes of 0.32 x 0.20 m with a dynamic single-track
model (tyre slip, friction limit); contacts between cars, with box obstacles and with bot
cars are physical (pymunk), so cars bump, push and block one another.

## Actions
Continuous: `steer` in [-1, 1] maps linearly to [`min_steer_deg`, `max_steer_deg`]
(default [-30, 30]) degrees (positive = left);
`speed` in [-1, 1] maps linearly to [`min_speed`, `max_speed`] m/s (default 0.5 to 4).
The speed is a command: a speed controller reaches it with the car's acceleration limits,
as on the real car. Finite values outside [-1, 1] are clipped; NaN or inf raise
`ValueError`. Discrete: an integer index into `discrete_actions`, a tuple of
(steering angle in degrees, speed in m/s); out-of-range indices raise `ValueError`.

## Observations
`sensors=("state",)` (default): a normalised state vector per car (see
`h2h_racing.sensors.state` for the exact layout): speed, sideslip, yaw rate, steering,
lateral offset, heading error, curvature look-ahead up to 5 m, track half-widths, race
position, penalty flag, and for the nearest opponents their track-relative gap, lateral
offset and relative speed, and for the nearest obstacles from 0.5 m behind to 5 m ahead
(so a box beside the car stays in view until the car is past it) their gap and offset. Bot
cars are opponents here: the `opponent_slots` take the nearest of the other cars and the bots alike (a bot moves, so it
needs the speed feature the obstacle slots lack), so a learner in `head_to_bot` sees them
without extra slots; raise `opponent_slots` with many bots.

Any other choice, e.g. `sensors=("camera", "lidar", "state")` (any sequence of names, a list
too), gives a `Dict` with those keys:
- `camera`: DeepRacer's front camera (0.13 m high, 0.145 m ahead, pitched down 15 deg, 64.7 deg
  horizontal field of view), 160 x 120 greyscale uint8 by default, shape (H, W, C) with
  C = cameras x frame_stack (`camera=CameraConfig(stereo=True, frame_stack=4, ...)`); it shows
  the track with its painted lines, the floor, the horizon, other cars, bot cars (all in one
  shade of their own) and obstacles as shaded 3-D boxes (see `h2h_racing.sensors.camera`);
- `lidar`: 64 ranges over +-150 deg in [0.15, max_range] m (1.0 by default, up to 12), seeing
  cars, bot cars and obstacles; optional Gaussian noise (seeded from the env's seed); or DeepRacer's
  `SECTOR_LIDAR` (8 binary sectors within 0.5 m) with `lidar=LidarConfig(mode="sector_lidar")`.
Sensors read the simulation state only, never the spectator renderer.

## Rewards
The weighted sum of these terms (weights in `RewardConfig`; each weighted term is also in
`infos[agent]["reward_<term>"]`):

| term | value | default weight |
|---|---|---|
| progress | metres of centre-line progress this step | 1.0 |
| speed | forward speed while racing [m/s] | 0.0 |
| off_track | 1 on the step the car goes off track | -5.0 |
| crash | 1 when judged at fault in a contact (the car behind, hitting an obstacle, or running into a bot from behind) | -5.0 |
| contact | 1 on the step of a new contact, at fault or not (a cost for being run into as well: the at-fault rule alone pays a car for braking in front of a follower) | 0.0 |
| overtake | cars passed on track minus times passed | 1.0 |
| lap | 1 per completed lap | 0.0 |
| time | 1 per step while racing | 0.0 |

### DeepRacer reward functions
`reward_function="path/to/reward.py"` (or a callable `f(params)`) replaces the reward above:
each car's reward is `float(reward_function(params))` from the first step on (`params["steps"]
== 1.0`), with DeepRacer's 27-key `params` (`h2h_racing.deepracer.params`: the model point
0.14 m ahead of the car, progress relative to the episode's start, commanded speed and
steering, the obstacles, the bot cars and the other cars as `objects_*`, in that order; with
bots every `objects_speed` is `bot_speed`, as in DeepRacer). A file is loaded once per car, so
module-level state is per car; a callable is shared. A car frozen by a penalty gets 0.0
without a call. The function gets a deep copy; with `info_level="full"`,
`infos[agent]["deepracer_params"]` holds the params of that step (None when the car was not
rated); the `reward_<term>` infos still hold the built-in terms. An exception, a non-number, NaN or inf raises `RewardFunctionError`
naming the file, car, step and params; a reward outside +-1e5 warns once per car.
`h2h_racing.deepracer.load_model_metadata("model_metadata.json")` gives the matching action
space and sensors as keyword overrides.

## Race rules, termination and truncation
Rules are `RaceRules` (presets by `race_type`; `rules="training"` or `"race"`):
- infractions: off track (all four wheels off), crash at fault, reversed (progress falling
  for 15 steps), immobilised (not moving for 15 steps);
- `rules="race"` (default): an infraction freezes the car for a penalty (5 s by default)
  while the clock runs, then puts it back on the nearest lane at its last valid progress;
- `rules="training"`: an infraction ends that car's episode (**terminated**);
- a car that completes the lap target has finished (**terminated**); its car is parked
  off the track;
- the race time limit and `max_cycles` end the episode of every car still racing
  (**truncated**).
Finished and retired cars leave `env.agents` on the step that ends them. Actions for cars
no longer in `env.agents` are ignored (a trainer may send one action per car on every step);
a missing action of a racing car, an unknown agent name or an invalid value raises
`ValueError`.

`parked_agents=True` keeps finished and retired cars in `env.agents` as *parked agents* until
the race ends (every car finished, retired or stopped by the time limit), for trainers that
need a fixed set of agents (SuperSuit's vector envs, SB3): a parked car still gets an
observation and an info (`parked` True) every step, its reward is 0.0, its actions are
ignored, and it reports `terminated` (finished or retired) or `truncated` (stopped) only on
the step that ends the race, together with every other car; then `env.agents` is empty.

Presets: `head_to_head` (3 laps, total time, 5 s penalties, 180 s limit), `time_trial`
(4 minutes, best valid lap, a lap with more than 3 resets is void), `object_avoidance`
(head-to-head rules with 6 boxes on the lanes; `randomize_obstacles=True` re-draws them per
reset, neighbours at least `obstacle_min_gap` = 2 m apart), `head_to_bot` (head-to-head rules
with 3 bot cars).

## Bot cars (`head_to_bot`)
DeepRacer's HEAD_TO_BOT: `num_bots` scripted cars (None: 3 in `head_to_bot`, else 0; an
explicit count works in any race type, up to 12) drive the lanes (half-way between the
centre line and a border) at `bot_speed` (0.75 m/s) and never react to the cars. They start
`linspace(2 m, L - 1 m, n)` ahead of the start point on alternating lanes, inner first
(`randomize_bots=True`: random positions at least 2 m apart and random lanes, per reset),
and change lanes every `bot_lane_change_min`..`bot_lane_change_max` seconds (3-5 s, drawn
from the env's generator; `bot_lane_change=False` keeps them in lane), a change taking
`bot_lane_change_distance` (1 m) of track. Bots are not agents: no laps, ranks, rewards or
results rows, and no overtake counting. Contacts are judged as DeepRacer judges them, by who
is behind along the track: a car that runs into a bot ahead is crashed (the crash infraction:
a penalty under race rules, the end of its episode under training rules); a bot that runs
into a car ahead makes every bot of the race stand still for `bot_penalty` seconds (5 s), and
the car is not penalised. Bots pass through obstacles and each other. `env.core.bot_*` holds
their state; `env.last_events.bot_contacts` lists `(env, car, bot, car_at_fault)` per contact.

## Training starts
DeepRacer's: `round_robin_starts=True` moves the start point of each episode
`round_robin_advance` (0.05) of the lap further round, the first episode on the start line
(the grid, laps in training rules and DeepRacer's `progress` all count from there);
`alternate_direction=True` drives every second episode the other way round (the same start
line; `env.track` and `env.core.track` are then `track.reversed()`, arc positions and progress
follow the driving direction and DeepRacer params report `is_reversed=True`). A `reset` with a
seed restarts both cycles (episode 0: start line, the track's own direction), so the same seed
gives the same first state; seed only the first reset to rotate. The rsl-rl VecEnv honours
`round_robin_starts` per env copy but refuses `alternate_direction` (its copies share one
direction and reset one at a time): train it on `track.reversed()` instead.

## Info
`infos[agent]` is flat and fixed: the same keys at `reset` and at every step, each a finite
Python number (`h2h_racing.envs.infos.INFO_KEYS`), so trainers can build tensor specs from the
infos of `reset` (TorchRL's `PettingZooWrapper` does):
- floats: `progress` (% of a lap since the episode start), `distance` (m from the start
  line), `last_lap_time` and `best_lap_time` (s; **-1.0 while the car has no (valid) timed
  lap**, `h2h_racing.envs.infos.NO_LAP_TIME`), `gap_to_leader` (m), `time` (simulated s);
- ints: `lap`, `rank`, `overtakes`, `overtaken`, `defences`, `resets`, `penalties`;
- bools: `frozen`, `finished`, `off_track`, `crashed`, `collided`, `penalised`, `parked`
  (the car's race is over and it is parked off the track);
- floats: `reward_progress`, `reward_speed`, ..., `reward_time`: the weighted reward terms
  of the step (0.0 at reset).

`info_level="full"` adds the structures that do not fit: `lap_times` (every lap's time, a
list growing each lap), `reward_terms` (the same terms as a dict) and, with a DeepRacer
`reward_function`, `deepracer_params` (at step only). `env.results()` gives the race results.

## Arguments
```python
h2h_racing.parallel_env(track="speedway", num_cars=2, race_type="head_to_head",
                        rules=None, render_mode=None, max_cycles=10_000,
                        reward_function=None, info_level="flat", parked_agents=False,
                        **config)
```
`track`: a catalogue name (`h2h-racing tracks list`), a track file (.json, .npy, .csv) or
a `Track`. `race_type`: `"head_to_head"`, `"time_trial"`, `"object_avoidance"` or
`"head_to_bot"`. `rules`: None (the race type's preset), `"race"`, `"training"` or a
`RaceRules`. Every other keyword is a field of `EnvConfig` (e.g. `action_type="discrete"`,
`num_obstacles=4`, `randomize_obstacles=True`, `grid="fixed"`, `reward=RewardConfig(...)`,
`num_bots=6`, `bot_speed=0.75`, `randomize_bots=True`, `round_robin_starts=True`,
`alternate_direction=True`), e.g.
`h2h_racing.parallel_env(track="speedway", num_cars=1, race_type="head_to_bot",
rules="training", round_robin_starts=True)`.
`min_steer_deg`/`max_steer_deg` set the continuous steering range (default +-30 deg).
`reward_function`: None (built-in reward), a `.py` file path or a callable (see above).
`reset(seed, options)` accepts `options={"grid": [slot of car_0, slot of car_1, ...]}`.

## Determinism and pickling
The same seed and actions give bit-identical observations, rewards and infos. An env pickled
mid-race continues identically, except when pickled while two bodies are touching: pymunk
cannot pickle the impulses it caches for ongoing contacts, so such a clone continues validly
but not bit-for-bit. Scripted drivers (``h2h_racing.policies``) read the true state from
``env.core`` (the batched core behind the env, E = 1).

## Version history
- v4: randomised obstacles keep `obstacle_min_gap` (2 m, DeepRacer's
  `MIN_DISTANCE_BETWEEN_OBSTACLES`) between neighbours, centre to centre, where the lap has
  room (it was 40 % of a lap's share per box: 0.9 m on a 17.7 m track, where two boxes in
  opposite lanes made a slalom no car can steer through). Fixed and evenly spaced layouts,
  and long laps (6 boxes on more than about 34 m), are drawn as in v3.
- v3: the state observation's obstacle slots keep a box until its centre is 0.5 m behind the
  car's (it was dropped once it was behind the car's centre, while the car was still beside
  it), so their arc gap can be negative down to -0.1; race rules put a car that crashed into
  a box back 1 m behind it on the other lane (DeepRacer's `RESET_BEHIND_DIST`), not on the
  lane nearest to where it stopped. Configurations without obstacles behave exactly as in v2.
- v2: flat, fixed infos (`reward_<term>` keys instead of the `reward_terms` dict, lap times
  -1.0 instead of inf before the first lap, a `parked` flag, no `lap_times` list: those and
  `deepracer_params` with `info_level="full"`); actions for cars that have left the race are
  ignored instead of raising; `parked_agents=True`; `sensors` accepts any sequence of names.
  Observations, rewards and the race are unchanged.
- v1: `head_to_bot` and bot cars (`num_bots`, ...), which fill the state observation's
  opponent slots, appear to the camera, the lidar and DeepRacer's `objects_*`, and are judged
  in contacts; DeepRacer training starts (`round_robin_starts`, `alternate_direction`);
  camera fix: cars 9 to 16 are drawn in their documented shade (`CAR_SHADES[i % 8]`; they were
  drawn with values read past the shade table). Configurations without bots and with at most
  8 cars behave exactly as in v0. Later in v1: the `contact` reward term (weight 0 by
  default, so rewards are unchanged; `reward_terms` gains the key).
- v0: initial release (state, camera and lidar observations).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from gymnasium import spaces
from pettingzoo import ParallelEnv
from pettingzoo.utils.conversions import parallel_to_aec

from h2h_racing.sim import rewards
from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.sim.core import RaceCore
from h2h_racing.deepracer.params import ParamsBuilder
from h2h_racing.deepracer.reward import DeepRacerReward
from h2h_racing.envs.actions import EnvActions
from h2h_racing.envs.rewards import EnvRewards
from h2h_racing.envs.infos import InfoBuilder
from h2h_racing.sensors.camera import CameraSensor
from h2h_racing.sensors.lidar import LidarSensor
from h2h_racing.sensors.state import OBS_BOUND, state_observation, state_size
from h2h_racing.track.shape import Track
from h2h_racing.track.io import load_track


def _resolve_rules(rules: Any, race_type: str) -> RaceRules | None:
    if rules is None or isinstance(rules, RaceRules):
        return rules
    if isinstance(rules, str):
        return RaceRules.preset(race_type, rules)
    raise ValueError(f"rules must be None, 'race', 'training' or a RaceRules, got {rules!r}")


class RacingEnv(EnvActions, EnvRewards, ParallelEnv):
    """Head-to-head racing as a PettingZoo ParallelEnv (see the module docstring).

    Its action checks and scaling are in ``h2h_racing.envs.actions``; parked agents and
    DeepRacer reward calls in ``h2h_racing.envs.rewards``.

    Args:
        track: Catalogue name, track file path or ``Track``.
        num_cars: Number of cars.
        race_type: ``"head_to_head"``, ``"time_trial"``, ``"object_avoidance"`` or
            ``"head_to_bot"``.
        rules: None, ``"race"``, ``"training"`` or a ``RaceRules``.
        render_mode: None or ``"rgb_array"``.
        config: An ``EnvConfig``; when given, the other configuration arguments must not be.
        reward_function: A DeepRacer reward function: the path of a ``.py`` file defining
            ``reward_function(params)`` (loaded once per car) or a callable; None keeps the
            built-in reward.
        info_level: ``"flat"`` (default: fixed keys of finite numbers, ``h2h_racing.envs.infos``)
            or ``"full"`` (those plus ``lap_times``, ``reward_terms`` and
            ``deepracer_params``).
        parked_agents: Keep finished and retired cars in ``env.agents`` as parked agents
            until the race ends (zero reward, actions ignored, terminated or truncated with
            everyone at the end), for trainers that need a fixed set of agents.
        reward_time_limit: Longest a call of ``reward_function`` may run [s]; past it the
            step raises ``RewardFunctionError`` (an endless loop no longer hangs the run).
            None (the default) sets no limit: the timer costs about 15 microseconds a call and
            needs the main thread (``h2h_racing.deepracer.reward``).
        **overrides: Further ``EnvConfig`` fields.
    """

    metadata = {
        "name": "h2h_racing_v4",
        "render_modes": ["rgb_array"],
        "render_fps": 15,
        "is_parallelizable": True,
    }

    def __init__(self, track: str | Track = "speedway", num_cars: int = 2,
                 race_type: str = "head_to_head", rules: Any = None,
                 render_mode: str | None = None, config: EnvConfig | None = None,
                 reward_function: str | Path | Callable[[dict[str, Any]], Any] | None = None,
                 info_level: str = "flat", parked_agents: bool = False,
                 reward_time_limit: float | None = None, **overrides: Any) -> None:
        # "human" is accepted so that PettingZoo's render_test can read the metadata; this
        # headless build cannot open a window and says so on the first render().
        if render_mode not in (None, "human", *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be None or one of "
                             f"{self.metadata['render_modes']}, got {render_mode!r}")
        if config is None:
            valid = {f.name for f in dataclasses.fields(EnvConfig)}
            unknown = sorted(set(overrides) - valid)
            if unknown:
                raise TypeError(f"unknown arguments {unknown}; valid EnvConfig fields are "
                                f"{sorted(valid)}")
            track_name = track.name if isinstance(track, Track) else str(track)
            config = EnvConfig(track=track_name, num_cars=num_cars, race_type=race_type,
                               rules=_resolve_rules(rules, race_type), **overrides)
        elif overrides:
            raise TypeError("pass either config or keyword overrides, not both")
        self.config = config
        self.track = track if isinstance(track, Track) else load_track(config.track)
        self.render_mode = render_mode
        self.core = RaceCore(config, self.track, num_envs=1)
        self.last_events: Any = None
        """The ``StepEvents`` of the last step (None before the first), for loggers."""
        self.possible_agents = [f"car_{i}" for i in range(config.num_cars)]
        self.agents: list[str] = []
        self._index = {agent: i for i, agent in enumerate(self.possible_agents)}
        size = state_size(config.opponent_slots, config.obstacle_slots)
        state_space = spaces.Box(-OBS_BOUND, OBS_BOUND, (size,), np.float32)
        obstacle_size = (config.obstacle_length, config.obstacle_width)
        self._camera = (CameraSensor(config.camera, self.track, config.car, obstacle_size)
                        if "camera" in config.sensors else None)
        self._lidar = (LidarSensor(config.lidar, config.car, obstacle_size)
                       if "lidar" in config.sensors else None)
        self._sensor_rng = np.random.default_rng()
        self._state_only = config.sensors == ("state",)
        if self._state_only:
            obs_space: spaces.Space = state_space
        else:
            parts = {"state": state_space,
                     "camera": self._camera.space() if self._camera else None,
                     "lidar": self._lidar.space() if self._lidar else None}
            obs_space = spaces.Dict({key: parts[key] for key in config.sensors})
        if config.action_type == "continuous":
            act_space: spaces.Space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        else:
            act_space = spaces.Discrete(len(config.discrete_actions))
            table = np.array(config.discrete_actions, dtype=np.float64)
            self._discrete_steer = np.radians(table[:, 0])
            self._discrete_speed = table[:, 1]
        # One space object per agent, built once: PettingZoo's tests require identity.
        self._observation_spaces = {a: obs_space for a in self.possible_agents}
        self._action_spaces = {a: act_space for a in self.possible_agents}
        # steer mid-point and half-range [rad], speed mid-point and half-range [m/s].
        self._affine = np.array(config.action_affine, dtype=np.float64)
        self._continuous = config.action_type == "continuous"
        self._num_cars = config.num_cars
        self._chosen: list[int] = []
        self._deepracer: DeepRacerReward | None = None
        self._params: ParamsBuilder | None = None
        # One params builder per driving direction (its centre line is in driving order).
        self._params_by_direction: dict[bool, ParamsBuilder] = {}
        if reward_function is not None:
            self._deepracer = DeepRacerReward(reward_function, config.num_cars,
                                              self.possible_agents, time_limit=reward_time_limit)
            self._params = self._params_builder(False)
        self._info = InfoBuilder(config.num_cars, self.track.length,
                                 rewards.weights_of(config.reward), info_level)
        if not isinstance(parked_agents, bool):
            raise ValueError(f"parked_agents must be a bool, got {parked_agents!r}")
        self.parked_agents = parked_agents
        # How each parked agent's race ended (True: terminated, False: truncated), reported
        # when the race ends.
        self._ended: dict[str, bool] = {}
        self._renderer: Any = None
        self._reset_done = False
        self._live: set[str] = set()
        self._active: list[str] = []

    # ---------------------------------------------------------------- spaces
    def observation_space(self, agent: str) -> spaces.Space:
        """Return the observation space of ``agent`` (the same object on every call)."""
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Space:
        """Return the action space of ``agent`` (the same object on every call)."""
        return self._action_spaces[agent]

    @property
    def max_cycles(self) -> int:
        """Steps after which every car is truncated (may be changed between episodes)."""
        return self.core.max_cycles

    @max_cycles.setter
    def max_cycles(self, value: int) -> None:
        if not isinstance(value, int) or value < 1:
            raise ValueError(f"max_cycles must be an int >= 1, got {value!r}")
        self.core.max_cycles = value

    # ---------------------------------------------------------------- API
    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None,
              ) -> tuple[dict[str, Any], dict[str, dict[str, Any]]]:
        """Start a new race.

        Args:
            seed: Seeds the env's random generator (grid draw, obstacle and bot
                randomisation, bot lane changes) and restarts the training-start cycles
                (``round_robin_starts``, ``alternate_direction``); None continues both.
            options: ``{"grid": [slot, ...]}`` puts car i in grid slot ``grid[i]``
                (a permutation of 0..N-1); other keys are ignored.

        Returns:
            ``(observations, infos)`` for every agent.
        """
        slots = None
        if options and "grid" in options:
            slots = np.asarray(options["grid"], dtype=np.int64)
            if slots.shape != (self.config.num_cars,):
                raise ValueError(f"options['grid'] must list one slot per car "
                                 f"({self.config.num_cars}), got {options['grid']!r}")
        self.core.reset(seed=seed, slots=slots)
        # With alternate_direction the core may now drive the track the other way round.
        self.track = self.core.track
        if self._params is not None:
            self._params = self._params_builder(self.core.is_reversed)
            self._params.reset()
        if self._lidar is not None and self.config.lidar.noise_std > 0:
            # The lidar's noise has a generator of its own, seeded from the env's, so that
            # turning noise on does not change the race's random stream.
            self._sensor_rng = np.random.default_rng(self.core.rng.integers(2**63))
        if self._camera is not None:
            self._camera.reset(self.core)
        self.agents = self.possible_agents[:]
        self._active = self.agents
        self._live = set(self.agents)
        self._ended = {}
        self._reset_done = True
        obs = self._observations()
        return obs, self._info.reset(self.core, self._index, self.agents)

    def step(self, actions: dict[str, Any]) -> tuple[dict[str, Any], dict[str, float],
                                                     dict[str, bool], dict[str, bool],
                                                     dict[str, dict[str, Any]]]:
        """Advance the race by one step (1/15 s).

        Args:
            actions: One action per racing agent. Entries for agents no longer in
                ``env.agents`` (finished or retired), and for parked agents, are ignored, so a
                trainer may send one action per car on every step.

        Returns:
            ``(observations, rewards, terminations, truncations, infos)`` keyed by the agents
            of ``env.agents`` when the step started.

        Raises:
            RuntimeError: ``reset`` was not called, or the race is over.
            ValueError: missing actions of racing agents, unknown agent names, wrong shapes,
                NaN/inf or bad indices.
        """
        if not self._reset_done:
            raise RuntimeError("call reset() before step()")
        agents = self.agents
        if not agents:
            raise RuntimeError("the race is over (env.agents is empty); call reset()")
        active = self._active
        steer, speed = self._parse_actions(actions, active)
        core = self.core
        racing = core._racing
        events = core.step(steer, speed)
        self.last_events = events
        index = self._index
        reward, infos = self._info.step(core, index, agents, events, racing)
        if self._deepracer is not None:
            reward, params = self._deepracer_rewards(active, racing[0], steer[0], events)
            if self._info.level == "full":
                for a in agents:
                    infos[a]["deepracer_params"] = params[index[a]]
        obs = self._observations()
        term = events.terminated[0].tolist()
        trunc = events.truncated[0].tolist()
        if len(agents) == len(index):
            # Every car still in the race (the common case): the lists are in agent order.
            rewards_out = dict(zip(agents, reward))
            terminations = dict(zip(agents, term))
            truncations = dict(zip(agents, trunc))
        else:
            rewards_out = {a: reward[index[a]] for a in agents}
            terminations = {a: term[index[a]] for a in agents}
            truncations = {a: trunc[index[a]] for a in agents}
            obs = {a: obs[a] for a in agents}
        if True in term or True in trunc:
            self._active = [a for a in active if not (terminations[a] or truncations[a])]
            self._live = set(self._active)
            if not self.parked_agents:
                self.agents = self._active
            else:
                self._park(active, terminations, truncations)
        if self.parked_agents and len(self._active) < len(agents):
            rewards_out, terminations, truncations = self._parked_results(
                agents, active, rewards_out, terminations, truncations)
        return obs, rewards_out, terminations, truncations, infos

    def _observations(self) -> dict[str, Any]:
        if self._state_only:
            return dict(zip(self.possible_agents, state_observation(self.core)[0]))
        sensors = self.config.sensors
        arrays = {}
        for key in sensors:
            if key == "state":
                arrays[key] = state_observation(self.core)[0]
            elif key == "camera":
                arrays[key] = self._camera.observe(self.core)[0]
            else:
                arrays[key] = self._lidar.observe(self.core, self._sensor_rng)[0]
        return {a: {key: value[i] for key, value in arrays.items()}
                for i, a in enumerate(self.possible_agents)}

    def render(self) -> npt.NDArray[np.uint8] | None:
        """Return a top-down spectator frame (H, W, 3) uint8 in ``rgb_array`` mode."""
        if self.render_mode is None:
            return None
        if self.render_mode == "human":
            raise RuntimeError("render_mode='human' needs a window, and h2h-racing renders "
                               "headless (opencv-python-headless): use render_mode='rgb_array' "
                               "and display the frames, or record the race for the rerun viewer")
        if self._renderer is None:
            from h2h_racing.viz.render import SpectatorRenderer

            self._renderer = SpectatorRenderer(self.track)
        return self._renderer.draw(self.core, env_index=0)

    def close(self) -> None:
        """Release the renderer."""
        self._renderer = None

    def results(self) -> list[dict[str, Any]]:
        """Return the race results so far, in finishing order (see ``h2h_racing.envs.results``)."""
        from h2h_racing.envs.results import race_results

        return race_results(self.core, env_index=0, agents=self.possible_agents)

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_renderer"] = None
        return state


def parallel_env(**kwargs: Any) -> RacingEnv:
    """Create the ParallelEnv (see the module docstring for the arguments)."""
    return RacingEnv(**kwargs)


def env(**kwargs: Any) -> Any:
    """Create the AEC view of the env (``parallel_to_aec(parallel_env(...))``)."""
    return parallel_to_aec(parallel_env(**kwargs))
