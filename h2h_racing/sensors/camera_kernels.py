"""Compiled kernels of the front camera: visible box faces and ground-plane homographies.

:func:`box_faces_kernel` projects, culls, clips and orders the faces of every box (cars,
obstacles, bots) seen by every camera; :func:`ground_maps_kernel` gives every camera's image ->
ground-texture homography. The camera frame, the pinhole model and the pixel convention are
described in :mod:`h2h_racing.sensors.camera`; :class:`~h2h_racing.sensors.camera.CameraSensor`
fills the polygons and warps the texture with OpenCV (this module needs no cv2).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

FACE_FACTORS = (0.80, 0.62, 1.0)
"""Shade factor of the front/rear faces, of the side faces and of the top face of a box."""
SHIFT = 4
"""Fractional bits of the polygon vertices given to OpenCV (1/16 pixel)."""
FACES_PER_BOX = 3
"""At most three faces of a box are visible from one point (two sides and the top)."""
MAX_VERTICES = 12
"""A quad clipped by the near plane and the four image edges has at most 9 vertices."""


@njit(cache=True, inline="always")
def _clip_polygon(src, n, dst, axis, sign, limit):  # pragma: no cover
    """Sutherland-Hodgman: keep the part of polygon ``src[:n]`` where ``sign * p[axis] >= sign
    * limit``, written to ``dst``; return its vertex count. Columns: x, y, z of each vertex."""
    m = 0
    for k in range(n):
        a = src[k]
        b = src[(k + 1) % n]
        da = sign * (a[axis] - limit)
        db = sign * (b[axis] - limit)
        if da >= 0.0:
            dst[m, 0] = a[0]
            dst[m, 1] = a[1]
            dst[m, 2] = a[2]
            m += 1
        if (da >= 0.0) != (db >= 0.0):
            t = da / (da - db)
            dst[m, 0] = a[0] + t * (b[0] - a[0])
            dst[m, 1] = a[1] + t * (b[1] - a[1])
            dst[m, 2] = a[2] + t * (b[2] - a[2])
            m += 1
    return m


@njit(cache=True)
def box_faces_kernel(cam_xy, cam_yaw, car_pos, car_yaw, done, obs_pos, obs_yaw,
                     car_size, obs_size, car_shades, obs_shade, cam_h, sin_p, cos_p, focal, cx,
                     cy, near, width, height, count, nverts, verts, shade):  # pragma: no cover
    """Project, cull, clip and order the visible faces of every box seen by every camera.

    Args:
        cam_xy: Optical centres on the ground plane, (E, N, C, 2) [m].
        cam_yaw: Heading of each car, (E, N) [rad].
        car_pos, car_yaw, done: Car centres (E, N, 2) [m], headings (E, N) [rad], parked cars.
        obs_pos, obs_yaw: Centres (E, K, 2) [m] and headings (E, K) [rad] of the other boxes
            (obstacles, then bot cars).
        car_size: (length, width, height) of the cars [m]. obs_size: that of each other box,
            (K, 3) [m].
        car_shades: Top-face grey level of each car, (N,). obs_shade: that of each other box,
            (K,).
        cam_h, sin_p, cos_p, focal, cx, cy, near, width, height: Camera model (module doc).
        count: Out, faces to draw per camera, (E, N, C).
        nverts: Out, vertices of each face, (E, N, C, F).
        verts: Out, fixed-point pixel vertices (``SHIFT`` bits), (E, N, C, F, MAX_VERTICES, 2).
        shade: Out, grey level of each face, (E, N, C, F).

    Faces are written far box first. A side face is visible when the camera lies on its outer
    side, ``(C - q) . n_out > 0``; the top face when the camera is higher than the box. The
    bottom face faces the ground and is never seen.
    """
    num_envs, num_cars, num_cams = cam_xy.shape[0], cam_xy.shape[1], cam_xy.shape[2]
    num_obs = obs_pos.shape[1]
    nb = num_cars + num_obs
    key = np.empty(nb)
    order = np.empty(nb, dtype=np.int64)
    corners = np.empty((8, 3))
    poly = np.empty((MAX_VERTICES, 3))
    tmp = np.empty((MAX_VERTICES, 3))
    fixed = float(1 << SHIFT)
    # Corner k of the footprint in the box frame, counter-clockwise from front-left.
    sx = np.array([0.5, -0.5, -0.5, 0.5])
    sy = np.array([0.5, 0.5, -0.5, -0.5])
    for e in range(num_envs):
        for i in range(num_cars):
            psi = cam_yaw[e, i]
            cf, sf = math.cos(psi), math.sin(psi)
            # Rows of R (world -> camera): x_c = r, y_c = -sin f - cos u, z_c = cos f - sin u.
            rx0, rx1 = sf, -cf
            for c in range(num_cams):
                ox, oy = cam_xy[e, i, c, 0], cam_xy[e, i, c, 1]
                # Candidate boxes and their squared distances (painter's key).
                m = 0
                for b in range(nb):
                    if b < num_cars:
                        if b == i or done[e, b]:
                            continue
                        bx, by = car_pos[e, b, 0], car_pos[e, b, 1]
                        half = 0.5 * math.hypot(car_size[0], car_size[1])
                    else:
                        bx, by = obs_pos[e, b - num_cars, 0], obs_pos[e, b - num_cars, 1]
                        half = 0.5 * math.hypot(obs_size[b - num_cars, 0],
                                                obs_size[b - num_cars, 1])
                    ahead = (bx - ox) * cf + (by - oy) * sf
                    if ahead + half <= 0.0:
                        continue
                    key[m] = (bx - ox) ** 2 + (by - oy) ** 2
                    order[m] = b
                    m += 1
                # Insertion sort, farthest first (ties: lower index first).
                for a in range(1, m):
                    kv, ov = key[a], order[a]
                    j = a - 1
                    while j >= 0 and (key[j] < kv or (key[j] == kv and order[j] > ov)):
                        key[j + 1] = key[j]
                        order[j + 1] = order[j]
                        j -= 1
                    key[j + 1] = kv
                    order[j + 1] = ov
                nf = 0
                for a in range(m):
                    b = order[a]
                    if b < num_cars:
                        bx, by, byaw = car_pos[e, b, 0], car_pos[e, b, 1], car_yaw[e, b]
                        bl, bw, bh = car_size[0], car_size[1], car_size[2]
                        top = car_shades[b]
                    else:
                        k = b - num_cars
                        bx, by, byaw = obs_pos[e, k, 0], obs_pos[e, k, 1], obs_yaw[e, k]
                        bl, bw, bh = obs_size[k, 0], obs_size[k, 1], obs_size[k, 2]
                        top = obs_shade[k]
                    cb, sb = math.cos(byaw), math.sin(byaw)
                    # The 8 corners in camera coordinates: P - C = (dx, dy, z - cam_h).
                    for q in range(8):
                        lx, ly = sx[q % 4] * bl, sy[q % 4] * bw
                        dx = bx + cb * lx - sb * ly - ox
                        dy = by + sb * lx + cb * ly - oy
                        dz = (bh if q >= 4 else 0.0) - cam_h
                        fwd = dx * cf + dy * sf
                        corners[q, 0] = dx * rx0 + dy * rx1
                        corners[q, 1] = -sin_p * fwd - cos_p * dz
                        corners[q, 2] = cos_p * fwd - sin_p * dz
                    # Faces: side q joins footprint corners q, q+1 (outward normal of that
                    # edge); face 4 is the top.
                    for face in range(5):
                        if face < 4:
                            # Outward normal of edge q -> q+1 of a CCW footprint, box frame.
                            if face == 0:
                                nx, ny = 0.0, 1.0
                            elif face == 1:
                                nx, ny = -1.0, 0.0
                            elif face == 2:
                                nx, ny = 0.0, -1.0
                            else:
                                nx, ny = 1.0, 0.0
                            mid_x = 0.5 * (sx[face] + sx[(face + 1) % 4]) * bl
                            mid_y = 0.5 * (sy[face] + sy[(face + 1) % 4]) * bw
                            # Camera position in the box frame minus the face centre.
                            rel_x = (ox - bx) * cb + (oy - by) * sb - mid_x
                            rel_y = -(ox - bx) * sb + (oy - by) * cb - mid_y
                            if rel_x * nx + rel_y * ny <= 0.0:
                                continue
                            idx = (face, (face + 1) % 4, (face + 1) % 4 + 4, face + 4)
                            factor = FACE_FACTORS[1] if nx == 0.0 else FACE_FACTORS[0]
                        else:
                            if cam_h <= bh:
                                continue
                            idx = (4, 5, 6, 7)
                            factor = FACE_FACTORS[2]
                        for v in range(4):
                            poly[v, 0] = corners[idx[v], 0]
                            poly[v, 1] = corners[idx[v], 1]
                            poly[v, 2] = corners[idx[v], 2]
                        n = _clip_polygon(poly, 4, tmp, 2, 1.0, near)
                        if n < 3:
                            continue
                        # Project onto the image: col = cx + f X / Z, row = cy + f Y / Z.
                        for v in range(n):
                            z = tmp[v, 2]
                            poly[v, 0] = cx + focal * tmp[v, 0] / z
                            poly[v, 1] = cy + focal * tmp[v, 1] / z
                            poly[v, 2] = 0.0
                        # Clip to the image (one pixel beyond each edge) so that the fixed-point
                        # vertices stay small.
                        n = _clip_polygon(poly, n, tmp, 0, 1.0, -1.0)
                        n = _clip_polygon(tmp, n, poly, 0, -1.0, width)
                        n = _clip_polygon(poly, n, tmp, 1, 1.0, -1.0)
                        n = _clip_polygon(tmp, n, poly, 1, -1.0, height)
                        if n < 3:
                            continue
                        for v in range(n):
                            verts[e, i, c, nf, v, 0] = np.int32(round(poly[v, 0] * fixed))
                            verts[e, i, c, nf, v, 1] = np.int32(round(poly[v, 1] * fixed))
                        nverts[e, i, c, nf] = n
                        shade[e, i, c, nf] = round(top * factor)
                        nf += 1
                count[e, i, c] = nf


@njit(cache=True)
def ground_maps_kernel(position, yaw, forward, lateral, cam_h, sin_p, cos_p, k_inv_t,
                       world_to_texture, track_index, cam_xy, maps):  # pragma: no cover
    """Optical centre and image -> texture homography of every camera.

    The ray through pixel ``(u, v)`` has the world direction ``d = R^T K^-1 [u, v, 1]``
    (``K^-1 T`` is ``k_inv_t``, with ``T`` moving the warped band's rows to image rows). It
    meets the ground at ``C + lam d`` with ``lam = h / -d_z``; scaled by ``-d_z > 0`` (below
    the horizon) this point is ``G d`` in homogeneous coordinates, with::

        G = [[h, 0, -C_x], [0, h, -C_y], [0, 0, -1]]

    so the map from band pixels to texture pixels is ``A^-1 G R^T K^-1 T``.

    Args:
        position, yaw: Cars (E, N, 2) [m] and (E, N) [rad].
        forward: Optical centre ahead of the car's origin [m].
        lateral: Left offset of each camera, (C,) [m].
        cam_h, sin_p, cos_p: Height [m] and pitch of the cameras.
        k_inv_t: ``K^-1 T``, (3, 3). world_to_texture: ``A^-1`` of each track's texture,
            (K, 3, 3); track_index: the track of each copy, (E,).
        cam_xy: Out, optical centres (E, N, C, 2) [m].
        maps: Out, homographies (E, N, C, 3, 3).
    """
    num_envs, num_cars = yaw.shape
    rt = np.empty((3, 3))
    ray = np.empty((3, 3))
    g_ray = np.empty((3, 3))
    for e in range(num_envs):
        w2t = world_to_texture[track_index[e]]
        for i in range(num_cars):
            cf, sf = math.cos(yaw[e, i]), math.sin(yaw[e, i])
            # R^T: columns x_c = r, y_c = -sin f - cos u, z_c = cos f - sin u (world frame).
            rt[0, 0], rt[0, 1], rt[0, 2] = sf, -sin_p * cf, cos_p * cf
            rt[1, 0], rt[1, 1], rt[1, 2] = -cf, -sin_p * sf, cos_p * sf
            rt[2, 0], rt[2, 1], rt[2, 2] = 0.0, -cos_p, -sin_p
            for r in range(3):
                for col in range(3):
                    ray[r, col] = (rt[r, 0] * k_inv_t[0, col] + rt[r, 1] * k_inv_t[1, col]
                                   + rt[r, 2] * k_inv_t[2, col])
            for c in range(lateral.shape[0]):
                # C = p + forward f + lateral l, with l = (-sin, cos) the left unit vector.
                x = position[e, i, 0] + forward * cf - lateral[c] * sf
                y = position[e, i, 1] + forward * sf + lateral[c] * cf
                cam_xy[e, i, c, 0] = x
                cam_xy[e, i, c, 1] = y
                for col in range(3):
                    g_ray[0, col] = cam_h * ray[0, col] - x * ray[2, col]
                    g_ray[1, col] = cam_h * ray[1, col] - y * ray[2, col]
                    g_ray[2, col] = -ray[2, col]
                for r in range(3):
                    for col in range(3):
                        maps[e, i, c, r, col] = (w2t[r, 0] * g_ray[0, col]
                                                 + w2t[r, 1] * g_ray[1, col]
                                                 + w2t[r, 2] * g_ray[2, col])
