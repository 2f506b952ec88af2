"""Which track each env copy of the batched core races: the tracks, their tables, generators
and views.

A ``RaceCore`` races K tracks (K = 1: a one-track core, the same code): copy e races
``tracks[track_index[e]]``. ``CoreTracks`` holds the tracks (in the current driving direction),
their tables for the compiled kernels (``TrackTables``), the copies' world layout (each copy a
cell of the shared pymunk Space that holds any of the tracks), one random generator per track,
and the one-track views of each track's copies (``core_view``). ``RaceCore`` (``h2h_racing.sim.core``)
mixes it in.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from h2h_racing.config.checks import check_seed
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
        # Every copy gets a cell that holds any of the tracks: with one track, its own size.
        pitch_x = (bounds[:, 2].max() - bounds[:, 0].min()) + park_room + ENV_GAP
        pitch_y = (bounds[:, 3].max() - bounds[:, 1].min()) + ENV_GAP
        cols = math.ceil(math.sqrt(self.num_envs))
        e = np.arange(self.num_envs)
        self.env_offset = np.stack([(e % cols) * pitch_x, (e // cols) * pitch_y], axis=1)
        """World offset of each env copy in the shared pymunk Space, shape (E, 2), metres."""
        k = np.arange(self.num_cars)
        park = np.stack([np.broadcast_to(bounds[:, 2:3] + PARK_MARGIN, (len(tracks), k.size)),
                         bounds[:, 1:2] + 0.5 * k], axis=2)
        self._park = park[self.track_index]
        """Where each car waits, parked, beside its copy's track, (E, N, 2) [m]."""
        self.rngs = [np.random.default_rng() for _ in tracks]
        """One random generator per track: it draws for that track's copies."""

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
