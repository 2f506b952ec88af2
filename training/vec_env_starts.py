"""Training starts of a ``RacingVecEnv``: random points of the lap, clear of the boxes.

Training starts: ``random_starts`` (the default) starts each episode of a copy at a random
point of the lap; ``EnvConfig.round_robin_starts`` instead moves each copy's start
``round_robin_advance`` of a lap further at every reset of that copy (DeepRacer's training
starts; each copy counts its own episodes, the first on the start line) and takes precedence.
``EnvConfig.alternate_direction`` is refused: the copies of one core share a driving direction
but reset one at a time (see ``RacingVecEnv``).

Bot cars (``race_type="head_to_bot"`` or ``num_bots``) drive in every copy; the learner's state
observation sees them in its opponent slots (the ``critic`` group's privileged part lists the
other cars only). Boxes (``race_type="object_avoidance"`` or ``num_obstacles``) and bots are
drawn per copy by the core at each of that copy's resets, from the VecEnv's seeded generator:
with ``randomize_obstacles`` / ``randomize_bots`` every copy and every episode gets its own
layout, as DeepRacer re-draws them per episode. A copy whose training start put a car on a box
or right behind one (``BOX_CLEAR_BEHIND``, ``BOX_CLEAR_AHEAD``) is reset again with a new start
and new boxes (up to ``START_TRIES`` times, then on the start line, which the core keeps
clear): otherwise about one episode in six would start in a crash (speedway, 6 boxes).

With ``tight_boxes`` (``[race] tight_box_share``) a share of the reset copies then get one
box moved to a tight place of the lap (``h2h_racing.training.tight_boxes``), before the starts
are checked.

With several tracks each copy's start is drawn by its track's generator (the copies of a track
in order), as a VecEnv of that track alone draws them.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from h2h_racing.training.tight_boxes import tight_places, tighten

BOX_CLEAR_BEHIND = 0.6
"""A box whose centre is less than this behind a car's centre at its start blocks that start
[m] (the box's half length 0.25 m plus the car's half length 0.16 m, and a margin)."""
BOX_CLEAR_AHEAD = 1.5
"""A box whose centre is less than this ahead of a car's centre at its start blocks that start
[m]: room to steer round it from standstill."""
START_TRIES = 16
"""Draws of a clear start per reset copy before it starts on the start line."""


class VecEnvStarts:
    """Where ``RacingVecEnv``'s copies start their episodes (a mixin; it reads ``core``,
    ``random_starts``, ``config`` and ``tight_boxes``, and keeps each track's tight places in
    ``_tight_places``: track index -> (the track, its ``tight_places``))."""

    def _clear_starts(self, mask: npt.NDArray[np.bool_]) -> None:
        """Reset again the copies in ``mask`` whose start has a box on or just ahead of a car,
        with new starts (and new boxes when randomised); after ``START_TRIES`` draws the
        copies still blocked start on the start line, clear of the core's boxes."""
        core = self.core
        if not core.num_obstacles:
            return
        self._tighten_boxes(mask)
        for tries in range(START_TRIES + 1):
            blocked = mask & self._blocked_starts()
            if not blocked.any():
                return
            start = self._starts(blocked) if tries < START_TRIES else np.zeros(blocked.sum())
            core.reset_envs(blocked, start=start)
            self._tighten_boxes(blocked)

    def _tighten_boxes(self, mask: npt.NDArray[np.bool_]) -> None:
        """Move a box of a ``tight_boxes.share`` of the copies in ``mask`` (just reset) to a
        tight place of their track (``h2h_racing.training.tight_boxes``), each track's copies
        drawn by its own generator; nothing, and no draw, without ``tight_boxes`` or at share 0."""
        settings = self.tight_boxes
        if settings is None or settings.share <= 0:
            return
        core, cfg = self.core, self.core.config
        grid = cfg.grid_spacing * (core.num_cars - 1) + cfg.car.length
        cache = self._tight_places
        for k in np.unique(core.track_index[mask]).tolist():
            rows = np.flatnonzero(mask & (core.track_index == k))
            track = core.tracks[k]
            # Keyed by the track object: set_tracks replaces it when the track changes.
            if k not in cache or cache[k][0] is not track:
                cache[k] = (track, tight_places(track, settings.room, cfg.obstacle_length,
                                                cfg.obstacle_width, grid))
            s, lane, moved = tighten(core.obstacle_s[rows], core.obstacle_lane[rows],
                                     cache[k][1], core.rngs[k], settings.share,
                                     cfg.obstacle_min_gap)
            if moved:
                core.move_obstacles(rows, s, lane)

    def _blocked_starts(self) -> npt.NDArray[np.bool_]:
        """Copies with a box centre within ``BOX_CLEAR_BEHIND`` behind or ``BOX_CLEAR_AHEAD``
        ahead of a car along the lap, on either lane, (E,)."""
        core = self.core
        gap = np.mod(core.obstacle_s[:, None, :] - core.s[:, :, None] + BOX_CLEAR_BEHIND,
                     core.lengths[:, None, None])
        return (gap < BOX_CLEAR_BEHIND + BOX_CLEAR_AHEAD).any(axis=(1, 2))

    def _starts(self, mask: npt.NDArray[np.bool_]) -> npt.NDArray[np.float64] | None:
        """Random start points of the copies in ``mask``, each drawn by its track's generator
        (in copy order), or None: the core places them (the line, or round-robin starts)."""
        if not self.random_starts or self.config.round_robin_starts:
            return None
        core = self.core
        index = core.track_index[mask]
        starts = np.empty(len(index))
        for k in np.unique(index).tolist():
            pick = index == k
            starts[pick] = core.rngs[k].uniform(0.0, core.tracks[k].length, int(pick.sum()))
        return starts
