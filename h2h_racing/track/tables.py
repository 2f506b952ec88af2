"""The tables of several tracks in one set of arrays, for the batched core's compiled kernels.

The env copies of one ``RaceCore`` can each race a different track. Every compiled kernel that
reads a track (projection onto the centre line, the heading, curvature, widths and centre point
along it) gets the tables of all the core's K tracks at once, and a track index per env copy:

- ``fields`` (6, S): each track's ``TrackLookup`` tables (rows ``HEADING``, ``CURVATURE``,
  ``WIDTH_LEFT``, ``WIDTH_RIGHT``, ``X``, ``Y``) one track after the other;
- ``start``, ``cert`` (C,): each track's projection grid cells (``Projector.start`` and
  ``cert``), one track after the other; ``start`` counts rows from the track's first row of
  ``tab``;
- ``tab`` (R, 5) and ``tab_full`` (F, 5): each track's windowed and full segment tables;
- ``scalars`` (K, ``SCALARS``): one row of constants per track, columns named below: where
  its parts start in the arrays above and how long they are, its lap length, table spacing,
  grid geometry, narrowest half-width and which side the inside of the loop is on.

Track k's part of each array holds exactly its own ``TrackLookup`` and ``Projector`` tables,
and the kernels do the same arithmetic on it (``lookup_span``, ``project_point``), so a copy
on track T reads, to the bit, what it would read in a core of T alone. A track given more than
once is stored once.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
from numba import njit

from h2h_racing.track.lookup import TrackLookup
from h2h_racing.track.projection import project_point

if TYPE_CHECKING:
    from h2h_racing.track.shape import Track

FloatArray = npt.NDArray[np.float64]

FIELDS = ("heading", "curvature", "width_left", "width_right", "x", "y")
"""The rows of ``TrackTables.fields``: ``TrackLookup``'s tables of the same names."""
HEADING, CURVATURE, WIDTH_LEFT, WIDTH_RIGHT, X, Y = range(len(FIELDS))

SCALARS = ("length", "inv_ds", "lut_first", "lut_count", "min_half_width", "origin_x",
           "origin_y", "inv_cell", "hi_x", "hi_y", "ny", "window", "cell_first", "cell_count",
           "tab_first", "tab_count", "full_first", "full_count", "inner_sign")
"""The columns of ``TrackTables.scalars`` (one row per track): lap length [m]; 1 / table
spacing [1/m]; first sample of the track in ``fields`` and its sample count; the track's
smallest half-width [m]; its projection grid's corner [m], 1 / cell size [1/m], largest cell
index per axis and cells per column; its window of candidate segments; where its cells start
in ``start`` / ``cert`` and how many; the same for its rows of ``tab`` and of ``tab_full``;
+1 when the inside of the loop is on the left of travel (counter-clockwise), else -1.
Indices are stored as floats (exact below 2**53)."""
(LENGTH, INV_DS, LUT_FIRST, LUT_COUNT, MIN_HALF_WIDTH, ORIGIN_X, ORIGIN_Y, INV_CELL, HI_X,
 HI_Y, NY, WINDOW, CELL_FIRST, CELL_COUNT, TAB_FIRST, TAB_COUNT, FULL_FIRST, FULL_COUNT,
 INNER_SIGN) = range(len(SCALARS))


@dataclass(frozen=True, eq=False)
class TrackTables:
    """The lookup and projection tables of K tracks (see the module docstring).

    Attributes:
        tracks: The tracks, in the order of ``scalars``' rows (K,).
        fields: Field tables of every track, (6, S) (rows as in ``FIELDS``).
        scalars: Per-track constants, (K, len(SCALARS)) (columns as in ``SCALARS``).
        start: Projection grid cells: first window row, counted from the track's first
            row of ``tab``, (C,).
        cert: Projection grid cells: certified distance [m], (C,).
        tab: Windowed segment tables, (R, 5) complex.
        tab_full: Full segment tables, (F, 5) complex.
    """

    tracks: tuple[Track, ...]
    fields: FloatArray
    scalars: FloatArray
    start: npt.NDArray[np.intp]
    cert: FloatArray
    tab: npt.NDArray[np.complex128]
    tab_full: npt.NDArray[np.complex128]

    @classmethod
    def build(cls, tracks: Sequence[Track]) -> TrackTables:
        """The tables of ``tracks`` (a track given twice, the same object, is stored once)."""
        tracks = tuple(tracks)
        if not tracks:
            raise ValueError("TrackTables needs at least one track, got none")
        rows = np.zeros((len(tracks), len(SCALARS)))
        parts: dict[str, list[np.ndarray]] = {"fields": [], "start": [], "cert": [], "tab": [],
                                              "tab_full": []}
        seen: dict[int, int] = {}
        used = dict.fromkeys(("fields", "start", "tab", "tab_full"), 0)
        for k, track in enumerate(tracks):
            if id(track) in seen:
                rows[k] = rows[seen[id(track)]]
                continue
            seen[id(track)] = k
            lut = TrackLookup.from_track(track)
            proj = track.projector()
            table = np.stack([getattr(lut, name) for name in FIELDS])
            count = table.shape[1]
            cells = len(proj.start)
            rows[k] = (lut.length, lut.inv_ds, used["fields"], count,
                       float(min(track.width_left.min(), track.width_right.min())),
                       proj.origin[0], proj.origin[1], proj.inv_cell, proj.hi[0], proj.hi[1],
                       proj.ny, proj.window, used["start"], cells, used["tab"], len(proj.tab),
                       used["tab_full"], len(proj.tab_full), 1.0 if track.is_ccw else -1.0)
            for name, part in (("fields", table), ("start", proj.start), ("cert", proj.cert),
                               ("tab", proj.tab), ("tab_full", proj.tab_full)):
                parts[name].append(part)
            used["fields"] += count
            used["start"] += cells
            used["tab"] += len(proj.tab)
            used["tab_full"] += len(proj.tab_full)
        return cls(tracks=tracks, fields=np.concatenate(parts["fields"], axis=1), scalars=rows,
                   start=np.concatenate(parts["start"]), cert=np.concatenate(parts["cert"]),
                   tab=np.concatenate(parts["tab"]), tab_full=np.concatenate(parts["tab_full"]))

    @property
    def lengths(self) -> FloatArray:
        """Lap length of each track, (K,) [m]."""
        return self.scalars[:, LENGTH]

    @property
    def inner_signs(self) -> npt.NDArray[np.int64]:
        """+1 where the inside of the loop is on the left of travel, else -1, (K,)."""
        return self.scalars[:, INNER_SIGN].astype(np.int64)

    def subset(self, k: int) -> TrackTables:
        """The tables of track ``k`` alone (a one-track core's), cut from these."""
        row = self.scalars[k].copy()
        cut = {}
        for name, first, count in (("start", CELL_FIRST, CELL_COUNT),
                                   ("cert", CELL_FIRST, CELL_COUNT),
                                   ("tab", TAB_FIRST, TAB_COUNT),
                                   ("tab_full", FULL_FIRST, FULL_COUNT)):
            a = int(row[first])
            cut[name] = getattr(self, name)[a:a + int(row[count])]
        a = int(row[LUT_FIRST])
        fields = np.ascontiguousarray(self.fields[:, a:a + int(row[LUT_COUNT])])
        for column in (LUT_FIRST, CELL_FIRST, TAB_FIRST, FULL_FIRST):
            row[column] = 0.0
        return TrackTables(tracks=(self.tracks[k],), fields=fields, scalars=row[None, :],
                           **cut)


@njit(cache=True, inline="always")
def project_on(scalars, t, start, cert, tab, tab_full, x, y):  # pragma: no cover
    """``(s, d)`` of the point ``(x, y)`` on track ``t`` of a ``TrackTables``' arrays."""
    row = scalars[t]
    return project_point(x, y, row[ORIGIN_X], row[ORIGIN_Y], row[INV_CELL], row[HI_X],
                         row[HI_Y], int(row[NY]), start, int(row[CELL_FIRST]), cert, tab,
                         int(row[TAB_FIRST]), int(row[WINDOW]), tab_full, int(row[FULL_FIRST]),
                         int(row[FULL_COUNT]), row[LENGTH])
