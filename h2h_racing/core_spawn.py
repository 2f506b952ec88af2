"""Starting episodes in the batched core: the start grid, obstacles and bots of reset copies.

``CoreSpawn._spawn`` puts the cars of the reset env copies on their grid slots (round-robin
starts included), clears their race records, and draws the copies' obstacles and bot lanes
from the core's one random generator. ``RaceCore`` (``h2h_racing.core``) mixes it in.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from h2h_racing import bots, spawn

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]


def check_rolling(rolling: object, max_speed: float) -> float:
    """``rolling`` as a float: a start speed in [0, ``max_speed``] m/s.

    Raises:
        ValueError: For anything else (a bool, a non-number, NaN, a negative speed or one
            above the car's top speed).
    """
    if (isinstance(rolling, bool) or not isinstance(rolling, (int, float, np.floating))
            or not 0.0 <= float(rolling) <= max_speed):
        raise ValueError(f"rolling must be a start speed in [0, {max_speed:g}] m/s (0 is a "
                         f"standing start; at most the car's max_speed), got {rolling!r}")
    return float(rolling)


class CoreSpawn:
    """Reset-time placement of ``RaceCore``'s cars, obstacles and bots (a mixin)."""

    def _spawn(self, mask: BoolArray, slots: IntArray | None,
               start: FloatArray | None = None, rolling: float = 0.0) -> None:
        cfg, track = self.config, self.track
        rolling = check_rolling(rolling, cfg.car.max_speed)
        m = int(mask.sum())
        n = self.num_cars
        if slots is None:
            slot = spawn.grid_assignment(self.rng, m, n, cfg.grid == "random")
        else:
            slot = np.broadcast_to(np.asarray(slots, dtype=np.int64), (m, n))
            if sorted(slot[0].tolist()) != list(range(n)):
                raise ValueError(f"slots must be a permutation of 0..{n - 1}, got {slot[0]}")
        offset, lane = spawn.grid_slots(n, cfg.grid_spacing, self.inner_sign)
        car_offset = offset[slot]
        line = np.zeros((m, 1))
        if start is None and cfg.round_robin_starts:
            # DeepRacer: start_ndist += ROUND_ROBIN_ADVANCE_DIST at every new episode.
            start = np.mod(self.episodes[mask] * cfg.round_robin_advance, 1.0) * track.length
        if start is not None:
            line = np.asarray(start, dtype=np.float64).reshape(m, 1)
            car_offset = car_offset + line
        self.episodes[mask] += 1
        car_lane = lane[slot]
        s = np.mod(car_offset, track.length)
        d = spawn.lane_offset(track, s, car_lane)
        pos, yaw = spawn.poses_on_track(track, s, d)
        self.position[mask] = pos
        self.yaw[mask] = yaw
        # A rolling start: every car moving straight along its yaw (the track's heading at its
        # slot), its speed controller already asking for that speed so it does not brake.
        self.velocity[mask] = rolling * np.stack([np.cos(yaw), np.sin(yaw)], axis=-1)
        self.yaw_rate[mask] = 0.0
        self.steer[mask] = 0.0
        self.speed[mask] = rolling
        self.steer_command[mask] = 0.0
        self.speed_command[mask] = rolling
        self.s[mask] = s
        self.d[mask] = d
        self.distance[mask] = car_offset
        self.start_distance[mask] = car_offset
        # Races count laps from the start line; training counts them from each car's start.
        self.lap_origin[mask] = car_offset if self.rules.mode == "training" else line
        for name in ("laps", "lap_resets", "resets", "penalties", "reverse_count",
                     "immobile_count", "off_tracks", "crashes", "collisions", "overtakes",
                     "overtaken", "defences"):
            getattr(self, name)[mask] = 0
        for name in ("lap_start_time", "penalty_time", "frozen_until", "replace_distance",
                     "replace_lane"):
            getattr(self, name)[mask] = 0.0
        for name in ("last_lap_time", "best_lap_time", "finish_time"):
            getattr(self, name)[mask] = np.inf
        self.pending_replace[mask] = False
        self.waiting[mask] = False
        self._parked[mask] = False
        self.done[mask] = False
        self.finished[mask] = False
        self.time[mask] = 0.0
        self.steps[mask] = 0
        self._pressure[mask] = 0.0
        self._faster[mask] = False
        for env in np.flatnonzero(mask).tolist():
            self.lap_times[env] = [[] for _ in range(n)]
            self.lap_valid[env] = [[] for _ in range(n)]
        if self.num_obstacles:
            obs_s, obs_lane = spawn.obstacle_layout(
                track, self.rng, m, self.num_obstacles, cfg.obstacle_positions,
                cfg.randomize_obstacles, self.inner_sign,
                grid_length=cfg.grid_spacing * (n - 1) + cfg.car.length,
                min_gap=cfg.obstacle_min_gap)
            obs_d = spawn.lane_offset(track, obs_s, obs_lane)
            opos, oyaw = spawn.poses_on_track(track, obs_s, obs_d)
            self.obstacle_s[mask] = np.mod(obs_s, track.length)
            self.obstacle_lane[mask] = obs_lane
            self.obstacle_d[mask] = obs_d
            self.obstacle_position[mask] = opos
            self.obstacle_yaw[mask] = oyaw
        if self.num_bots:
            self._spawn_bots(mask, line[:, 0])
        self._racing = ~self.done & self._penalty_over()
        self._pending_any = bool(self.pending_replace.any())
        self._update_ranks()
        self._gap[...] = self.distance[:, :, None] - self.distance[:, None, :]
        self._sync_physics()

    def _spawn_bots(self, mask: BoolArray, line: FloatArray) -> None:
        """Lay out the bots of the copies in ``mask`` from their start points ``line`` (M,)."""
        cfg, track = self.config, self.track
        m, b = int(mask.sum()), self.num_bots
        start, lane = spawn.bot_layout(track.length, self.rng, m, b, cfg.randomize_bots,
                                       self.inner_sign, line, self._grid_length())
        if cfg.bot_lane_change:
            # DeepRacer: the first change starts uniform(lower, upper) seconds after the start.
            first = self.rng.uniform(cfg.bot_lane_change_min, cfg.bot_lane_change_max, (m, b))
        else:
            first = np.full((m, b), np.inf)
        self.bot_clock[mask] = 0.0
        self.bot_pause_until[mask] = 0.0
        self.bot_pauses[mask] = 0
        self.bot_start[mask] = start
        self.bot_lane[mask] = lane
        self.bot_lane_from[mask] = lane
        self.bot_change_start[mask] = -np.inf
        self.bot_next_change[mask] = first
        self.bot_velocity[mask] = 0.0
        self.bot_speed[mask] = 0.0
        distance, s, d, position, yaw = bots.bot_poses(
            self.lookup, start, lane, lane, self.bot_change_start[mask], np.zeros(m),
            self._bot_duration, cfg.bot_speed)
        self.bot_distance[mask] = distance
        self.bot_s[mask] = s
        self.bot_d[mask] = d
        self.bot_position[mask] = position
        self.bot_yaw[mask] = yaw
