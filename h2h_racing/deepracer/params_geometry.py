"""Polyline geometry of DeepRacer's ``params``, as simapp's Shapely calls compute it, compiled.

:class:`_Polyline` holds a polyline's segment table; the kernels find the nearest point of a
polyline (Shapely's ``project`` / ``interpolate``: the first minimum wins), test points against
rings (even-odd), measure every car's and object's fields, and test whether an object is in a
car's camera view. :class:`h2h_racing.deepracer.params.ParamsBuilder` calls them.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

FloatArray = npt.NDArray[np.float64]


class _Polyline:
    """Segment table of an open polyline whose rows include the closing point."""

    def __init__(self, points: FloatArray) -> None:
        a = points[:-1]
        d = points[1:] - a
        self.ax = np.ascontiguousarray(a[:, 0])
        self.ay = np.ascontiguousarray(a[:, 1])
        self.dx = np.ascontiguousarray(d[:, 0])
        self.dy = np.ascontiguousarray(d[:, 1])
        self.len2 = self.dx**2 + self.dy**2
        self.seg = np.sqrt(self.len2)
        self.cum = np.concatenate([[0.0], np.cumsum(self.seg)])
        self.length = float(self.cum[-1])
        # One (7, segments) table per polyline: few arguments keep numba's dispatch cheap.
        self.table = np.ascontiguousarray(np.stack(
            [self.ax, self.ay, self.dx, self.dy, self.len2, self.seg, self.cum[:-1]]))


@njit(cache=True)
def _nearest(px, py, tab):  # pragma: no cover
    # Nearest point of a polyline to (px, py), as Shapely's project/interpolate: clamp the
    # projection factor t = (p - a).d / |d|^2 to [0, 1] on each segment; the first minimum
    # wins (strict <). Zero-length segments are skipped: their point is a neighbour's end.
    # tab rows: a_x, a_y, d_x, d_y, |d|^2, |d|, arc position of a.
    best = np.inf
    arc = 0.0
    qx = tab[0, 0]
    qy = tab[1, 0]
    for j in range(tab.shape[1]):
        len2 = tab[4, j]
        if len2 == 0.0:
            continue
        t = ((px - tab[0, j]) * tab[2, j] + (py - tab[1, j]) * tab[3, j]) / len2
        t = min(max(t, 0.0), 1.0)
        cx = tab[0, j] + t * tab[2, j]
        cy = tab[1, j] + t * tab[3, j]
        d2 = (px - cx) ** 2 + (py - cy) ** 2
        if d2 < best:
            best = d2
            arc = tab[6, j] + t * tab[5, j]
            qx = cx
            qy = cy
    return arc, qx, qy, math.sqrt(best)


@njit(cache=True)
def _project_points(points, tab, out):  # pragma: no cover
    for i in range(points.shape[0]):
        out[i] = _nearest(points[i, 0], points[i, 1], tab)[0]


@njit(cache=True)
def _in_ring(px, py, tab):  # pragma: no cover
    # Even-odd rule against the closed ring through the segment starts (tab rows 0, 1).
    inside = False
    n = tab.shape[1]
    j = n - 1
    for i in range(n):
        yi = tab[1, i]
        yj = tab[1, j]
        if ((yi > py) != (yj > py)
                and px < (tab[0, j] - tab[0, i]) * (py - yi) / (yj - yi) + tab[0, i]):
            inside = not inside
        j = i
    return inside


@njit(cache=True)
def _car_kernel(position, yaw, front, wheels, centre, left, right, model_point, proj, dist,
                width, is_left, wheels_on):  # pragma: no cover
    for i in range(position.shape[0]):
        c = math.cos(yaw[i])
        s = math.sin(yaw[i])
        # P = origin + R(yaw) (0.14, 0) (utils.py, RELATIVE_POSITION_OF_FRONT_OF_CAR).
        px = position[i, 0] + front * c
        py = position[i, 1] + front * s
        model_point[i, 0] = px
        model_point[i, 1] = py
        arc, qx, qy, d = _nearest(px, py, centre)
        proj[i] = arc
        dist[i] = d
        # track_width (track_data.py): distance between the border points nearest to the
        # projected centre point Q; is_left_of_center: P is nearer the left one.
        _, lx, ly, _ = _nearest(qx, qy, left)
        _, rx, ry, _ = _nearest(qx, qy, right)
        width[i] = math.hypot(lx - rx, ly - ry)
        is_left[i] = math.hypot(px - lx, py - ly) < math.hypot(px - rx, py - ry)
        # all_wheels_on_track: every wheel centre inside Polygon(outer, [inner]); the road is
        # inside exactly one of the two border rings (even-odd).
        on = True
        for w in range(wheels.shape[0]):
            wx = position[i, 0] + c * wheels[w, 0] - s * wheels[w, 1]
            wy = position[i, 1] + s * wheels[w, 0] + c * wheels[w, 1]
            if _in_ring(wx, wy, left) == _in_ring(wx, wy, right):
                on = False
        wheels_on[i] = on


@njit(cache=True)
def _object_kernel(objects, centre, inner, proj, dist, band):  # pragma: no cover
    for j in range(objects.shape[0]):
        ox = objects[j, 0]
        oy = objects[j, 1]
        arc, _, _, d = _nearest(ox, oy, centre)
        proj[j] = arc
        dist[j] = d
        # Inside Polygon(C, [inner_border]): inside C's ring xor inside the inner ring.
        band[j] = _in_ring(ox, oy, centre) != _in_ring(ox, oy, inner)


@njit(cache=True)
def _in_camera(px, py, yaw, camera_ahead_of_p, half_fov, max_range, ox, oy, oyaw, half_len,
               half_wid):  # pragma: no cover
    # The object's box intersects the camera's horizontal frustum (a wedge of half-angle
    # half_fov and radius max_range) when one of its corners, edge midpoints or its centre lies
    # inside the wedge.
    c = math.cos(yaw)
    s = math.sin(yaw)
    cx = px + camera_ahead_of_p * c
    cy = py + camera_ahead_of_p * s
    oc = math.cos(oyaw)
    os_ = math.sin(oyaw)
    for u in (-1.0, 0.0, 1.0):
        for v in (-1.0, 0.0, 1.0):
            qx = ox + u * half_len * oc - v * half_wid * os_ - cx
            qy = oy + u * half_len * os_ + v * half_wid * oc - cy
            ahead = qx * c + qy * s
            across = -qx * s + qy * c
            r = math.hypot(ahead, across)
            if ahead > 0.0 and r <= max_range and abs(math.atan2(across, ahead)) <= half_fov:
                return True
    return False
