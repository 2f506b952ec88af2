"""The batched simulation core: E env copies x N cars in arrays.

``RaceCore`` holds the state of every car of every env copy in arrays with leading axes
``(E, N)`` and advances them together: the single-track dynamics for all cars, one pymunk
Space for contacts, then race rules, observations and rewards over the same arrays (compiled
numba loops for the per-car work, numpy for the rare events). The PettingZoo env is this core
with E = 1; the training VecEnv is the same core with E in the hundreds.

A step is two-phase: commands are applied to every car, physics runs, the state is read
back once, and then race rules, observations and rewards are computed from that same
snapshot, so no car sees a half-updated world.

Bot cars (``head_to_bot``, ``EnvConfig.num_bots``) are B scripted cars per env copy in
``(E, B)`` arrays (``bot_*``): they drive their lanes open-loop (``h2h_racing.sim.bots``) as
kinematic bodies of the same Space, so cars bump into them physically. They are not agents:
they have no laps, ranks or rewards. A contact between a car and a bot is judged as
DeepRacer judges it: the one behind along the track is at fault. A car that runs into a bot
ahead is crashed (the rules' usual crash infraction); a bot that runs into a car ahead makes
every bot of that env copy stand still for ``bot_penalty`` seconds, and the car goes free.

Training starts (DeepRacer's): with ``round_robin_starts`` each reset of a copy moves its start
point ``round_robin_advance`` of a lap further round; with ``alternate_direction`` every second
episode drives the track the other way round (``RaceCore.reset(reverse=...)``; every copy of a
core drives the same direction, so the flip needs a reset of every copy at once).

Several tracks: ``RaceCore(config, [track_a, track_b, ...], num_envs)`` races K tracks at
once, env copy e on ``tracks[track_index[e]]`` (by default the copies split into K blocks in
track order). Every kernel reads the tables of all K tracks (``TrackTables``) at the copy's
track index, doing the same arithmetic as on one track's tables; each track has a random
generator of its own (``rngs``), which draws for its copies exactly as the generator of a core
of that track alone would. So a copy on track T races, to the bit, as the same copy of a core
of T alone, seeded with that track's seed, at the same place in the shared Space (pymunk works
in world coordinates: the last bits of a copy's motion depend on its offset there, as between
the copies of a one-track core). A one-track core is the case K = 1. Drivers written for one
track drive the copies of track k through ``track_views()``: each view reads the core's arrays
of those copies as a one-track core.

The core is split by concept: its arrays and their pickling in ``sim.state``, reset-time
placement in ``sim.starts``, infractions, re-placement and parking in ``sim.penalties``, the
step's report (``StepEvents``, re-exported here) in ``sim.events``, the tracks of the copies
(their tables, layout, generators and views) in ``sim.tracks``, and the one-track views of a
core of several tracks in ``sim.view``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from h2h_racing.sim import bots, race, layouts as spawn
from h2h_racing.config.env import EnvConfig
from h2h_racing.config.checks import check_seed
from h2h_racing.sim.events import StepEvents
from h2h_racing.sim.penalties import CorePenalties
from h2h_racing.sim.starts import CoreSpawn, check_rolling
from h2h_racing.sim.state import CoreState
from h2h_racing.sim.tracks import (ENV_GAP, PARK_MARGIN, CoreTracks, check_overlay,
                                   track_index_of)
from h2h_racing.sim.dynamics import SingleTrackModel
from h2h_racing.sim.physics import PhysicsWorld
from h2h_racing.track.shape import Track

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]

__all__ = ["ENV_GAP", "PARK_MARGIN", "RaceCore", "StepEvents"]


class RaceCore(CoreTracks, CoreState, CoreSpawn, CorePenalties):
    """Batched race simulation over ``num_envs`` copies of one track, or of several.

    Args:
        config: Environment configuration.
        track: The track every copy races on, or a sequence of K tracks.
        num_envs: Number of env copies E.
        track_index: The track of each copy, (E,) ints in [0, K); None splits the copies into
            K blocks in track order (copy e races track ``e * K // E``), and then needs
            ``num_envs >= K``.
        overlay: Lay each track's copies out in the Space as a core of that track alone
            with those copies would, over the other tracks' copies, which they never touch
            (at most ``MAX_OVERLAID_TRACKS``; see ``CoreTracks``): then even pymunk's last
            bits are a one-track core's. False: every copy a cell of its own.
    """

    def __init__(self, config: EnvConfig, track: Track | Sequence[Track], num_envs: int = 1,
                 track_index: npt.ArrayLike | None = None, overlay: bool = False) -> None:
        if not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs must be an int >= 1, got {num_envs!r}")
        tracks = (track,) if isinstance(track, Track) else tuple(track)
        if not tracks or not all(isinstance(t, Track) for t in tracks):
            raise TypeError(f"track must be a Track or a non-empty sequence of Tracks, got "
                            f"{type(track).__name__}")
        self.track_index = track_index_of(track_index, num_envs, len(tracks))
        """The track of each env copy, (E,): copy e races ``tracks[track_index[e]]``."""
        self.num_tracks = len(tracks)
        """Tracks K."""
        self.overlay = check_overlay(overlay, self.num_tracks)
        """Whether each track's copies are laid out as in a core of that track alone."""
        self.config = config
        self.rules = config.race_rules
        self.forward_tracks = tracks
        """The tracks as given (driven in their own direction when not reversed)."""
        self._reverse_tracks: tuple[Track, ...] | None = None
        self.is_reversed = False
        """Whether the current episodes drive ``forward_tracks`` the other way round."""
        self.num_envs = num_envs
        self.num_cars = config.num_cars
        self.num_obstacles = config.obstacle_count
        self.num_bots = config.bot_count
        """Bot cars per env copy B."""
        self.dt = config.step_dt
        self.model = SingleTrackModel(config.car)
        self._use_tracks(tracks)
        self.episodes = np.zeros(num_envs, dtype=np.int64)
        """Episodes started by each copy since the last seeded reset, (E,) (round-robin starts
        and alternating directions count them)."""
        car = config.car
        # Wheel centres in the body frame: rear axle at -l_r, front at +l_f, +-track/2.
        half_track = 0.5 * car.wheel_track
        self._wheels = np.array([[car.cg_to_front, half_track], [car.cg_to_front, -half_track],
                                 [-car.cg_to_rear, half_track], [-car.cg_to_rear, -half_track]])
        self._wheel_reach = float(np.hypot(self._wheels[:, 0], self._wheels[:, 1]).max())
        self._lay_out()
        self._bot_duration = config.bot_lane_change_distance / config.bot_speed
        if self.num_bots:
            # Fail at construction, not at the first reset, when a lap cannot hold the bots.
            for t in tracks:
                spawn.bot_layout(t.length, np.random.default_rng(0), 1, self.num_bots, False,
                                 1, np.zeros(1), self._grid_length())
        self.max_cycles = config.max_cycles
        """Steps after which every car is truncated (the env may change it at run time)."""
        self.world: PhysicsWorld | None = None
        # The rules kernel's packed constants, built on the first step.
        self._rule_args: FloatArray | None = None
        self._allocate()

    def _alternated(self) -> bool:
        """Whether the next episode drives reversed under ``alternate_direction`` (odd
        episodes; every copy counts the same episodes, as they reset together)."""
        return bool(self.config.alternate_direction and self.episodes[0] % 2 == 1)

    def _grid_length(self) -> float:
        """How far the start grid reaches behind its first slot [m]."""
        cfg = self.config
        return cfg.grid_spacing * (self.num_cars - 1) + cfg.car.length


    @property
    def racing(self) -> BoolArray:
        """Cars neither done nor frozen by a penalty, (E, N) (a copy)."""
        return self._racing.copy()

    @property
    def frozen(self) -> BoolArray:
        """Cars serving a penalty, (E, N)."""
        return ~self.done & ~self._penalty_over()

    def _penalty_over(self) -> BoolArray:
        """Whether each car's penalty (if any) has been served, (E, N)."""
        return self.frozen_until <= self.time[:, None] + race.TIME_EPS

    @property
    def episode_progress(self) -> FloatArray:
        """Percent of a lap driven since the episode start, (E, N) (DeepRacer's progress)."""
        return (self.distance - self.start_distance) * (100.0 / self._length)[:, None]

    # ------------------------------------------------------------------ reset
    def reset(self, seed: int | None = None, slots: IntArray | None = None,
              start: FloatArray | None = None, reverse: bool | None = None,
              rolling: float = 0.0) -> None:
        """Reset every env copy and build a new pymunk Space.

        Args:
            seed: Seed of a new random generator; None keeps the current generator, so a
                later unseeded reset continues the seeded sequence deterministically. A seed
                also restarts the episode count (``episodes``) of the training starts, so the
                same seed gives the same first state.
            slots: Grid slot of each car, shape (N,) or (E, N); None draws them as
                ``config.grid`` says.
            start: Arc position of grid slot 0 in each copy, shape (E,) [m]; None puts it on
                the start line, or ``round_robin_advance`` of a lap further per episode already
                started with ``round_robin_starts``. Under ``race`` rules laps then count from
                that point (the race starts and finishes there); under ``training`` rules from
                each car's own start (DeepRacer's training starts round the lap). Distances
                stay measured from the track's start line, in the driving direction.
            reverse: Drive the track the other way round (True) or its own way (False); None
                follows ``alternate_direction`` (reversed on odd episodes) or else drives its
                own way. Arc positions, lanes and progress are then measured in the driving
                direction (``track`` is ``forward_track.reversed()``, same start line).
            rolling: Start speed of every car [m/s], in [0, ``car.max_speed``]: 0 is a standing
                start; above 0 a rolling start, each car moving straight along its heading
                with that speed commanded (``sim.starts.check_rolling`` checks it).
        """
        # Checked before anything is rebuilt, so a bad seed or speed leaves the core as it was.
        check_seed(seed)
        check_rolling(rolling, self.config.car.max_speed)
        if seed is not None:
            self.seed(seed)
            self.episodes[:] = 0
        self._set_direction(self._alternated() if reverse is None else bool(reverse))
        car = self.config.car
        self.world = PhysicsWorld(
            num_cars=self.num_envs * self.num_cars,
            num_obstacles=self.num_envs * self.num_obstacles,
            car_size=(car.length, car.width), car_mass=car.mass, car_inertia=car.yaw_inertia,
            obstacle_size=(self.config.obstacle_length, self.config.obstacle_width),
            friction=car.body_friction, elasticity=car.body_elasticity,
            num_bots=self.num_envs * self.num_bots, groups=self._collision_groups())
        self._allocate()
        self._spawn(np.ones(self.num_envs, dtype=bool), slots, start, rolling)

    def reset_envs(self, mask: BoolArray, slots: IntArray | None = None,
                   start: FloatArray | None = None, rolling: float = 0.0) -> None:
        """Reset the env copies where ``mask`` is True, keeping the others running.

        Args:
            mask: Which copies to reset, shape (E,).
            slots: Grid slots, shape (N,) or (sum(mask), N); None draws them.
            start: Arc position of slot 0 in each reset copy, shape (sum(mask),) [m] (see
                ``reset``).
            rolling: Start speed of the reset copies' cars [m/s] (see ``reset``).
        """
        if self.world is None:
            raise RuntimeError("call reset() before reset_envs()")
        mask = np.asarray(mask, dtype=bool)
        if not mask.any():
            return
        if self.config.alternate_direction:
            if not mask.all():
                raise ValueError(
                    "alternate_direction flips the driving direction of every env copy of a "
                    "core at once, so copies cannot be reset one by one; reset all of them "
                    "(reset_envs with an all-True mask, or reset()), or use round_robin_starts "
                    "without alternate_direction")
            self._set_direction(self._alternated())
        self._spawn(mask, slots, start, rolling)


    def _move_bots(self) -> None:
        """Advance the bots of every copy over the coming step and command their bodies.

        A copy's bot clock advances by the part of the step after its bots' pause (none once
        every car of the copy is done, when its clock stops too); the bodies get the velocity
        that carries them from their pose now to their pose at the end of the step.
        """
        cfg, tables = self.config, self.tables
        moved = self._bot_moved
        if bots.advance_clock_kernel(self.time, self.steps, self.done, self.bot_pause_until,
                                     self.dt, self.bot_clock, moved, self.bot_next_change):
            # Each track's generator draws for its own copies' changes.
            names = ("bot_clock", "bot_next_change", "bot_lane_from", "bot_lane",
                     "bot_change_start")
            for k, rows in self._track_rows():
                arrays = [getattr(self, name)[rows] for name in names]
                bots.schedule_lane_changes(*arrays, self._bot_duration, cfg.bot_lane_change_min,
                                           cfg.bot_lane_change_max, self.rngs[k])
                if not isinstance(rows, slice):  # fancy indexing copied them: write back
                    for name, array in zip(names, arrays):
                        getattr(self, name)[rows] = array
        bots.move_kernel(self.bot_start, self.bot_lane_from, self.bot_lane,
                         self.bot_change_start, self.bot_clock, moved, self._bot_duration,
                         cfg.bot_speed, 1.0 / self.dt, self.track_index, tables.scalars,
                         tables.fields, self.bot_distance, self.bot_s, self.bot_d,
                         self.bot_position, self.bot_yaw, self.bot_velocity, self.bot_speed,
                         self.world.bot_command)

    def _sync_physics(self, mask: BoolArray | None = None) -> None:
        """Write the pose and velocity of every body of the copies in ``mask`` (E,; None: of
        every copy) into pymunk (after their resets and teleports).

        The bodies of the other copies keep pymunk's own state, to the bit: writing theirs
        back from the core's arrays would nudge them (a bot is where its lane puts it, pymunk
        a rounding away; a car's position goes through its copy's world offset and back), so
        that one copy's re-placement would move the last bits of every other copy's race.
        """
        assert self.world is not None
        e, n, k, b = self.num_envs, self.num_cars, self.num_obstacles, self.num_bots
        car_pos = (self.position + self.env_offset[:, None, :]).reshape(-1, 2)
        obs_pos = (self.obstacle_position + self.env_offset[:, None, :]).reshape(-1, 2)
        bot_pos = (self.bot_position + self.env_offset[:, None, :]).reshape(-1, 2)
        position = np.concatenate([car_pos, obs_pos, bot_pos])
        angle = np.concatenate([self.yaw.reshape(-1), self.obstacle_yaw.reshape(-1),
                                self.bot_yaw.reshape(-1)])
        velocity = np.concatenate([self.velocity.reshape(-1, 2), np.zeros((e * k, 2)),
                                   self.bot_velocity.reshape(-1, 2)])
        angular = np.concatenate([self.yaw_rate.reshape(-1), np.zeros(e * k), np.zeros(e * b)])
        if mask is not None and not mask.all():
            keep = ~np.concatenate([np.repeat(mask, n), np.repeat(mask, k), np.repeat(mask, b)])
            state = self.world.state
            position[keep] = state[keep, 0:2]
            angle[keep] = state[keep, 2]
            velocity[keep] = state[keep, 3:5]
            angular[keep] = state[keep, 5]
        self.world.set_state(position, angle, velocity, angular)

    # ------------------------------------------------------------------ step
    def step(self, steer_command: FloatArray, speed_command: FloatArray) -> StepEvents:
        """Advance every env copy by one step.

        Args:
            steer_command: Commanded steering angle, (E, N), radians (clipped to the car's
                limit).
            speed_command: Commanded forward speed, (E, N), m/s.

        Returns:
            The events of the step. Cars that are done or frozen ignore their commands.
            The returned arrays belong to the caller (the core does not reuse them).
        """
        world = self.world
        if world is None:
            raise RuntimeError("call reset() before step()")
        cfg, rules, tables = self.config, self.rules, self.tables
        e, n = self.num_envs, self.num_cars
        dt = self.dt
        racing = self._racing
        self.steer_command = steer_command
        self.speed_command = speed_command

        # Phase 1: dynamics for all cars, the bots' scripted motion, then contacts and
        # integration in pymunk.
        if self.num_bots:
            self._move_bots()
        yaw, velocity, yaw_rate, steer = self._flat_dynamics
        self.model.step_into(yaw, velocity, yaw_rate, steer, steer_command.reshape(-1),
                             speed_command.reshape(-1), racing.reshape(-1), dt, world.command)
        world.step(dt, cfg.physics_substeps)

        # Phase 2: rules on the new snapshot, per car in one compiled pass.
        if self._rule_args is None:
            self._rule_args = race.pack_rule_scalars(self.dt, self.rules, self._wheel_reach)
        step_distance = np.empty((e, n))
        # One fresh block for the three flags (a compiled call costs per array argument).
        off_track, reversed_, immobilised = flags = np.empty((3, e, n), dtype=bool)
        laps = np.empty((e, n), dtype=np.int64)
        event, out_of_time = race.advance_cars(
            world.state, self.env_offset, self._wheels, racing, self.time, self.steps,
            rules.time_limit, self.max_cycles, self._car_vectors, self._car_floats,
            self._car_counts, self._car_flags, self._rule_args, self._points,
            self._point_track, self._selected, self._wheel_first, self._scratch,
            self.track_index, tables.scalars, tables.fields, tables.start, tables.cert,
            tables.tab, tables.tab_full, step_distance, flags, laps)
        contact_a, contact_b = world.pop_contacts()

        # Laps.
        lap_completed = laps > self.laps if event else self._no_cars
        if event and lap_completed.any():
            finished_now = self._complete_laps(lap_completed, laps, step_distance)
        else:
            finished_now = self._no_cars

        # Contacts.
        bot_events: list[tuple[int, int, int, bool]] = []
        bots_paused = None
        if contact_a.size:
            first_bot = e * (n + self.num_obstacles)
            with_bot = (contact_a >= first_bot) | (contact_b >= first_bot)
            crashed, collided, collision_events = race.judge_contacts(
                contact_a[~with_bot], contact_b[~with_bot], e, n, self.num_obstacles,
                self.distance, racing)
            if with_bot.any():
                bot_fault, bot_collided, bot_events, pause = race.judge_bot_contacts(
                    contact_a[with_bot], contact_b[with_bot], e, n, first_bot, self.num_bots,
                    self.s, self.bot_s, self._length, racing, self.done)
                crashed |= bot_fault
                collided |= bot_collided
                if pause.any():
                    # DeepRacer: every bot of the copy waits penalty_seconds.
                    bots_paused = pause
                    self.bot_pause_until = np.where(
                        pause, np.maximum(self.bot_pause_until, self.time + cfg.bot_penalty),
                        self.bot_pause_until)
                    self.bot_pauses += pause
            self.collisions += collided
            self.crashes += crashed
            event = True
        else:
            crashed = collided = self._no_cars
            collision_events = []
        obstacle_hits = [(env, car, k) for env, car, k, is_box in collision_events if is_box]

        # Overtakes and defences between cars racing before and after the step.
        passes: list[tuple[int, int, int]] = []
        overtakes_now = overtaken_now = defences_now = self._zero_counts
        if n > 1:
            still = racing & ~finished_now if event else racing
            # The kernel updates the previous gaps in place and fills the scratch flags.
            passed, defended = self._passed, self._defended
            any_passed, any_defended = race.pairs_kernel(
                self.distance, still, self.speed, self._pair_floats, self._pair_flags,
                self._length, dt, rules.defence_gap, rules.defence_time)
            if any_passed:
                overtakes_now = passed.sum(axis=2)
                overtaken_now = passed.sum(axis=1)
                self.overtakes += overtakes_now
                self.overtaken += overtaken_now
                passes = [tuple(x) for x in np.argwhere(passed).tolist()]
            if any_defended:
                defences_now = defended.sum(axis=1)
                self.defences += defences_now

        # Infractions: end the car's episode (training) or freeze it for a penalty (race).
        penalised = self._no_cars
        if event:
            self.off_tracks += off_track
            crash_infraction = crashed & rules.crash_is_infraction
            infraction = (off_track | crash_infraction | reversed_ | immobilised) & racing
            infraction &= ~finished_now
            if infraction.any():
                penalised = self._infractions(infraction, off_track, crash_infraction,
                                              reversed_, immobilised,
                                              self.distance - step_distance, obstacle_hits)

        # Time limit and lap target.
        terminated = truncated = self._no_cars
        if event:
            terminated = self.done & ~self._parked
        if out_of_time:
            ended = ((self.time >= rules.time_limit - race.TIME_EPS)
                     | (self.steps >= self.max_cycles))
            truncated = ended[:, None] & ~self.done
            self.done |= truncated

        # Put penalised cars back, park cars whose episode ended.
        replaced = self._no_cars
        if self._pending_any or event or out_of_time:
            replaced = self.pending_replace & ~self.done & self._penalty_over()
            newly_done = self.done & ~self._parked
            if replaced.any() or newly_done.any():
                if replaced.any():
                    replaced = self._replace(replaced)
                if newly_done.any():
                    self._park_cars(newly_done)
                self._sync_physics((replaced | newly_done).any(axis=1))
                # Gaps before the next step must see the re-placed cars where they now are.
                self._gap[...] = self.distance[:, :, None] - self.distance[:, None, :]
            self._pending_any = bool(self.pending_replace.any())
            self._racing = ~self.done & self._penalty_over()
        self._update_ranks()
        return StepEvents(
            terminated=terminated, truncated=truncated,
            off_track=off_track, crashed=crashed, collided=collided, reversed=reversed_,
            immobilised=immobilised, penalised=penalised, replaced=replaced,
            lap_completed=lap_completed, finished=finished_now, progress=step_distance,
            overtakes=overtakes_now, overtaken=overtaken_now, defences=defences_now,
            collisions=collision_events, passes=passes, bot_contacts=bot_events,
            bots_paused=bots_paused)

    def _complete_laps(self, completed: BoolArray, laps: IntArray,
                       step_distance: FloatArray) -> BoolArray:
        """Record lap times for cars that completed a lap; return those that finished."""
        rules = self.rules
        line = self.lap_origin + laps * self._length[:, None]
        cross = race.crossing_time(self.time[:, None], self.dt, self.distance, step_distance,
                                   line)
        lap_time = cross - self.lap_start_time
        valid = np.ones_like(completed)
        if rules.max_resets_per_lap is not None:
            valid = self.lap_resets <= rules.max_resets_per_lap
        self.last_lap_time[...] = np.where(completed, lap_time, self.last_lap_time)
        self.best_lap_time[...] = np.where(completed & valid,
                                           np.minimum(self.best_lap_time, lap_time),
                                           self.best_lap_time)
        for env, car in np.argwhere(completed).tolist():
            self.lap_times[env][car].append(float(lap_time[env, car]))
            self.lap_valid[env][car].append(bool(valid[env, car]))
        self.lap_start_time = np.where(completed, cross, self.lap_start_time)
        self.lap_resets = self.lap_resets * ~completed
        np.copyto(self.laps, laps, where=completed)
        finished = np.zeros_like(completed)
        if rules.laps > 0:
            finished = completed & (self.laps >= rules.laps)
            self.finished |= finished
            self.finish_time = np.where(finished, cross, self.finish_time)
            self.done |= finished
        return finished


    def _update_ranks(self) -> None:
        race._rank_kernel(self.distance, self.finished, self.finish_time, self.best_lap_time,
                          self.rules.ranking == "best_lap", self.rank)
