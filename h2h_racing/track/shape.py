"""Immutable track geometry: a closed centre line with per-vertex half-widths, and Frenet maps onto it.

A :class:`Track` is a closed polyline (the centre line, in driving order, first vertex not repeated) with a
width to the left and to the right of the direction of travel at every vertex. It answers the geometric
questions the simulation core asks every step, vectorised over any leading shape:

* :meth:`Track.project` maps world points to ``(s, d)``: the arc position ``s`` of the nearest point of the
  centre *polyline* (as DeepRacer's Shapely ``LinearRing.project``) and the signed distance ``d`` to it,
  positive on the left of the direction of travel.
* :meth:`Track.point_at`, :meth:`Track.heading_at`, :meth:`Track.curvature_at`,
  :meth:`Track.half_widths_at`, :meth:`Track.lane_point` go the other way.

This module is pure numpy (no pymunk, cv2 or pettingzoo); loaders live in
:mod:`h2h_racing.track.io`, the polyline geometry and self-crossing checks in
:mod:`h2h_racing.track.geometry`, and the projection lookup grid with its compiled kernels in
:mod:`h2h_racing.track.projection`.

**Frenet inverse.** The nearest-point map onto a polyline is not smooth: on the outside of a vertex a whole
wedge of points projects onto the vertex, and on the inside ``s`` jumps by ``2|d|tan(turn/2)`` across the
bisector. No continuous ``point_at`` can invert it everywhere. ``point_at`` uses the exact inverse wherever
one exists, the *segment* normal, and makes it continuous by rotating the normal through the vertex
bisector over a short blend zone of half-width ``h = min(BLEND_HALF_WIDTH, len/4)`` around each vertex
(``heading_at`` uses the same field). Hence ``project(point_at(s, d)) == (s, d)`` to rounding error
everywhere except within ``h + |d| tan(turn/2)`` of a vertex, where the error in ``s`` is at most about
that distance. On a DeepRacer-scale track (15 cm spacing, 2 degrees of turn per vertex, ``|d| = 0.5 m``)
this zone is about 1.8 cm around each vertex and the error there is below 2 cm.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from h2h_racing.track.geometry import _centre_geometry, _check_no_fold, _check_simple, _ro
from h2h_racing.track.projection import Projector, project_kernel

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

CAR_WIDTH = 0.20
"""Width of a car [m]; a track must be at least two car widths wide everywhere."""
MIN_TOTAL_WIDTH = 2 * CAR_WIDTH
"""Smallest allowed ``width_left + width_right`` [m]."""
BLEND_HALF_WIDTH = 0.01
"""Largest half-width [m] of the zone around a vertex over which the normal rotates between segments."""
BORDER_TOLERANCE = 0.005
"""Largest overlap [m] of an explicit (file-given) border crossing that is accepted as a drawing glitch."""

MAX_TRACK_VERTICES = 100_000
"""Most centre-line vertices a track may have. Real tracks have a few hundred to a few thousand (a
TUMFTM circuit at 1 m spacing about 5,000); the checks load 100,000 in about 1.5 s, but every
racing env's lookup grid (:mod:`h2h_racing.track.projection`) costs time in proportion to the vertex
count, so thin a denser file out (every k-th row) before loading it."""

_ALL = np.zeros(0, dtype=bool)  # an empty mask means "project every point"


def _as_xy(name: str, value: Any, where: str) -> FloatArray:
    """Convert ``value`` to a float64 ``(M, 2)`` array or raise a ``ValueError`` that names ``where``."""
    arr = np.array(value, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"{where}: expected {name} of shape (M, 2) [m], got shape {arr.shape}.")
    return arr


@dataclass(frozen=True, eq=False)
class Track:
    """An immutable closed race track (DeepRacer scale, metres).

    Construct it directly from arrays or through :func:`h2h_racing.track.io.load_track`. All
    arrays are float64 copies flagged read-only. The constructor validates the geometry and
    raises ``ValueError`` naming the source, the problem, the vertex index and its coordinates.

    Attributes:
        centre: Centre-line vertices, shape (M, 2) [m], driving order, closed loop with the first vertex NOT
            repeated. Duplicate consecutive vertices (zero-length segments) are allowed.
        width_left: Distance from the centre to the left border at each vertex, shape (M,) [m]; a scalar is
            broadcast.
        width_right: Distance from the centre to the right border at each vertex, shape (M,) [m].
        name: Short name (catalogue key or file stem).
        description: Free text.
        source: File the track came from, or ``'<memory>'``.
        left_border: Left border, shape (M, 2) [m]; given by DeepRacer files, otherwise computed as
            ``centre + n * width_left`` with ``n`` the vertex normal (mean of the adjacent segment normals).
        right_border: Right border, shape (M, 2) [m], ``centre - n * width_right`` when computed.
        waypoints: The rows as the source gave them, shape (K, 2) [m], driving order (DeepRacer's
            ``params["waypoints"]``). Defaults to the centre vertices with the first repeated at the end.
    """

    centre: FloatArray = field(repr=False)
    width_left: FloatArray = field(repr=False)
    width_right: FloatArray = field(repr=False)
    name: str = "track"
    description: str = ""
    source: str = "<memory>"
    left_border: FloatArray | None = field(default=None, repr=False, kw_only=True)
    right_border: FloatArray | None = field(default=None, repr=False, kw_only=True)
    waypoints: FloatArray | None = field(default=None, repr=False, kw_only=True)
    _geo: dict[str, Any] = field(init=False, repr=False, default_factory=dict)
    _cache: dict[str, Any] = field(init=False, repr=False, default_factory=dict)

    # ------------------------------------------------------------------ construction and validation

    def __post_init__(self) -> None:
        where = self._where
        centre = _as_xy("centre", self.centre, where)
        m = len(centre)
        if m > MAX_TRACK_VERTICES:
            raise ValueError(
                f"{where}: the centre line has {m} vertices; at most {MAX_TRACK_VERTICES} are "
                "allowed (h2h_racing.track.shape.MAX_TRACK_VERTICES). Thin the file out, e.g. "
                "keep every k-th row."
            )
        wl = self._as_widths("width_left", self.width_left, m)
        wr = self._as_widths("width_right", self.width_right, m)
        explicit = self.left_border is not None or self.right_border is not None
        if explicit and (self.left_border is None or self.right_border is None):
            raise ValueError(f"{where}: give both left_border and right_border, or neither (to compute them).")
        lb = _as_xy("left_border", self.left_border, where) if explicit else None
        rb = _as_xy("right_border", self.right_border, where) if explicit else None
        for name, arr in (("left_border", lb), ("right_border", rb)):
            if arr is not None and arr.shape != centre.shape:
                raise ValueError(
                    f"{where}: expected {name} of shape {centre.shape} (one row per centre vertex), "
                    f"got {arr.shape}."
                )
        wp = None if self.waypoints is None else _as_xy("waypoints", self.waypoints, where)

        for name, arr in (
            ("centre", centre),
            ("width_left", wl),
            ("width_right", wr),
            ("left_border", lb),
            ("right_border", rb),
            ("waypoints", wp),
        ):
            if arr is not None and not np.all(np.isfinite(arr)):
                row = int(np.argwhere(~np.isfinite(arr.reshape(len(arr), -1)))[0, 0])
                raise ValueError(
                    f"{where}: {name} has a non-finite value (NaN or inf) in row {row}: {arr[row]}. "
                    "All coordinates and widths must be finite numbers."
                )
        n_distinct = len(np.unique(centre, axis=0)) if m else 0
        if n_distinct < 4:
            raise ValueError(
                f"{where}: the centre line needs at least 4 distinct vertices to form a closed loop, "
                f"got {n_distinct} (of {m} rows)."
            )
        for name, w in (("width_left", wl), ("width_right", wr)):
            if np.any(w <= 0):
                i = int(np.argmax(w <= 0))
                raise ValueError(
                    f"{where}: {name} must be > 0 m at every vertex, got {w[i]:.6g} at vertex {i} "
                    f"({centre[i, 0]:.4f}, {centre[i, 1]:.4f})."
                )
        total = wl + wr
        if np.any(total < MIN_TOTAL_WIDTH):
            i = int(np.argmin(total))
            raise ValueError(
                f"{where}: the track is {total[i]:.4f} m wide at vertex {i} "
                f"({centre[i, 0]:.4f}, {centre[i, 1]:.4f}); it must be at least two car widths "
                f"({MIN_TOTAL_WIDTH:.2f} m) everywhere."
            )

        geo = _centre_geometry(centre, where)
        if lb is None or rb is None:
            vn = geo["vertex_normal"]
            lb = centre + vn * wl[:, None]
            rb = centre - vn * wr[:, None]
        if wp is None:
            wp = np.vstack([centre, centre[:1]])

        if not explicit:
            _check_no_fold(centre, lb, "left border", where)
            _check_no_fold(centre, rb, "right border", where)
        _check_simple(centre, "centre line", where, tolerance=0.0)
        # A computed border crosses itself where the radius of curvature is below the half-width. A border
        # given by a file is accepted if its crossing overlaps by at most BORDER_TOLERANCE (a drawing glitch).
        tol = BORDER_TOLERANCE if explicit else 0.0
        _check_simple(lb, "left border", where, tolerance=tol)
        _check_simple(rb, "right border", where, tolerance=tol)

        for name, arr in (
            ("centre", centre),
            ("width_left", wl),
            ("width_right", wr),
            ("left_border", lb),
            ("right_border", rb),
            ("waypoints", wp),
        ):
            object.__setattr__(self, name, _ro(arr))
        object.__setattr__(self, "_explicit_borders", explicit)
        self._geo.update(geo)
        self._build_fields()

    @property
    def _where(self) -> str:
        return f"track {self.name!r} ({self.source})"

    def _as_widths(self, name: str, value: Any, m: int) -> FloatArray:
        arr = np.array(value, dtype=np.float64)
        if arr.ndim == 0:
            arr = np.full(m, float(arr))
        if arr.shape != (m,):
            raise ValueError(
                f"{self._where}: expected {name} of shape ({m},) (one width per centre vertex) or a scalar, "
                f"got shape {arr.shape}."
            )
        return arr

    def _build_fields(self) -> None:
        """Precompute the interpolation tables of the continuous fields (heading, centre, widths)."""
        g = self._geo
        keep: IntArray = g["keep"]
        sc: FloatArray = g["vertex_s"][keep]
        length = g["length"]
        lc: FloatArray = g["seg_len"][g["seg_of_kept"]]
        psi: FloatArray = g["psi"]  # unwrapped heading of each compressed segment
        total = g["total_turn"]
        # Blend zone: knots (s_v - h, psi_in) and (s_v + h, psi_out) around each distinct vertex v.
        h = np.minimum(BLEND_HALF_WIDTH, 0.25 * np.minimum(lc, np.roll(lc, 1)))
        psi_in = np.concatenate([[psi[-1] - total], psi[:-1]])
        ks = np.stack([sc - h, sc + h], axis=1).ravel()
        kp = np.stack([psi_in, psi], axis=1).ravel()
        g["heading_knots"] = (
            np.concatenate([ks - length, ks, ks + length]),
            np.concatenate([kp - total, kp, kp + total]),
        )
        xs = np.append(sc, length)
        g["interp_s"] = xs

        def closed(v: np.ndarray) -> np.ndarray:
            return np.append(v[keep], v[keep[0]])

        g["cx"], g["cy"] = closed(self.centre[:, 0]), closed(self.centre[:, 1])
        g["wl"], g["wr"] = closed(self.width_left), closed(self.width_right)
        # Curvature: centred difference of the unwrapped heading field over +-w, w = 2 median spacings.
        # On a circle of radius R sampled every l this gives (turn per vertex)/l = 1/R to O((l/R)^2).
        w = 2.0 * float(np.median(lc))
        s_v = self.vertex_s
        kappa = (self._psi(s_v + w) - self._psi(s_v - w)) / (2.0 * w)
        g["curvature_vertex"] = _ro(kappa)
        g["kappa"] = closed(kappa)

    # ------------------------------------------------------------------ pickling (drop the lazy grid)

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state["_cache"] = {}
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)

    def __repr__(self) -> str:
        return (
            f"Track(name={self.name!r}, vertices={len(self.centre)}, length={self.length:.3f} m, "
            f"width={self.min_width:.3f}..{float(self.width.max()):.3f} m, source={self.source!r})"
        )

    # ------------------------------------------------------------------ derived properties

    @property
    def length(self) -> float:
        """Centre-line length [m], closing segment included."""
        return self._geo["length"]

    @property
    def vertex_s(self) -> FloatArray:
        """Arc position of each centre vertex, shape (M,) [m]; ``vertex_s[0] == 0``."""
        return self._geo["vertex_s"]

    @property
    def width(self) -> FloatArray:
        """Total width ``width_left + width_right`` at each vertex, shape (M,) [m]."""
        if "width" not in self._cache:
            self._cache["width"] = _ro(self.width_left + self.width_right)
        return self._cache["width"]

    @property
    def min_width(self) -> float:
        """Smallest total width [m]."""
        return float(self.width.min())

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """Bounding box ``(xmin, ymin, xmax, ymax)`` [m] of both borders."""
        pts = np.vstack([self.left_border, self.right_border, self.centre])
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])

    @property
    def is_ccw(self) -> bool:
        """Whether the centre line runs counter-clockwise (positive signed area)."""
        return self._geo["area"] > 0

    @property
    def left_lane(self) -> FloatArray:
        """Mid-line between the centre and the left border, shape (M, 2) [m] (DeepRacer's lane)."""
        if "left_lane" not in self._cache:
            self._cache["left_lane"] = _ro(0.5 * (self.centre + self.left_border))
        return self._cache["left_lane"]

    @property
    def right_lane(self) -> FloatArray:
        """Mid-line between the centre and the right border, shape (M, 2) [m]."""
        if "right_lane" not in self._cache:
            self._cache["right_lane"] = _ro(0.5 * (self.centre + self.right_border))
        return self._cache["right_lane"]

    @property
    def curvature_vertex(self) -> FloatArray:
        """Smoothed signed curvature at each vertex, shape (M,) [1/m], positive turning left."""
        return self._geo["curvature_vertex"]

    # ------------------------------------------------------------------ continuous fields along s

    def _psi(self, s: FloatArray) -> FloatArray:
        """Unwrapped heading [rad] at arc positions ``s`` in [-L, 2L)."""
        ks, kp = self._geo["heading_knots"]
        return np.interp(s, ks, kp)

    def _wrap_s(self, s: Any) -> FloatArray:
        return np.remainder(np.asarray(s, dtype=np.float64), self.length)

    def heading_at(self, s: Any) -> FloatArray:
        """Return the direction of travel at arc positions ``s``.

        The heading is the segment direction, rotated linearly through the vertex bisector within
        ``BLEND_HALF_WIDTH`` of each vertex, so it has no jumps (other than the wrap at +-pi).

        Args:
            s: Arc positions, any shape (...) [m]; wrapped modulo ``length``.

        Returns:
            Heading, shape (...) [rad] in [-pi, pi), 0 along +x, counter-clockwise positive.
        """
        psi = self._psi(self._wrap_s(s))
        return psi - 2.0 * np.pi * np.floor((psi + np.pi) / (2.0 * np.pi))

    def point_at(self, s: Any, d: Any = 0.0) -> FloatArray:
        """Return the world point at arc position ``s`` and signed offset ``d``.

        ``centre(s) + d * normal(s)`` with ``centre(s)`` on the polyline and ``normal(s)`` the left normal of
        :meth:`heading_at` (see the module docstring for why this inverts :meth:`project`).

        Args:
            s: Arc positions, shape (...) [m]; wrapped modulo ``length``.
            d: Signed offsets, broadcastable with ``s`` [m], positive to the left.

        Returns:
            Points, shape (..., 2) [m].
        """
        g = self._geo
        sw = self._wrap_s(s)
        psi = self._psi(sw)
        x = np.interp(sw, g["interp_s"], g["cx"]) - d * np.sin(psi)
        y = np.interp(sw, g["interp_s"], g["cy"]) + d * np.cos(psi)
        return np.stack(np.broadcast_arrays(x, y), axis=-1)

    def curvature_at(self, s: Any) -> FloatArray:
        """Return the signed curvature at arc positions ``s`` [1/m], positive turning left.

        Per-vertex values are a centred difference of the heading over +-2 median segment lengths,
        interpolated linearly in ``s``.

        Args:
            s: Arc positions, shape (...) [m]; wrapped modulo ``length``.

        Returns:
            Curvature, shape (...) [1/m].
        """
        g = self._geo
        return np.interp(self._wrap_s(s), g["interp_s"], g["kappa"])

    def half_widths_at(self, s: Any) -> tuple[FloatArray, FloatArray]:
        """Return the left and right widths at arc positions ``s``, interpolated linearly between vertices.

        Args:
            s: Arc positions, shape (...) [m]; wrapped modulo ``length``.

        Returns:
            ``(left, right)``, each shape (...) [m], distances from the centre to each border.
        """
        g = self._geo
        sw = self._wrap_s(s)
        return np.interp(sw, g["interp_s"], g["wl"]), np.interp(sw, g["interp_s"], g["wr"])

    def lane_point(self, s: Any, lane: Any) -> FloatArray:
        """Return the point of a DeepRacer lane (half-way between the centre and a border).

        Args:
            s: Arc positions, shape (...) [m].
            lane: +1 for the left lane, -1 for the right lane; broadcastable with ``s``.

        Returns:
            Points, shape (..., 2) [m].

        Raises:
            ValueError: If ``lane`` holds anything other than +1 or -1.
        """
        lane_arr = np.asarray(lane)
        if not np.all((lane_arr == 1) | (lane_arr == -1)):
            raise ValueError(f"Expected lane = +1 (left) or -1 (right), got {lane!r}.")
        left, right = self.half_widths_at(s)
        d = 0.5 * np.where(lane_arr > 0, left, -right)
        return self.point_at(s, d)

    # ------------------------------------------------------------------ projection

    def project(self, points: Any, where: Any = None) -> tuple[FloatArray, FloatArray]:
        """Project world points onto the centre polyline.

        Exact nearest point of the polyline (closing segment included; ties go to the lower segment in the
        search window). A lazily built grid gives each point a window of candidate segments; a per-cell
        certificate proves the window holds the nearest segment, and the rare uncertified points (far from
        the track, or near the medial axis between two distant parts of it) are solved by brute force.

        Args:
            points: World points, shape (..., 2) [m].
            where: Optional boolean mask, shape (...): points where it is False are skipped and get
                ``s = d = 0`` (the simulation core skips parked cars this way).

        Returns:
            ``(s, d)``, each shape (...): ``s`` [m] in [0, length) the arc position of the nearest point, and
            ``d`` [m] the signed distance to it, positive on the left of the direction of travel.
        """
        q = np.asarray(points, dtype=np.float64)
        lead = q.shape[:-1]
        if q.shape[-1:] != (2,):
            raise ValueError(f"Expected points of shape (..., 2) [m], got shape {q.shape}.")
        q = np.ascontiguousarray(q.reshape(-1, 2))
        p = self._cache.get("proj") or self._build_projector()
        s = np.empty(len(q))
        d = np.empty(len(q))
        mask = _ALL if where is None else np.broadcast_to(np.asarray(where, dtype=bool), lead).reshape(-1)
        project_kernel(q, mask, p.origin, p.inv_cell, p.hi, p.ny, p.start, p.cert, p.tab, p.window,
                        p.tab_full, p.length, s, d)
        return s.reshape(lead), d.reshape(lead)

    def on_track(self, points: Any) -> npt.NDArray[np.bool_]:
        """Return whether each point lies between the borders: ``-width_right(s) <= d <= width_left(s)``.

        Args:
            points: World points, shape (..., 2) [m].

        Returns:
            Boolean array, shape (...).
        """
        s, d = self.project(points)
        left, right = self.half_widths_at(s)
        return (d >= -right) & (d <= left)

    def projector(self) -> Projector:
        """Return the projection lookup tables (built once, lazily) for compiled kernels."""
        return self._cache.get("proj") or self._build_projector()

    def _build_projector(self) -> Projector:
        proj = Projector.build(self)
        self._cache["proj"] = proj
        return proj

    # ------------------------------------------------------------------ transforms

    def reversed(self) -> Track:
        """Return the same circuit driven the other way round.

        The start vertex stays first (as DeepRacer's reversed waypoint list starts on the same start line);
        the other vertices are reversed, left and right widths and borders are swapped, and the waypoints are
        reversed.
        """
        order = np.concatenate([[0], np.arange(len(self.centre) - 1, 0, -1)])
        return Track(
            self.centre[order],
            self.width_right[order],
            self.width_left[order],
            name=self.name,
            description=self.description,
            source=self.source,
            left_border=self.right_border[order] if self._explicit_borders else None,
            right_border=self.left_border[order] if self._explicit_borders else None,
            waypoints=self.waypoints[::-1],
        )
