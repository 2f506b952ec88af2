"""rsl-rl ``VecEnv`` over the batched race core (not over K Python env objects).

Rows are learner-controlled cars: ``learners`` cars in each of ``num_envs`` env copies of one
``RaceCore`` (``num_envs * learners`` rows, parameter sharing between a copy's learner cars).
The other cars of a copy are opponents, driven inside :meth:`RacingVecEnv.step` by a scripted
driver or a frozen policy, in one batched call over every copy. Every car's grid slot is drawn
at each reset (seat fairness).

Several tracks in one batch (``[procedural] tracks``): given K tracks, the copies split into K
blocks in track order, each racing its track, in the same core (``RaceCore``'s several tracks:
one step for every copy); every rollout, and every mini-batch drawn from it, mixes the K
tracks. Each track has its own random generator and its own opponent and expert drivers
(``vec_env_drivers``), so the rows of a track's copies are those a VecEnv of that track alone
would give, seeded with the track's seed (``RaceCore.track_seeds``). With a single track, one
track of a procedural run's rollout pulls every gradient step of the iteration towards it:
camera students' laps on the held-out tracks swung from checkpoint to checkpoint (issue 21,
``experiments/camera``).

A copy's episode ends as soon as one of its learner cars is done (finished its laps, retired by
an infraction under ``training`` rules, or out of time), and the copy is reset inside ``step``:
that learner's row reports ``done`` (a termination, or a time-out for a time limit), the other
learners of the copy report ``done`` with ``time_outs`` set (their episode was cut short, so PPO
bootstraps their value), and the observations returned are the first of the next episode.
rsl-rl has no row mask (every row goes into the loss), so a copy never keeps running with a
finished learner in it.

The observation groups are built in ``vec_env_observe``, the training starts (random points
of the lap, clear of the boxes) drawn in ``vec_env_starts``, and the drivers of the other cars
and of the expert labels held in ``vec_env_drivers``.

DeepRacer inputs: ``reward_function`` replaces the built-in reward by a DeepRacer
``reward_function(params)`` file, loaded once per learner row (module-level state stays per
car and per copy), with the env's rules (called from the first step, ``steps == 1``; a frozen car
gets 0 without a call; exceptions, non-numbers, NaN and inf raise ``RewardFunctionError``
naming the file, the car, the step and the params; |reward| > 1e5 warns). A discrete action
space (``action_type="discrete"``, e.g. from ``load_model_metadata``) keeps rsl-rl's Gaussian
policy: its (steer, speed) output picks the nearest action of the list
(``h2h_racing.deepracer.metadata.nearest_discrete``). ``simtrace`` writes DeepRacer simtrace
and metrics logs of a few copies (``h2h_racing.deepracer.logs``).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from typing import Any, Callable, Literal

import numpy as np
import numpy.typing as npt

os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")  # rsl-rl imports GitPython

from h2h_racing.common.extras import missing_extra  # noqa: E402

try:
    import torch  # noqa: E402
    from rsl_rl.env import VecEnv  # noqa: E402
    from tensordict import TensorDict  # noqa: E402
except ImportError as _error:
    raise missing_extra("train", "training", _error) from None

from h2h_racing.sim import rewards  # noqa: E402
from h2h_racing.config.env import EnvConfig  # noqa: E402
from h2h_racing.sim.core import RaceCore  # noqa: E402
from h2h_racing.deepracer.metadata import nearest_discrete  # noqa: E402
from h2h_racing.sim.race import TIME_EPS  # noqa: E402
from h2h_racing.sensors.camera import CameraSensor  # noqa: E402
from h2h_racing.sensors.lidar import LidarSensor  # noqa: E402
from h2h_racing.track.shape import Track  # noqa: E402
from h2h_racing.track.io import load_track  # noqa: E402
from h2h_racing.training.vec_env_drivers import PoolOpponent, TrackDrivers  # noqa: E402
from h2h_racing.training.vec_env_observe import (  # noqa: E402
    ACTOR_GROUPS,
    OBSERVATIONS,
    VecEnvObservations,
)
from h2h_racing.training.vec_env_starts import VecEnvStarts  # noqa: E402
from h2h_racing.training.tight_boxes import TightBoxes  # noqa: E402

__all__ = ["ACTOR_GROUPS", "OBSERVATIONS", "PoolOpponent", "RacingVecEnv"]

Opponent = Callable[[RaceCore, int], npt.NDArray[np.floating]]
"""Drives car ``car`` of every copy: ``opponent(core, car) -> (E, 2)`` actions in [-1, 1]."""


class RacingVecEnv(VecEnvObservations, VecEnvStarts, VecEnv):
    """Learner cars of a batched race core as rsl-rl rows.

    Args:
        config: The env configuration (track, cars, rules, rewards, sensors' settings).
        num_envs: Env copies E.
        learners: Learner cars per copy L (cars ``0 .. L-1``); None means every car (self-play
            with parameter sharing).
        opponent: Driver of the other cars: a ``h2h_racing.policies`` driver name, an object
            with ``reset(core)`` and ``act(core, car)``, or None when every car is a learner.
        observations: ``"state"``, ``"camera"`` (adds the ``camera`` group),
            ``"camera_only"`` (adds the ``camera`` and ``motion`` groups) or
            ``"camera_lidar"`` (adds ``camera``, ``lidar`` and ``motion``); see
            ``ACTOR_GROUPS``.
        seed: Seed of the core's random generator (one per track, ``RaceCore.track_seeds``, with
            several tracks), and (spawned from it) of the lidar's noise when
            ``config.lidar.noise_std > 0``.
        device: Torch device of the returned tensors.
        track: A ``Track`` to use instead of loading ``config.track``, or K tracks: the copies
            split into K blocks in track order (``num_envs`` a multiple of K), each block with
            its own opponent and expert drivers (a driver name is built per track, seeded with
            its track's seed; an object is copied per track, a ``PoolOpponent`` split).
        random_starts: Start each episode at a random point of the lap (drawn from the core's
            generator), as DeepRacer's training starts move round the lap, so that a policy
            learns every corner from every state; False starts on the start line. Ignored
            with ``config.round_robin_starts`` (DeepRacer's own rotation, done by the core).
        reward_function: A DeepRacer reward file (``reward_function(params)``) for the
            learner cars; None keeps the built-in reward.
        simtrace: Folder for DeepRacer simtrace CSV and metrics JSON of the learner cars of
            copies ``0 .. simtrace_envs - 1`` (one DRfC worker each); None writes none. Call
            ``close()`` at the end to write the metrics and unfinished episodes.
        simtrace_envs: How many copies to log (1-10; logging costs a few us per row).
        simtrace_episodes: Episodes of each logged copy per simtrace iteration
            (``SimtraceWriter``'s ``episodes_per_iteration``).
        expert: A scripted driver (name, e.g. ``"racing_line"``, or object) whose actions for
            the learner cars fill the ``expert`` observation group; None adds no group.
        race_types: Race types that take turns at each ``set_track`` (a procedural run's new
            track): the k-th call races ``race_types[k % len]`` with that race type's default
            boxes and bots; empty keeps ``config.race_type``.
        tight_boxes: Training's tight boxes (``[race] tight_box_share``): a share of each
            reset's box layouts get one box moved where the room beside it is tight
            (``h2h_racing.training.tight_boxes``); None (the default) places them as the env.

    Raises:
        ValueError: For bad arguments, for a DeepRacer reward function or simtrace logs with
            several tracks (they are bound to one), and for ``config.alternate_direction``: the
            copies
            share one driving direction but reset one at a time, so they cannot alternate.
            Train on ``track.reversed()``, switch with ``set_track(track.reversed())``
            between ``learn()`` calls, or use the PettingZoo env, which alternates.
    """

    def __init__(self, config: EnvConfig, num_envs: int, learners: int | None = None,
                 opponent: str | Any | None = None,
                 observations: Literal["state", "camera", "camera_only",
                                       "camera_lidar"] = "state", seed: int = 0,
                 device: str = "cpu", track: Track | Sequence[Track] | None = None,
                 random_starts: bool = True, reward_function: str | None = None,
                 simtrace: str | None = None, simtrace_envs: int = 2,
                 simtrace_episodes: int = 20,
                 expert: str | Any | None = None, race_types: tuple[str, ...] = (),
                 reward_time_limit: float | None = None,
                 tight_boxes: TightBoxes | None = None) -> None:
        n = config.num_cars
        learners = n if learners is None else learners
        if not isinstance(learners, int) or not 1 <= learners <= n:
            raise ValueError(f"learners must be an int in [1, num_cars={n}], got {learners!r}")
        if learners < n and opponent is None:
            raise ValueError(f"{n - learners} car(s) per copy are not learners: give an opponent "
                             "(a driver name such as 'racing_line', or a driver object)")
        if observations not in OBSERVATIONS:
            raise ValueError(f"observations must be one of {OBSERVATIONS}, got {observations!r}")
        if config.alternate_direction:
            raise ValueError(
                "RacingVecEnv cannot honour EnvConfig.alternate_direction: its env copies share "
                "one driving direction (one track in the batched core) but end and reset one at "
                "a time. Train on the reversed track (track=load_track(name).reversed()), switch "
                "direction between learn() calls with set_track(track.reversed()), or use the "
                "PettingZoo env (h2h_racing.parallel_env(alternate_direction=True)), which "
                "alternates per episode")
        tracks = ((load_track(config.track),) if track is None
                  else (track,) if isinstance(track, Track) else tuple(track))
        if not tracks or num_envs % len(tracks):
            raise ValueError(f"{num_envs} env copies do not split evenly into {len(tracks)} "
                             f"tracks; make num_envs a multiple of the number of tracks")
        if len(tracks) > 1 and (reward_function is not None or simtrace is not None):
            raise ValueError("a DeepRacer reward function or simtrace logs need one track; "
                             "give one track (not several)")
        self.config = config
        self.race_types = tuple(race_types)
        self._tracks_set = 0
        self.cfg = config.to_dict()
        self.core = RaceCore(config, tracks, num_envs=num_envs)
        self.learners = learners
        self.num_envs = num_envs * learners
        self.num_actions = 2
        self.device = device
        self.observation_kind = observations
        self.max_episode_length = min(
            config.max_cycles, int(np.ceil(self.core.rules.time_limit / config.step_dt - TIME_EPS)))
        self.episode_length_buf = torch.zeros(self.num_envs, dtype=torch.long, device=device)
        self._weights = rewards.weights_of(config.reward)
        self._camera = (CameraSensor(config.camera, tracks, config.car,
                                     (config.obstacle_length, config.obstacle_width))
                        if "camera" in ACTOR_GROUPS[observations] else None)
        self._lidar = (LidarSensor(config.lidar, config.car,
                                   (config.obstacle_length, config.obstacle_width))
                       if "lidar" in ACTOR_GROUPS[observations] else None)
        # The lidar's noise has a generator of its own (spawned from the seed, as the env's
        # is seeded from its own), so that turning noise on leaves the race's draws unchanged.
        self._lidar_rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])
        self._seeds = ([seed] if len(tracks) == 1
                       else RaceCore.track_seeds(seed, len(tracks)))
        self._opponents = None if opponent is None else TrackDrivers(opponent, self.core,
                                                                     self._seeds)
        self._experts = None if expert is None else TrackDrivers(expert, self.core, self._seeds)
        self.random_starts = random_starts
        self.tight_boxes = tight_boxes
        self._tight_places: dict[int, tuple[Any, Any]] = {}
        self.core.seed(seed)
        every = np.ones(num_envs, dtype=bool)
        self.core.reset(start=self._starts(every))
        self._clear_starts(every)
        self.reward_function = reward_function
        self.reward_time_limit = reward_time_limit
        self._builders: list[Any] = []
        self._deepracer: list[Any] = []
        if reward_function is not None:
            from h2h_racing.deepracer import DeepRacerReward, ParamsBuilder

            self._builders = [ParamsBuilder(self.track, config.car, n) for _ in range(num_envs)]
            self._deepracer = [DeepRacerReward(reward_function, learners,
                                               agents=[f"car_{i} of env copy {e}"
                                                       for i in range(learners)],
                                               time_limit=reward_time_limit)
                               for e in range(num_envs)]
        self.simtrace = None
        if simtrace is not None:
            from h2h_racing.deepracer.logs import SimtraceWriter

            if not isinstance(simtrace_envs, int) or not 1 <= simtrace_envs <= num_envs:
                raise ValueError(f"simtrace_envs must be an int in [1, num_envs={num_envs}], "
                                 f"got {simtrace_envs!r}")
            self.simtrace = SimtraceWriter(simtrace, config, self.track,
                                           envs=range(simtrace_envs), cars=range(learners),
                                           episodes_per_iteration=simtrace_episodes)
            self.simtrace.start(self.core)
        self.evaluations: Any = None
        """DeepRacer's evaluation episodes between the simtrace's training iterations: an
        object whose ``run(start, slots)`` runs them from a grid (``grid``) and returns their
        metrics entries (``h2h_racing.training.simtrace_eval.SimtraceEvaluations``); None
        runs none. With a simtrace, ``step`` runs them when the first logged copy finishes an
        iteration, and appends them to its metrics (``SimtraceWriter.log_evaluation``)."""
        self._reset_drivers()
        if self._camera is not None:
            self._camera.reset(self.core)
        self._obs = self._observe()

    @property
    def tracks(self) -> tuple[Track, ...]:
        """The tracks the copies race, in block order."""
        return self.core.forward_tracks

    @property
    def track(self) -> Track:
        """The track every copy races (a VecEnv of several tracks has ``tracks``)."""
        if self.core.num_tracks != 1:
            raise AttributeError(f"this RacingVecEnv races {self.core.num_tracks} tracks, so it "
                                 f"has no single track: see tracks")
        return self.core.forward_track

    @property
    def opponent(self) -> Any:
        """The driver of the cars that are not learners (None when every car learns): with
        several tracks, the one given (each track drives with its own, ``TrackDrivers``)."""
        return None if self._opponents is None else self._opponents.driver

    @property
    def expert(self) -> Any:
        """The driver whose actions fill the ``expert`` group (None without one)."""
        return None if self._experts is None else self._experts.driver

    # ---------------------------------------------------------------- rsl-rl API
    def get_observations(self) -> TensorDict:
        """Return the current observation groups."""
        return self._obs

    def step(self, actions: torch.Tensor) -> tuple[TensorDict, torch.Tensor, torch.Tensor,
                                                   dict[str, Any]]:
        """Apply the learners' actions, drive the opponents, step every copy, auto-reset.

        Args:
            actions: ``(num_envs * learners, 2)`` = (steer, speed) in [-1, 1] (clipped).

        Returns:
            ``(observations, rewards (B,), dones (B,), extras)`` with ``extras["time_outs"]``
            (B,) and ``extras["log"]`` (episode statistics of the copies that ended).
        """
        core, cfg = self.core, self.config
        e, n, learners = core.num_envs, core.num_cars, self.learners
        if tuple(actions.shape) != (self.num_envs, 2):
            raise ValueError(f"actions must have shape ({self.num_envs}, 2) (one row per learner "
                             f"car of every copy), got {tuple(actions.shape)}")
        values = actions.detach().to("cpu", torch.float64).numpy().reshape(e, learners, 2)
        if not np.isfinite(values).all():
            raise ValueError("actions contain NaN or inf")
        commands = np.empty((e, n, 2))
        commands[:, :learners] = values
        for car in range(learners, n):
            commands[:, car] = self._opponents.act(car)
        index = None
        if cfg.action_type == "discrete":
            # Every car drives the nearest action of the list (see the module docstring).
            index = nearest_discrete(cfg, commands)
            table = np.asarray(cfg.discrete_actions, dtype=np.float64)
            steer_deg, speed = table[index, 0], table[index, 1]
            steer = np.radians(steer_deg)
        else:
            steer, speed = cfg.commands(commands)
            steer_deg = np.degrees(steer)
        racing = core.racing
        events = core.step(steer, speed)
        terms, reward = rewards.reward_terms(self._weights, events, core.speed, racing)
        if self._deepracer:
            reward = self._deepracer_rewards(events, racing, steer_deg)
        if self.simtrace is not None:
            self.simtrace.log_step(core, events, racing, reward=reward, action=index,
                                   steer_deg=steer_deg)

        learner_done = core.done[:, :learners]
        ended = learner_done.any(axis=1) | core.done.all(axis=1)
        terminated = events.terminated[:, :learners]
        dones = np.broadcast_to(ended[:, None], (e, learners))
        time_outs = dones & ~terminated
        log = self._episode_log(ended, terms) if ended.any() else {}
        if ended.any():
            core.reset_envs(ended, start=self._starts(ended))
            self._clear_starts(ended)
            if self._camera is not None:
                self._camera.reset(core)
            for copy in np.flatnonzero(ended).tolist() if self._builders else ():
                self._builders[copy].reset()
            if self.simtrace is not None:
                # The episodes the reset cut short end first, so that an evaluation follows
                # every car's last episode of the iteration. DeepRacer evaluates from where
                # the worker's next training episode starts (its start does not advance in
                # the evaluation phase).
                self.simtrace.cut(ended)
                if self.evaluations is not None and self.simtrace.evaluation_due:
                    trials = self.evaluations.run(*self.grid(int(self.simtrace.envs[0])))
                    self.simtrace.log_evaluation(trials)
                self.simtrace.start(core, ended)
        self._obs = self._observe()
        steps = np.repeat(core.steps, learners)
        self.episode_length_buf.copy_(torch.from_numpy(steps))
        extras = {"time_outs": self._tensor(time_outs.reshape(-1), torch.float32),
                  "log": log}
        return (self._obs, self._tensor(reward[:, :learners].reshape(-1), torch.float32),
                self._tensor(dones.reshape(-1), torch.long), extras)

    def grid(self, copy: int) -> tuple[float, npt.NDArray[np.int64]]:
        """The start grid of env copy ``copy``'s current episode: the arc position of its slot
        0 [m] and the grid slot of each car, (N,) (``restart`` starts copies there)."""
        start = self.core.start_distance[copy]
        # Slot k starts k * grid_spacing behind slot 0 (spawn.grid_slots).
        slots = np.argsort(np.argsort(-start, kind="stable"), kind="stable")
        return float(start.max()), slots.astype(np.int64)

    def restart(self, start: npt.ArrayLike, slots: npt.ArrayLike | None = None) -> None:
        """Start a new episode in every copy, slot 0 at ``start`` [m] ((E,) or one for all),
        the cars on ``slots`` ((N,) or (E, N); None draws them), then observe. A start with a
        box on it is drawn again, as at every reset. Does not touch the simtrace."""
        core = self.core
        e = core.num_envs
        every = np.ones(e, dtype=bool)
        core.reset_envs(every, slots=slots,
                        start=np.broadcast_to(np.asarray(start, dtype=np.float64), (e,)))
        self._clear_starts(every)
        if self._camera is not None:
            self._camera.reset(core)
        for builder in self._builders:
            builder.reset()
        self._obs = self._observe()

    def set_opponent(self, opponent: str | Any) -> None:
        """Drive the non-learner cars with ``opponent`` from now on (a driver name or object;
        a league changes its learners' opponents between ``learn()`` calls)."""
        self._opponents = TrackDrivers(opponent, self.core, self._seeds)
        self._opponents.reset()

    def close(self) -> None:
        """Write the simtrace's metrics and unfinished episodes (no-op without simtrace)."""
        if self.simtrace is not None:
            self.simtrace.close()

    def set_track(self, track: Track) -> None:
        """Race on ``track`` from now on (``set_tracks([track])``, for a VecEnv of one track)."""
        self.set_tracks([track])

    def set_tracks(self, tracks: Sequence[Track]) -> None:
        """Race ``tracks[k]`` in block ``k`` of the copies from now on: every copy restarts on
        its track (the same generator streams, the same drivers, each reset for its track).

        Call it between ``learn()`` calls (rsl-rl reads ``get_observations()`` at the start of
        each); training on new random tracks every few iterations teaches policies to drive
        tracks they have never seen. With ``race_types`` each call also moves on to the next
        race type.

        Raises:
            ValueError: Unless there is one track per block (as many as the VecEnv was built
                with), and with a DeepRacer reward function or simtrace logs, which are bound
                to one track.
        """
        if self._deepracer or self.simtrace is not None:
            raise ValueError("a DeepRacer reward function or simtrace logs need one track; "
                             "train on a fixed track (not 'procedural') to use them")
        tracks = tuple(tracks)
        if len(tracks) != self.core.num_tracks:
            raise ValueError(f"set_tracks needs one track per block of copies "
                             f"({self.core.num_tracks}), got {len(tracks)}")
        if self.race_types:
            # Only the race type's default boxes and bots change: the rules are the run's own,
            # fixed in self.config (RaceSettings.rules_type).
            kind = self.race_types[self._tracks_set % len(self.race_types)]
            self.config = dataclasses.replace(self.config, race_type=kind)
            self.cfg = self.config.to_dict()
        self._tracks_set += 1
        old = self.core
        self.core = RaceCore(self.config, tracks, num_envs=old.num_envs)
        self.core.rngs = old.rngs
        self.core.max_cycles = old.max_cycles
        every = np.ones(self.core.num_envs, dtype=bool)
        self.core.reset(start=self._starts(every))
        self._clear_starts(every)
        for drivers in (self._opponents, self._experts):
            if drivers is not None:
                drivers.bind(self.core)
        self._reset_drivers()
        if self._camera is not None:
            self._camera = CameraSensor(self.config.camera, tracks, self.config.car,
                                        (self.config.obstacle_length, self.config.obstacle_width))
            self._camera.reset(self.core)
        self._obs = self._observe()

    # ---------------------------------------------------------------- helpers
    def _deepracer_rewards(self, events: Any, racing: npt.NDArray[np.bool_],
                           steer_deg: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """DeepRacer rewards of the learner cars that raced this step, (E, N) (0 elsewhere).

        One Python call per learner car and copy: the reward function is Python, so this is
        the cost of running DeepRacer reward files (see benchmarks/bench_deepracer.py).
        """
        core, learners = self.core, self.learners
        reward = np.zeros((core.num_envs, core.num_cars))
        rated = racing[:, :learners]
        for copy in np.flatnonzero(rated.any(axis=1)).tolist():
            cars = np.flatnonzero(rated[copy]).tolist()
            params = self._builders[copy].from_core(core, steering_deg=steer_deg[copy],
                                                    events=events, cars=cars, env_index=copy)
            function = self._deepracer[copy]
            for car in cars:
                reward[copy, car] = function(car, params[car])
        return reward

    def _reset_drivers(self) -> None:
        """Per-track precompute of the opponents and the experts (racing lines are cached)."""
        for drivers in (self._opponents, self._experts):
            if drivers is not None:
                drivers.reset()

    def _tensor(self, array: npt.NDArray[Any], dtype: torch.dtype) -> torch.Tensor:
        return torch.tensor(np.asarray(array), dtype=dtype, device=self.device)

    def _episode_log(self, ended: npt.NDArray[np.bool_],
                     terms: npt.NDArray[np.float64]) -> dict[str, float]:
        """Statistics of the learner cars of the copies whose episode ended this step."""
        core, learners = self.core, self.learners
        laps = core.laps[ended, :learners]
        lap_times = [t for env in np.flatnonzero(ended) for car in range(learners)
                     for t in core.lap_times[env][car]]
        log = {
            "lap_completion": float((laps >= 1).mean()),
            "progress": float(core.episode_progress[ended, :learners].mean()),
            "off_tracks": float(core.off_tracks[ended, :learners].mean()),
            "crashes": float(core.crashes[ended, :learners].mean()),
            "collisions": float(core.collisions[ended, :learners].mean()),
            "overtakes": float(core.overtakes[ended, :learners].mean()),
            **{f"reward/{name}": float(terms[k, :, :learners].mean())
               for k, name in enumerate(rewards.TERMS)},
        }
        if lap_times:  # rsl-rl averages what it is given; no NaN for "no lap yet"
            log["lap_time"] = float(np.mean(lap_times))
        return log
