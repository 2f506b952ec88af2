"""Starting episodes in the batched core: the start grid, obstacles and bots of reset copies.

``CoreSpawn._spawn`` puts the cars of the reset env copies on their grid slots (round-robin
starts included), clears their race records, and draws the copies' obstacles and bot lanes,
one track at a time: each track's copies from that track's random generator, as a core of that
track alone would. ``RaceCore`` (``h2h_racing.sim.core``) mixes it in.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from h2h_racing.sim import bots, layouts as spawn

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
        cfg = self.config
        rolling = check_rolling(rolling, cfg.car.max_speed)
        m = int(mask.sum())
        n = self.num_cars
        # Checked for every reset copy before any is placed, so bad slots change nothing.
        slot = None
        if slots is not None:
            slot = np.broadcast_to(np.asarray(slots, dtype=np.int64), (m, n))
            bad = np.flatnonzero((np.sort(slot, axis=1) != np.arange(n)).any(axis=1))
            if bad.size:
                raise ValueError(f"slots must be a permutation of 0..{n - 1}, got "
                                 f"{slot[bad[0]]}")
        line = None if start is None else np.asarray(start, dtype=np.float64).reshape(m)
        order = self.track_index[mask]
        for k, rows in self._track_rows(mask):
            pick = order == k
            self._spawn_track(k, rows, None if slot is None else slot[pick],
                              None if line is None else line[pick], rolling)
        self._racing = ~self.done & self._penalty_over()
        self._pending_any = bool(self.pending_replace.any())
        self._update_ranks()
        self._gap[...] = self.distance[:, :, None] - self.distance[:, None, :]
        self._sync_physics(mask)

    def _spawn_track(self, k: int, rows: IntArray, slot: IntArray | None,
                     start: FloatArray | None, rolling: float) -> None:
        """Start new episodes in the copies ``rows`` of track ``k`` (see ``RaceCore.reset``)."""
        cfg, track, rng = self.config, self.tracks[k], self.rngs[k]
        inner_sign = int(self.tables.inner_signs[k])
        m = len(rows)
        n = self.num_cars
        if slot is None:
            slot = spawn.grid_assignment(rng, m, n, cfg.grid == "random")
        offset, lane = spawn.grid_slots(n, cfg.grid_spacing, inner_sign)
        car_offset = offset[slot]
        line = np.zeros((m, 1))
        if start is None and cfg.round_robin_starts:
            # DeepRacer: start_ndist += ROUND_ROBIN_ADVANCE_DIST at every new episode.
            start = np.mod(self.episodes[rows] * cfg.round_robin_advance, 1.0) * track.length
        if start is not None:
            line = np.asarray(start, dtype=np.float64).reshape(m, 1)
            car_offset = car_offset + line
        self.episodes[rows] += 1
        car_lane = lane[slot]
        s = np.mod(car_offset, track.length)
        d = spawn.lane_offset(track, s, car_lane)
        pos, yaw = spawn.poses_on_track(track, s, d)
        self.position[rows] = pos
        self.yaw[rows] = yaw
        # A rolling start: every car moving straight along its yaw (the track's heading at its
        # slot), its speed controller already asking for that speed so it does not brake.
        self.velocity[rows] = rolling * np.stack([np.cos(yaw), np.sin(yaw)], axis=-1)
        self.yaw_rate[rows] = 0.0
        self.steer[rows] = 0.0
        self.speed[rows] = rolling
        self.steer_command[rows] = 0.0
        self.speed_command[rows] = rolling
        self.s[rows] = s
        self.d[rows] = d
        self.distance[rows] = car_offset
        self.start_distance[rows] = car_offset
        # Races count laps from the start line; training counts them from each car's start.
        self.lap_origin[rows] = car_offset if self.rules.mode == "training" else line
        for name in ("laps", "lap_resets", "resets", "penalties", "reverse_count",
                     "immobile_count", "off_tracks", "crashes", "collisions", "overtakes",
                     "overtaken", "defences"):
            getattr(self, name)[rows] = 0
        for name in ("lap_start_time", "penalty_time", "frozen_until", "replace_distance",
                     "replace_lane"):
            getattr(self, name)[rows] = 0.0
        for name in ("last_lap_time", "best_lap_time", "finish_time"):
            getattr(self, name)[rows] = np.inf
        self.pending_replace[rows] = False
        self.waiting[rows] = False
        self._parked[rows] = False
        self.done[rows] = False
        self.finished[rows] = False
        self.time[rows] = 0.0
        self.steps[rows] = 0
        self._pressure[rows] = 0.0
        self._faster[rows] = False
        for env in rows.tolist():
            self.lap_times[env] = [[] for _ in range(n)]
            self.lap_valid[env] = [[] for _ in range(n)]
        if self.num_obstacles:
            obs_s, obs_lane = spawn.obstacle_layout(
                track, rng, m, self.num_obstacles, cfg.obstacle_positions,
                cfg.randomize_obstacles, inner_sign,
                grid_length=cfg.grid_spacing * (n - 1) + cfg.car.length,
                min_gap=cfg.obstacle_min_gap)
            obs_d = spawn.lane_offset(track, obs_s, obs_lane)
            opos, oyaw = spawn.poses_on_track(track, obs_s, obs_d)
            self.obstacle_s[rows] = np.mod(obs_s, track.length)
            self.obstacle_lane[rows] = obs_lane
            self.obstacle_d[rows] = obs_d
            self.obstacle_position[rows] = opos
            self.obstacle_yaw[rows] = oyaw
        if self.num_bots:
            self._spawn_bots(k, rows, line[:, 0])

    def move_obstacles(self, rows: IntArray, s: FloatArray, lane: FloatArray) -> None:
        """Put the boxes of the copies ``rows`` (R,) at arc positions ``s`` (R, K) [m] on lanes
        ``lane`` (R, K) (+1 left, -1 right) and write them into pymunk. For training's tight
        boxes (``h2h_racing.training.tight_boxes``), which move a box after a reset placed it;
        the env's own placement never calls it."""
        rows = np.asarray(rows, dtype=np.int64)
        s = np.asarray(s, dtype=np.float64)
        lane = np.asarray(lane, dtype=np.float64)
        for k in np.unique(self.track_index[rows]).tolist():
            pick = self.track_index[rows] == k
            track, at = self.tracks[k], rows[pick]
            obs_s = np.mod(s[pick], track.length)
            obs_d = spawn.lane_offset(track, obs_s, lane[pick])
            opos, oyaw = spawn.poses_on_track(track, obs_s, obs_d)
            self.obstacle_s[at] = obs_s
            self.obstacle_lane[at] = lane[pick]
            self.obstacle_d[at] = obs_d
            self.obstacle_position[at] = opos
            self.obstacle_yaw[at] = oyaw
        mask = np.zeros(self.num_envs, dtype=bool)
        mask[rows] = True
        self._sync_physics(mask)

    def _spawn_bots(self, k: int, rows: IntArray, line: FloatArray) -> None:
        """Lay out the bots of the copies ``rows`` of track ``k`` from their start points
        ``line`` (M,)."""
        cfg, track, rng = self.config, self.tracks[k], self.rngs[k]
        m, b = len(rows), self.num_bots
        start, lane = spawn.bot_layout(track.length, rng, m, b, cfg.randomize_bots,
                                       int(self.tables.inner_signs[k]), line,
                                       self._grid_length())
        if cfg.bot_lane_change:
            # DeepRacer: the first change starts uniform(lower, upper) seconds after the start.
            first = rng.uniform(cfg.bot_lane_change_min, cfg.bot_lane_change_max, (m, b))
        else:
            first = np.full((m, b), np.inf)
        self.bot_clock[rows] = 0.0
        self.bot_pause_until[rows] = 0.0
        self.bot_pauses[rows] = 0
        self.bot_start[rows] = start
        self.bot_lane[rows] = lane
        self.bot_lane_from[rows] = lane
        self.bot_change_start[rows] = -np.inf
        self.bot_next_change[rows] = first
        self.bot_velocity[rows] = 0.0
        self.bot_speed[rows] = 0.0
        distance, s, d, position, yaw = bots.bot_poses(
            self.tables, self.track_index[rows], start, lane, lane, self.bot_change_start[rows],
            np.zeros(m), self._bot_duration, cfg.bot_speed)
        self.bot_distance[rows] = distance
        self.bot_s[rows] = s
        self.bot_d[rows] = d
        self.bot_position[rows] = position
        self.bot_yaw[rows] = yaw
