"""Which track each env copy of the batched core races: the tracks, their tables, generators
and views.

A ``RaceCore`` races K tracks (K = 1: a one-track core, the same code): copy e races
``tracks[track_index[e]]``. ``CoreTracks`` holds the tracks (in the current driving direction),
their tables for the compiled kernels (``TrackTables``), the copies' world layout, one random
generator per track, and the one-track views of each track's copies (``sim.view``).
``RaceCore`` (``h2h_racing.sim.core``) mixes it in.

The layout: by default each copy is a cell of the shared pymunk Space that holds any of the
tracks. Overlaid (``RaceCore(overlay=True)``), each track's copies lie where a core of that
track alone would put them, over the other tracks' copies, and pymunk's collision categories
keep the tracks apart (at most ``MAX_OVERLAID_TRACKS``): pymunk works in world coordinates, so
only there are a copy's last bits those of its own core (``training.evaluate_tracks``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from h2h_racing.config.checks import check_seed
from h2h_racing.sim.physics import MAX_GROUPS
from h2h_racing.sim.view import CoreView
from h2h_racing.track.shape import Track
from h2h_racing.track.tables import TrackTables

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]

ENV_GAP = 30.0
"""Empty space between the bounding boxes of neighbouring env copies in the shared Space [m]."""
PARK_MARGIN = 1.0
"""Parked cars wait this far beyond the track's bounding box [m] (inside the projection
grid's margin, so projecting them stays cheap)."""


MAX_OVERLAID_TRACKS = MAX_GROUPS
"""Tracks an overlaid core (``RaceCore(overlay=True)``) can hold: its copies of different
tracks share the Space's cells and are kept apart by pymunk's collision categories, of which
there are 32."""


def check_overlay(overlay: bool, num_tracks: int) -> bool:
    """``overlay``, checked against the tracks' count."""
    if not isinstance(overlay, bool):
        raise TypeError(f"overlay must be True or False, got {overlay!r}")
    if overlay and num_tracks > MAX_OVERLAID_TRACKS:
        raise ValueError(f"overlay=True holds at most {MAX_OVERLAID_TRACKS} tracks (pymunk's "
                         f"collision categories keep them apart), got {num_tracks}; split "
                         f"them over several cores")
    return overlay


def grid_offsets(bounds: FloatArray, park_room: float, count: int) -> FloatArray:
    """World offsets of ``count`` copies in a square grid of cells that each hold any of the
    tracks of ``bounds`` ((K, 4): xmin, ymin, xmax, ymax) and its parked cars, (count, 2) [m]."""
    pitch_x = (bounds[:, 2].max() - bounds[:, 0].min()) + park_room + ENV_GAP
    pitch_y = (bounds[:, 3].max() - bounds[:, 1].min()) + ENV_GAP
    cols = math.ceil(math.sqrt(count))
    e = np.arange(count)
    return np.stack([(e % cols) * pitch_x, (e // cols) * pitch_y], axis=1)


def track_index_of(track_index: npt.ArrayLike | None, num_envs: int,
                 num_tracks: int) -> IntArray:
    """The track of each copy, (E,), checked: ``track_index`` given, or K blocks in order."""
    if track_index is None:
        if num_envs < num_tracks:
            raise ValueError(f"{num_tracks} tracks need at least one env copy each, got "
                             f"num_envs={num_envs}; give more copies, or give track_index")
        return np.arange(num_envs) * num_tracks // num_envs
    index = np.asarray(track_index)
    if (index.shape != (num_envs,) or index.dtype.kind not in "iu"
            or (index.size and not 0 <= index.min() <= index.max() < num_tracks)):
        raise ValueError(f"track_index must hold one track index in [0, {num_tracks}) per env "
                         f"copy, shape ({num_envs},) ints, got {index.dtype} values of shape "
                         f"{index.shape}")
    return index.astype(np.int64)


class CoreTracks:
    """The tracks of ``RaceCore``'s copies (a mixin; the core sets ``track_index``,
    ``num_tracks``, ``forward_tracks``, ``num_envs`` and ``num_cars`` first)."""

    def _use_tracks(self, tracks: tuple[Track, ...]) -> None:
        """Drive ``tracks`` (one direction of ``forward_tracks``) from the next spawn on."""
        self.tracks = tracks
        """The tracks in the current driving direction (``forward_tracks`` or their
        reverses)."""
        self.tables = TrackTables.build(tracks)
        """The tracks' tables for the compiled kernels, in one set of arrays."""
        self._length = self.tables.lengths[self.track_index]
        self._views: list[tuple[slice | IntArray, Any]] | None = None

    def _lay_out(self) -> None:
        """Place every copy in its cell of the shared Space, and its parking spots."""
        tracks = self.forward_tracks
        bounds = np.array([t.bounds for t in tracks])  # (K, 4): xmin, ymin, xmax, ymax
        park_room = PARK_MARGIN + 0.5 * self.num_cars
        if self.overlay:
            # Each track's copies where a core of that track alone puts them (pymunk works in
            # world coordinates, so that is where its last bits are the same).
            self.env_offset = np.empty((self.num_envs, 2))
            for k, rows in self._track_rows():
                count = len(range(self.num_envs)[rows]) if isinstance(rows, slice) else len(rows)
                self.env_offset[rows] = grid_offsets(bounds[k:k + 1], park_room, count)
        else:
            # Every copy gets a cell that holds any of the tracks: with one track, its own size.
            self.env_offset = grid_offsets(bounds, park_room, self.num_envs)
        """World offset of each env copy in the shared pymunk Space, shape (E, 2), metres."""
        k = np.arange(self.num_cars)
        park = np.stack([np.broadcast_to(bounds[:, 2:3] + PARK_MARGIN, (len(tracks), k.size)),
                         bounds[:, 1:2] + 0.5 * k], axis=2)
        self._park = park[self.track_index]
        """Where each car waits, parked, beside its copy's track, (E, N, 2) [m]."""
        self.rngs = [np.random.default_rng() for _ in tracks]
        """One random generator per track: it draws for that track's copies."""

    def _collision_groups(self) -> IntArray | None:
        """Each body's collision group for ``PhysicsWorld`` (cars, obstacles, bots, copy-major):
        its copy's track in an overlaid core, where copies of different tracks share cells;
        None (every body may touch every other) otherwise."""
        if not self.overlay:
            return None
        index = self.track_index
        return np.concatenate([np.repeat(index, self.num_cars),
                               np.repeat(index, self.num_obstacles),
                               np.repeat(index, self.num_bots)])

    @property
    def track(self) -> Track:
        """The track in the current driving direction (``forward_track`` or its reverse); a
        core of several tracks has ``tracks`` instead."""
        return self._only("track", self.tracks)

    @property
    def forward_track(self) -> Track:
        """The track as given (a core of several tracks has ``forward_tracks``)."""
        return self._only("forward_track", self.forward_tracks)

    @property
    def inner_sign(self) -> int:
        """+1 when the inside of the loop is on the left of travel, else -1 (of the one
        track; per track: ``tables.inner_signs``)."""
        return int(self._only("inner_sign", self.tables.inner_signs))

    @property
    def rng(self) -> np.random.Generator:
        """The random generator of the one track (a core of several tracks has ``rngs``)."""
        return self._only("rng", self.rngs)

    @rng.setter
    def rng(self, rng: np.random.Generator) -> None:
        self._only("rng", self.rngs)
        self.rngs = [rng]

    def _only(self, name: str, values: Sequence[object]) -> object:
        if self.num_tracks != 1:
            raise AttributeError(
                f"this RaceCore races {self.num_tracks} tracks, so it has no single {name}: "
                f"copy e races tracks[track_index[e]] (see also rngs, tables and track_views())")
        return values[0]

    @staticmethod
    def track_seeds(seed: int, count: int) -> list[int]:
        """The seeds of the generators of a core of ``count`` > 1 tracks seeded with ``seed``
        (``seed(seed)``): one spawned from ``seed`` per track."""
        return [int(child.generate_state(1)[0])
                for child in np.random.SeedSequence(seed).spawn(count)]

    def seed_tracks(self, seeds: Sequence[int]) -> None:
        """Seed each track's generator with its own seed, ``seeds[k]`` for track k (K ints), as
        a core of that track alone seeded with it; ``reset()`` (no seed) then draws from them.
        (``seed(seed)`` gives a core of K > 1 tracks ``track_seeds(seed, K)``.)"""
        if len(seeds) != self.num_tracks:
            raise ValueError(f"seed_tracks needs one seed per track ({self.num_tracks}), got "
                             f"{len(seeds)}")
        for value in seeds:
            check_seed(value)
            if value is None:
                raise ValueError("seed_tracks needs a seed for every track, got None")
        self.rngs = [np.random.default_rng(value) for value in seeds]
        self.episodes[:] = 0

    def track_views(self) -> list[tuple[slice | IntArray, Any]]:
        """``(rows, view)`` of each track that some copy races, in track order: ``rows`` are
        its copies (a slice when they are consecutive), ``view`` reads the core as a core of
        that track alone with those copies (``CoreView``), so that code written for one track
        (the drivers) drives them. A core of one track is its own view."""
        if self._views is None:
            if self.num_tracks == 1:
                self._views = [(slice(0, self.num_envs), self)]
            else:
                self._views = [(rows, CoreView(self, k, rows)) for k, rows in self._track_rows()]
        return self._views

    def _set_direction(self, reverse: bool) -> None:
        if reverse == self.is_reversed:
            return
        if reverse and self._reverse_tracks is None:
            self._reverse_tracks = tuple(t.reversed() for t in self.forward_tracks)
        self._use_tracks(self._reverse_tracks if reverse else self.forward_tracks)
        self.is_reversed = bool(reverse)

    @property
    def lengths(self) -> FloatArray:
        """Lap length of each copy's track, (E,) [m]."""
        return self._length.copy()

    def seed(self, seed: int | None) -> None:
        """Replace the core's random generators (the only source of randomness): with one
        track, ``np.random.default_rng(seed)``; with K, one per track, seeded with
        ``track_seeds(seed, K)`` (fresh ones for None)."""
        check_seed(seed)
        if self.num_tracks == 1:
            self.rngs = [np.random.default_rng(seed)]
        elif seed is None:
            self.rngs = [np.random.default_rng() for _ in range(self.num_tracks)]
        else:
            self.rngs = [np.random.default_rng(s)
                         for s in self.track_seeds(seed, self.num_tracks)]

    def _track_rows(self, mask: BoolArray | None = None) -> list[tuple[int, slice | IntArray]]:
        """``(k, rows)`` of each track with copies (in ``mask``, if given), in track order: its
        copies, a slice when every copy of it is meant and they are consecutive."""
        index = self.track_index
        out: list[tuple[int, slice | IntArray]] = []
        for k in np.unique(index if mask is None else index[mask]).tolist():
            rows = np.flatnonzero(index == k if mask is None else mask & (index == k))
            if mask is None and rows[-1] - rows[0] + 1 == rows.size:
                out.append((k, slice(int(rows[0]), int(rows[-1]) + 1)))
            else:
                out.append((k, rows))
        return out
