"""One track's copies of a core of several tracks, read as a core of that track alone.

A ``RaceCore`` over K tracks races copy e on ``tracks[track_index[e]]``. Code written for a
core of one track (the scripted and trained drivers, which read ``core.track``, the state
arrays and the sensors) drives the copies of track k through a ``CoreView``
(``RaceCore.track_views()``): the view has that track as its ``track``, one track's
``tables``, ``num_envs`` = its copies, and every per-copy array of the core cut to those copies
(a view of the core's memory when the copies are consecutive, as the default blocks are; a
copy otherwise). It reads the core as it is now: build it once, use it every step. It is for
reading: stepping or resetting goes through the core.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from h2h_racing.track.shape import Track
    from h2h_racing.track.tables import TrackTables

PER_COPY = frozenset((
    # The per-car fields (views into the core's blocks), (E, N, ...).
    "position", "velocity", "yaw", "yaw_rate", "steer", "speed", "s", "d", "distance",
    "start_distance", "lap_origin", "last_lap_time", "best_lap_time", "frozen_until", "laps",
    "reverse_count", "immobile_count", "resets", "penalties", "overtakes", "overtaken",
    "defences", "rank", "done", "finished", "_gap", "_pressure", "_faster", "_passed",
    "_defended",
    # The other per-copy arrays and lists, (E, ...).
    "steer_command", "speed_command", "lap_start_time", "lap_times", "lap_valid", "lap_resets",
    "penalty_time", "pending_replace", "waiting", "replace_distance", "replace_lane",
    "finish_time", "off_tracks", "crashes", "collisions", "time", "steps", "obstacle_s",
    "obstacle_lane", "obstacle_d", "obstacle_position", "obstacle_yaw", "bot_clock",
    "bot_pause_until", "bot_pauses", "bot_start", "bot_distance", "bot_s", "bot_d", "bot_lane",
    "bot_lane_from", "bot_change_start", "bot_next_change", "bot_position", "bot_yaw",
    "bot_velocity", "bot_speed", "_bot_moved", "final_position", "final_yaw", "_parked",
    "_no_cars", "_zero_counts", "_racing", "episodes", "env_offset", "_park", "_length",
    # Properties computed per copy.
    "racing", "frozen", "episode_progress", "lengths"))
"""Attributes of ``RaceCore`` with one entry per env copy on their first axis."""
BLOCKS = frozenset(("_car_vectors", "_car_floats", "_car_counts", "_car_flags", "_pair_floats",
                    "_pair_flags"))
"""The blocks of per-car fields: one row per field, then the env copies (axis 1)."""
SHARED = frozenset(("config", "rules", "num_cars", "num_obstacles", "num_bots", "dt", "model",
                    "max_cycles", "is_reversed", "_wheels", "_wheel_reach", "_bot_duration"))
"""Attributes every copy shares, read from the core as they are."""


class CoreView:
    """The copies ``rows`` of track ``track_number`` of ``core``, read as a one-track core.

    Args:
        core: The core.
        track_number: The track's index in ``core.tracks``.
        rows: Its copies: a slice, or their indices in increasing order.
    """

    num_tracks = 1

    def __init__(self, core: Any,  # a RaceCore: not imported, it imports this module
                 track_number: int,
                 rows: slice | npt.NDArray[np.int64]) -> None:
        self._core = core
        self._rows = rows
        self.track_number = track_number
        """The track's index in the core's ``tracks``."""
        self.num_envs = len(range(core.num_envs)[rows]) if isinstance(rows, slice) else len(rows)
        """The track's copies."""
        self.track_index = np.zeros(self.num_envs, dtype=np.int64)
        self._tables: TrackTables | None = None

    def __getattr__(self, name: str) -> Any:
        core = self.__dict__.get("_core")
        if core is None:  # not initialised (unpickling): no attribute is there yet
            raise AttributeError(name)
        rows = self._rows
        if name in PER_COPY:
            value = getattr(core, name)
            if isinstance(value, list) and not isinstance(rows, slice):
                return [value[e] for e in rows.tolist()]
            return value[rows]
        if name in BLOCKS:
            return getattr(core, name)[:, rows]
        if name in SHARED:
            return getattr(core, name)
        raise AttributeError(
            f"a CoreView (the copies of track {self.track_number} of a RaceCore) reads the "
            f"core's state and shared settings; it has no {name!r}: step, reset and seed the "
            f"core itself")

    @property
    def track(self) -> Track:
        """The track, in the current driving direction."""
        return self._core.tracks[self.track_number]

    @property
    def forward_track(self) -> Track:
        """The track as given to the core."""
        return self._core.forward_tracks[self.track_number]

    @property
    def tracks(self) -> tuple[Track, ...]:
        return (self.track,)

    @property
    def forward_tracks(self) -> tuple[Track, ...]:
        return (self.forward_track,)

    @property
    def tables(self) -> TrackTables:
        """The track's tables alone (``TrackTables.subset``)."""
        tables = self._core.tables
        if self._tables is None or self._tables.tracks[0] is not self.track:
            self._tables = tables.subset(self.track_number)
        return self._tables

    @property
    def inner_sign(self) -> int:
        """+1 when the inside of the loop is on the left of travel, else -1."""
        return int(self._core.tables.inner_signs[self.track_number])

    @property
    def rng(self) -> np.random.Generator:
        """The track's random generator."""
        return self._core.rngs[self.track_number]

    @property
    def rngs(self) -> list[np.random.Generator]:
        return [self.rng]
