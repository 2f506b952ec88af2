"""Infractions in the batched core: ending or freezing cars, putting them back, parking them.

Training rules end a car's episode at an infraction; race rules freeze it for a time penalty
and then put it back on the first spot clear of every other body (``h2h_racing.sim.replacement``):
after leaving the track, reversing or stalling, on the lane nearest to where it stopped at its
last valid progress; after hitting a box, as DeepRacer does (``RESET_BEHIND_DIST``), 1 m
behind the box on the other lane, the one the box leaves clear. Cars whose episode ended are
parked off the track. ``RaceCore`` (``h2h_racing.sim.core``) mixes ``CorePenalties`` in.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from h2h_racing.sim import layouts as spawn
from h2h_racing.sim.replacement import (
    OBSTACLE_APPROACH,
    REPLACE_GAP,
    REPLACE_STEP,
    REPLACE_TRIES,
    RESET_BEHIND_OBSTACLE,
    place_kernel,
)
from h2h_racing.track.lookup import wrap_arc

if TYPE_CHECKING:
    from h2h_racing.track.shape import Track

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]


class CorePenalties:
    """Infraction consequences, re-placement and parking of ``RaceCore``'s cars (a mixin)."""

    def _infractions(self, infraction: BoolArray, off_track: BoolArray, crash: BoolArray,
                     reversed_: BoolArray, immobilised: BoolArray,
                     prev_distance: FloatArray,
                     obstacle_hits: list[tuple[int, int, int]]) -> BoolArray:
        """Apply the rules' consequence of each infraction; return the penalised cars.

        ``obstacle_hits`` are this step's ``(env, car, obstacle)`` contacts with a box."""
        rules = self.rules
        self.reverse_count *= ~infraction
        self.immobile_count *= ~infraction
        if rules.mode == "training":
            self.done |= infraction
            return self._no_cars
        penalty = np.maximum.reduce([
            off_track * rules.off_track_penalty,
            crash * rules.crash_penalty,
            reversed_ * rules.reversed_penalty,
            immobilised * rules.immobilised_penalty])
        self.penalties += infraction
        self.penalty_time += penalty * infraction
        self.frozen_until[...] = np.where(infraction, self.time[:, None] + penalty,
                                          self.frozen_until)
        self.pending_replace |= infraction
        self._pending_any = True
        # Off track, reversed or stuck: back to the last valid progress; a crash leaves the
        # car on the surface, where it is.
        back = off_track | reversed_ | immobilised
        self.replace_distance = np.where(
            infraction, np.where(back, prev_distance, self.distance), self.replace_distance)
        self.replace_lane[infraction] = 0.0
        # A crash into a box: RESET_BEHIND_OBSTACLE behind the box, on the lane it leaves
        # clear (DeepRacer). A few contacts per step at most: this loop is over contact events.
        for env, car, k in obstacle_hits:
            if crash[env, car] and infraction[env, car]:
                ahead = wrap_arc(self.obstacle_s[env, k] - self.s[env, car], self._length[env])
                self.replace_distance[env, car] = (self.distance[env, car] + ahead
                                                   - RESET_BEHIND_OBSTACLE)
                # The box's side of the centre line (0 for a box on it: the nearest lane).
                self.replace_lane[env, car] = -np.sign(self.obstacle_d[env, k])
        return infraction.copy()

    def _replace(self, mask: BoolArray) -> BoolArray:
        """Put frozen cars back at their re-placement distance, on their re-placement lane
        (or the nearest one), on the first candidate spot clear of every other body
        (``h2h_racing.sim.replacement``), one track at a time.

        A car with no clear spot stays frozen for one more step (the clock runs), parked off
        the track (``waiting``), and is tried again then. Returns the cars placed, (E, N).
        """
        placed = np.zeros_like(mask)
        for k, rows in self._track_rows(mask.any(axis=1)):
            chosen = np.zeros_like(mask)
            chosen[rows] = mask[rows]
            self._replace_on(self.tracks[k], chosen, placed)
        return placed

    def _replace_on(self, track: Track, mask: BoolArray, placed: BoolArray) -> None:
        """``_replace`` for the cars in ``mask``, all of copies racing ``track``; marks those
        placed in ``placed``."""
        cfg = self.config
        env_idx, car_idx = np.nonzero(mask)
        target = self.replace_distance[env_idx, car_idx]
        chosen = self.replace_lane[env_idx, car_idx]
        lane = np.where(chosen != 0.0, chosen,
                        np.where(self.d[env_idx, car_idx] >= 0.0, 1.0, -1.0))
        # After a box: up the clear lane towards the box first (OBSTACLE_APPROACH).
        forward = np.where(chosen != 0.0, OBSTACLE_APPROACH, 0.0)
        cand_dist, cand_lane = spawn.replacement_candidates(track, target, lane, REPLACE_STEP,
                                                            REPLACE_TRIES, forward)
        cand_s = np.mod(cand_dist, track.length)
        cand_d = spawn.lane_offset(track, cand_s, cand_lane)
        cand_pos = track.point_at(cand_s, cand_d)
        choice = np.empty(len(env_idx), dtype=np.int64)
        place_kernel(env_idx, car_idx, cand_pos, track.heading_at(cand_s), self.position,
                     self.yaw, self.obstacle_position, self.obstacle_yaw, self.bot_position,
                     self.bot_yaw, np.array([cfg.car.length, cfg.car.width]),
                     np.array([cfg.obstacle_length, cfg.obstacle_width]), REPLACE_GAP, choice)
        ok = choice >= 0
        if not ok.all():
            wait_env, wait_car = env_idx[~ok], car_idx[~ok]
            self.frozen_until[wait_env, wait_car] = self.time[wait_env] + self.dt
            self._wait_off_track(wait_env, wait_car)
        env_idx, car_idx, choice = env_idx[ok], car_idx[ok], choice[ok]
        rows = np.flatnonzero(ok)
        self.s[env_idx, car_idx] = cand_s[rows, choice]
        self.d[env_idx, car_idx] = cand_d[rows, choice]
        self.distance[env_idx, car_idx] = cand_dist[rows, choice]
        self.velocity[env_idx, car_idx] = 0.0
        self.yaw_rate[env_idx, car_idx] = 0.0
        self.steer[env_idx, car_idx] = 0.0
        self.speed[env_idx, car_idx] = 0.0
        self.pending_replace[env_idx, car_idx] = False
        self.waiting[env_idx, car_idx] = False
        self.resets[env_idx, car_idx] += 1
        self.lap_resets[env_idx, car_idx] += 1
        placed[env_idx, car_idx] = True

    def _wait_off_track(self, env_idx: IntArray, car_idx: IntArray) -> None:
        """Park cars that found no clear spot while they wait: left where they stopped, cars
        waiting next to each other could block each other's spots for good."""
        first = ~self.waiting[env_idx, car_idx]
        on_env, on_car = env_idx[first], car_idx[first]
        self.final_position[on_env, on_car] = self.position[on_env, on_car]
        self.final_yaw[on_env, on_car] = self.yaw[on_env, on_car]
        self.position[env_idx, car_idx] = self._park[env_idx, car_idx]
        self.velocity[env_idx, car_idx] = 0.0
        self.yaw_rate[env_idx, car_idx] = 0.0
        self.speed[env_idx, car_idx] = 0.0
        self.waiting[env_idx, car_idx] = True

    def _park_cars(self, mask: BoolArray) -> None:
        """Move cars whose episode ended off the track, where nobody can hit them."""
        env_idx, car_idx = np.nonzero(mask)
        # A waiting car is parked already; its last pose on the track is kept.
        on_track = ~self.waiting[env_idx, car_idx]
        on_env, on_car = env_idx[on_track], car_idx[on_track]
        self.final_position[on_env, on_car] = self.position[on_env, on_car]
        self.final_yaw[on_env, on_car] = self.yaw[on_env, on_car]
        self.waiting[env_idx, car_idx] = False
        self.position[env_idx, car_idx] = self._park[env_idx, car_idx]
        self.velocity[env_idx, car_idx] = 0.0
        self.yaw_rate[env_idx, car_idx] = 0.0
        self.speed[env_idx, car_idx] = 0.0
        self._parked[env_idx, car_idx] = True
