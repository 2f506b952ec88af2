"""The batched core's state layout: every array of ``RaceCore`` and how it pickles.

The per-car fields the compiled kernels read and write every step are rows of a few blocks
(``race.CAR_*``, ``race.PAIR_*``), and each field is a view into its block. ``CoreState``
allocates them, cuts the views, and pickles only the blocks (re-cutting the views on arrival,
which a plain pickle would cut off their blocks). ``RaceCore`` (``h2h_racing.sim.core``) mixes
it in.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from h2h_racing.sim import race

_BLOCKS = (("_car_vectors", race.CAR_VECTORS), ("_car_floats", race.CAR_FLOATS),
           ("_car_counts", race.CAR_COUNTS), ("_car_flags", race.CAR_FLAGS),
           ("_pair_floats", race.PAIR_FLOATS), ("_pair_flags", race.PAIR_FLAGS))
"""Each block of per-car (and per-pair) fields and the fields in its rows, in order."""


class CoreState:
    """``RaceCore``'s arrays: allocation, the block views and pickling (a mixin; the core
    sets ``num_envs``, ``num_cars``, ``num_obstacles``, ``num_bots`` and ``_wheels`` first)."""

    def _allocate(self) -> None:
        e, n, k, b = self.num_envs, self.num_cars, self.num_obstacles, self.num_bots
        zeros = np.zeros
        # The per-car fields the compiled kernels read and write every step are rows of four
        # blocks (race.CAR_*), so that a kernel takes a block, not an array per field (a
        # compiled call costs about 80 ns per array argument). Every field is a view into
        # its block: update them in place, never rebind them.
        self._car_vectors = zeros((len(race.CAR_VECTORS), e, n, 2))
        self._car_floats = zeros((len(race.CAR_FLOATS), e, n))
        self._car_counts = zeros((len(race.CAR_COUNTS), e, n), dtype=np.int64)
        self._car_flags = zeros((len(race.CAR_FLAGS), e, n), dtype=bool)
        self.position = self._field("position")
        """Car positions in track coordinates, (E, N, 2), metres."""
        self.yaw = self._field("yaw")
        """Car headings, (E, N), radians."""
        self.velocity = self._field("velocity")
        """World-frame velocities, (E, N, 2), m/s."""
        self.yaw_rate = self._field("yaw_rate")
        """Yaw rates, (E, N), rad/s."""
        self.steer = self._field("steer")
        """Front steering angles, (E, N), radians."""
        self.speed = self._field("speed")
        """Forward (body-frame) speed, (E, N), m/s."""
        self.steer_command = zeros((e, n))
        """Last commanded steering angle, (E, N), radians."""
        self.speed_command = zeros((e, n))
        """Last commanded speed, (E, N), m/s."""
        self.s = self._field("s")
        """Arc position on the centre line, (E, N), metres in [0, L)."""
        self.d = self._field("d")
        """Signed lateral offset from the centre line, (E, N), metres, left positive."""
        self.distance = self._field("distance")
        """Unwrapped race distance from the start line, (E, N), metres."""
        self.start_distance = self._field("start_distance")
        """Race distance at the start of the episode, (E, N), metres."""
        self.lap_origin = self._field("lap_origin")
        """Distance from which laps are counted (start line in races), (E, N), metres."""
        self.laps = self._field("laps")
        """Completed laps, (E, N)."""
        self.lap_start_time = zeros((e, n))
        """Simulated time at which the current lap started, (E, N), seconds."""
        self.last_lap_time = self._field("last_lap_time")
        self.last_lap_time[...] = np.inf
        """Time of the last completed lap, (E, N), seconds (inf: none yet)."""
        self.best_lap_time = self._field("best_lap_time")
        self.best_lap_time[...] = np.inf
        """Best valid lap time, (E, N), seconds (inf: none yet)."""
        self.lap_times: list[list[list[float]]] = [[[] for _ in range(n)] for _ in range(e)]
        """Lap times of every car, ``lap_times[env][car]``, seconds (few appends per lap)."""
        self.lap_valid: list[list[list[bool]]] = [[[] for _ in range(n)] for _ in range(e)]
        """Whether each lap was valid (resets within the limit)."""
        self.lap_resets = zeros((e, n), dtype=np.int64)
        """Resets during the current lap, (E, N)."""
        self.resets = self._field("resets")
        """Resets (re-placements) over the episode, (E, N)."""
        self.penalties = self._field("penalties")
        """Time penalties received, (E, N)."""
        self.penalty_time = zeros((e, n))
        """Total penalty seconds received, (E, N)."""
        self.frozen_until = self._field("frozen_until")
        """Simulated time until which a penalised car is frozen, (E, N), seconds."""
        self.pending_replace = zeros((e, n), dtype=bool)
        """The car is frozen and will be put back on track when its penalty ends."""
        self.waiting = zeros((e, n), dtype=bool)
        """The car served its penalty but found no re-placement spot clear of every body: it
        waits, frozen and parked off the track (so it blocks nobody), until one clears;
        ``final_position`` and ``final_yaw`` hold its last pose on the track, (E, N)."""
        self.replace_distance = zeros((e, n))
        """Race distance at which a penalised car is put back, (E, N), metres."""
        self.replace_lane = zeros((e, n))
        """Lane a penalised car is put back on first, (E, N): +1 left, -1 right, 0 the lane
        nearest to where it stopped."""
        self.done = self._field("done")
        """The car's episode is over (finished, retired or truncated); it is parked."""
        self.finished = self._field("finished")
        """The car reached the lap target."""
        self.finish_time = np.full((e, n), np.inf)
        """Simulated time at which the car finished, (E, N), seconds."""
        self.reverse_count = self._field("reverse_count")
        self.immobile_count = self._field("immobile_count")
        self.off_tracks = zeros((e, n), dtype=np.int64)
        """Off-track infractions over the episode, (E, N)."""
        self.crashes = zeros((e, n), dtype=np.int64)
        """Crashes at fault over the episode, (E, N)."""
        self.collisions = zeros((e, n), dtype=np.int64)
        """Contacts of any kind over the episode, (E, N)."""
        self.overtakes = self._field("overtakes")
        """On-track passes made over the episode, (E, N)."""
        self.overtaken = self._field("overtaken")
        """Times passed over the episode, (E, N)."""
        self.defences = self._field("defences")
        """Defences over the episode, (E, N)."""
        self.rank = self._field("rank")
        """Race position, 1 = leader, (E, N)."""
        self.rank[...] = 1
        self._flatten_dynamics()
        self.time = zeros(e)
        """Simulated time of each env copy, (E,), seconds."""
        self.steps = zeros(e, dtype=np.int64)
        """Steps taken in the episode of each env copy, (E,)."""
        self.obstacle_s = zeros((e, k))
        """Arc position of each obstacle, (E, K), metres."""
        self.obstacle_lane = zeros((e, k))
        """Lane of each obstacle, (E, K): +1 left, -1 right."""
        self.obstacle_d = zeros((e, k))
        """Lateral offset of each obstacle from the centre line, (E, K), metres."""
        self.obstacle_position = zeros((e, k, 2))
        """Obstacle centres in track coordinates, (E, K, 2), metres."""
        self.obstacle_yaw = zeros((e, k))
        """Obstacle headings, (E, K), radians."""
        self.bot_clock = zeros(e)
        """Seconds the bots of each copy have driven (their pauses excluded), (E,)."""
        self.bot_pause_until = zeros(e)
        """Simulated time until which the bots of each copy stand still, (E,), seconds."""
        self.bot_pauses = zeros(e, dtype=np.int64)
        """Bot pauses (a bot ran into a car ahead) over the episode, (E,)."""
        self.bot_start = zeros((e, b))
        """Unwrapped arc position of each bot at the start of the episode, (E, B), metres."""
        self.bot_distance = zeros((e, b))
        """Unwrapped arc position, ``bot_start + bot_speed * bot_clock``, (E, B), metres."""
        self.bot_s = zeros((e, b))
        """Arc position on the centre line, (E, B), metres in [0, L)."""
        self.bot_d = zeros((e, b))
        """Signed lateral offset from the centre line, (E, B), metres, left positive."""
        self.bot_lane = zeros((e, b))
        """Lane each bot is in, or heading to during a lane change, (E, B): +1 left, -1 right."""
        self.bot_lane_from = zeros((e, b))
        """Lane each bot's last lane change started from, (E, B) (equal to ``bot_lane``
        before the first change)."""
        self.bot_change_start = np.full((e, b), -np.inf)
        """Bot clock at which the last lane change started, (E, B), seconds (-inf: none)."""
        self.bot_next_change = np.full((e, b), np.inf)
        """Bot clock at which the next lane change starts, (E, B), seconds (inf: never)."""
        self.bot_position = zeros((e, b, 2))
        """Bot centres in track coordinates, (E, B, 2), metres."""
        self.bot_yaw = zeros((e, b))
        """Bot headings, (E, B), radians in [-pi, pi)."""
        self.bot_velocity = zeros((e, b, 2))
        """Bot velocities over the last step, (E, B, 2), m/s (world frame)."""
        self.bot_speed = zeros((e, b))
        """Bot speed along the track over the last step, (E, B), m/s (0 while paused)."""
        self._bot_moved = zeros(e)
        self.final_position = zeros((e, n, 2))
        """Where each car was when its episode ended, before it was parked, (E, N, 2), metres
        (logs and DeepRacer params of the last step read it; stale while the car races)."""
        self.final_yaw = zeros((e, n))
        """Heading of each car when its episode ended, (E, N), radians."""
        self._parked = zeros((e, n), dtype=bool)
        # Scratch for the per-step projection: every car's centre, then the wheels of the
        # cars near an edge.
        capacity = e * n * (1 + len(self._wheels))
        self._points = zeros((capacity, 2))
        self._point_track = zeros(capacity, dtype=np.int64)
        self._selected = zeros(capacity, dtype=bool)
        # Rows: each car's displacement this step, then the s and d of the projected points.
        self._scratch = zeros((3, capacity))
        self._wheel_first = zeros(e * n, dtype=np.int64)
        self._no_cars = zeros((e, n), dtype=bool)
        self._no_cars.flags.writeable = False
        self._zero_counts = zeros((e, n), dtype=np.int64)
        self._zero_counts.flags.writeable = False
        self._racing = np.ones((e, n), dtype=bool)
        self._pending_any = False
        # The pair kernel's arrays, (E, N, N) rows of two blocks (race.PAIR_*).
        self._pair_floats = zeros((len(race.PAIR_FLOATS), e, n, n))
        self._pair_flags = zeros((len(race.PAIR_FLAGS), e, n, n), dtype=bool)
        for _, names in _BLOCKS[4:]:
            for name in names:
                setattr(self, name, self._field(name))

    def _field(self, name: str) -> npt.NDArray[np.generic]:
        """The view of the per-car field ``name`` in its block (see ``_allocate``)."""
        for block, names in _BLOCKS:
            if name in names:
                return getattr(self, block)[names.index(name)]
        raise KeyError(name)

    def _flatten_dynamics(self) -> None:
        # The dynamics kernel's (C,) views of the car state, cut once (it runs every step).
        self._flat_dynamics = (self.yaw.reshape(-1), self.velocity.reshape(-1, 2),
                               self.yaw_rate.reshape(-1), self.steer.reshape(-1))

    def __getstate__(self) -> dict[str, object]:
        # Pickling copies every array on its own, which would cut the fields off their
        # blocks: only the blocks travel, and the views are cut again on arrival.
        state = self.__dict__.copy()
        for _, names in _BLOCKS:
            for name in names:
                del state[name]
        del state["_flat_dynamics"]
        state["_views"] = None  # rebuilt on demand
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        for _, names in _BLOCKS:
            for name in names:
                setattr(self, name, self._field(name))
        self._flatten_dynamics()
