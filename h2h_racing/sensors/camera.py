"""DeepRacer's front camera for every car, batched: greyscale frames rendered from the state.

The camera is a pinhole mounted like DeepRacer's simulated ZED camera: ``forward_m`` ahead of
the car's origin, ``height_m`` above the ground, pitched down by ``pitch_deg``, horizontal field
of view ``hfov_deg``, square pixels. A frame is drawn in three layers, none of which depends on
the spectator renderer or on ``render_mode``:

1. **Sky** above the horizon: one constant shade.
2. **Ground** below the horizon: a greyscale texture of the whole track (surface, painted
   border lines, dashed centre line, start line, floor) pre-rendered once, warped into the
   image with the ground-plane homography of the camera's pose (``cv2.warpPerspective``).
3. **Boxes**: the other cars, the obstacles and the bot cars as solid 3-D boxes. Their visible
   faces are clipped to the near plane and the image in a compiled kernel and filled with
   ``cv2.fillConvexPoly``, far boxes first (painter's order), so nearer boxes hide farther ones.

Camera frame (OpenCV convention): ``x_c`` right, ``y_c`` down, ``z_c`` along the optical axis.
With the car heading ``psi``, its forward unit vector ``f = (cos psi, sin psi, 0)``, its right
unit vector ``r = (sin psi, -cos psi, 0)``, the up vector ``u = (0, 0, 1)`` and the pitch
``theta`` (down positive)::

    x_c = r
    y_c = -sin(theta) f - cos(theta) u
    z_c =  cos(theta) f - sin(theta) u

A world point ``P`` seen from the optical centre ``C`` projects to the pixel::

    (X, Y, Z) = R (P - C)              R = [x_c; y_c; z_c] (rows)
    col = cx + fx X / Z,   row = cy + fy Y / Z
    fx = fy = (W / 2) / tan(hfov / 2), cx = (W - 1) / 2, cy = (H - 1) / 2

(pixel centres at integer coordinates). The horizon (``Y / Z = -tan(theta)`` for directions
parallel to the ground) is the row ``cy - fy tan(theta)``; rows below it see the ground.

The compiled kernels (box faces, ground homographies) live in
:mod:`h2h_racing.sensors.camera_kernels`.

Channels: ``C = cameras * frame_stack``; channel ``t * cameras + c`` holds camera ``c`` (0 =
left, 1 = right with ``stereo``) of the ``t``-th frame, oldest first, newest last.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np
import numpy.typing as npt
from gymnasium import spaces

from h2h_racing.config.env import CameraConfig
from h2h_racing.sensors.camera_kernels import (
    FACE_FACTORS,  # re-exported: the shades of a box's faces, which tests and users check
    FACES_PER_BOX,
    MAX_VERTICES,
    SHIFT,
    box_faces_kernel,
    ground_maps_kernel,
)
from h2h_racing.track.shape import Track
from h2h_racing.track.lookup import MAX_SAMPLES

if TYPE_CHECKING:
    from h2h_racing.config.env import CarParams
    from h2h_racing.sim.core import RaceCore

UInt8Array = npt.NDArray[np.uint8]
FloatArray = npt.NDArray[np.float64]

SKY = 205
"""Grey level of the sky."""
FLOOR = 95
"""Grey level of the floor beyond the track."""
SURFACE = 45
"""Grey level of the track surface."""
BORDER = 250
"""Grey level of the painted border lines (white)."""
CENTRE = 195
"""Grey level of the dashed centre line (DeepRacer's yellow, as luma)."""
START = 235
"""Grey level of the start line."""
OBSTACLE_SHADE = 225
"""Grey level of the top face of an obstacle box."""
CAR_SHADES = (130, 15, 240, 70, 160, 35, 105, 190)
"""Grey level of the top face of car ``i`` is ``CAR_SHADES[i % 8]`` (the same in every view)."""
BOT_SHADE = 175
"""Grey level of the top face of every bot car (a shade no car has)."""

BORDER_LINE_M = 0.05
"""Width of the painted border lines [m] (2 in tape)."""
CENTRE_LINE_M = 0.03
"""Width of the dashed centre line [m]."""
DASH_M = 0.3
"""Length of a centre-line dash and of the gap after it [m]."""
TEXTURE_MARGIN_M = 1.0
"""Floor drawn around the track's bounding box in the texture [m]."""


def car_shade(index: int) -> int:
    """Return the grey level of car ``index``'s top face in every camera."""
    return CAR_SHADES[index % len(CAR_SHADES)]


# ---------------------------------------------------------------------------- ground texture

class GroundTexture:
    """A greyscale top-down picture of the track and floor, drawn once with OpenCV.

    Texture pixel ``(a, b)`` (column, row) has its centre at the world point
    ``X = x0 + a res``, ``Y = y1 - b res``, so world to texture is the affine map ``A^-1``::

        [a]   [1/res    0    -x0/res] [X]
        [b] = [  0   -1/res   y1/res] [Y]
        [1]   [  0      0       1   ] [1]

    Args:
        track: The track to draw.
        resolution: Requested size of a pixel [m/px].
        max_px: Largest allowed side [px]; the resolution is coarsened to respect it.
    """

    def __init__(self, track: Track, resolution: float, max_px: int) -> None:
        xmin, ymin, xmax, ymax = track.bounds
        x0, y1 = xmin - TEXTURE_MARGIN_M, ymax + TEXTURE_MARGIN_M
        span = max(xmax - xmin, ymax - ymin) + 2.0 * TEXTURE_MARGIN_M
        res = max(resolution, span / (max_px - 1))
        self.resolution = res
        """Size of one pixel [m/px]."""
        self.origin = (x0, y1)
        """World position of the centre of pixel (0, 0): (x0, y1) [m]."""
        cols = math.ceil((xmax + TEXTURE_MARGIN_M - x0) / res) + 1
        rows = math.ceil((y1 - (ymin - TEXTURE_MARGIN_M)) / res) + 1
        self.world_to_texture = np.array([[1.0 / res, 0.0, -x0 / res],
                                          [0.0, -1.0 / res, y1 / res],
                                          [0.0, 0.0, 1.0]])
        """The 3 x 3 affine map from homogeneous world points to texture pixels."""
        self.image = self._draw(track, rows, cols)
        """The texture, shape (rows, cols), uint8."""

    def to_pixels(self, xy: FloatArray) -> npt.NDArray[np.int32]:
        """Map world points (..., 2) [m] to fixed-point texture pixels (``SHIFT`` bits)."""
        x0, y1 = self.origin
        scale = (1 << SHIFT) / self.resolution
        a = (xy[..., 0] - x0) * scale
        b = (y1 - xy[..., 1]) * scale
        return np.round(np.stack([a, b], axis=-1)).astype(np.int32)

    def _draw(self, track: Track, rows: int, cols: int) -> UInt8Array:
        img = np.full((rows, cols), FLOOR, dtype=np.uint8)
        res = self.resolution
        left = self.to_pixels(track.left_border)
        right = self.to_pixels(track.right_border)
        # The outer border encloses the larger area: fill it with the surface, then cut the
        # inner one back to floor.
        area_left = abs(cv2.contourArea(left.astype(np.float32)))
        area_right = abs(cv2.contourArea(right.astype(np.float32)))
        outer, inner = (left, right) if area_left >= area_right else (right, left)
        cv2.fillPoly(img, [outer], SURFACE, cv2.LINE_8, SHIFT)
        cv2.fillPoly(img, [inner], FLOOR, cv2.LINE_8, SHIFT)
        border_px = max(1, round(BORDER_LINE_M / res))
        cv2.polylines(img, [left, right], True, BORDER, border_px, cv2.LINE_8, SHIFT)
        # Dashed centre line: DASH_M on, DASH_M off, sampled every centimetre (in at most
        # MAX_SAMPLES samples: a lap of thousands of km gets coarser, aliased dashes).
        step = max(min(0.01, DASH_M / 4), track.length / MAX_SAMPLES)
        s = np.arange(0.0, track.length, step)
        on = (np.floor(s / DASH_M).astype(np.int64) % 2) == 0
        pts = self.to_pixels(track.point_at(s))
        # Split the samples into runs of consecutive "on" samples: one polyline per dash.
        edges = np.flatnonzero(np.diff(on.astype(np.int8)))
        starts = np.concatenate([[0], edges + 1])
        stops = np.concatenate([edges + 1, [len(s)]])
        dashes = [pts[a:b] for a, b in zip(starts, stops) if on[a] and b - a >= 2]
        centre_px = max(1, round(CENTRE_LINE_M / res))
        cv2.polylines(img, dashes, False, CENTRE, centre_px, cv2.LINE_8, SHIFT)
        # Start line across the track at s = 0.
        left0, right0 = track.half_widths_at(np.array([0.0]))
        ends = self.to_pixels(track.point_at(np.zeros(2), np.array([left0[0], -right0[0]])))
        cv2.line(img, tuple(int(v) for v in ends[0]), tuple(int(v) for v in ends[1]), START,
                 border_px, cv2.LINE_8, SHIFT)
        return img


# ---------------------------------------------------------------------------- sensor

class CameraSensor:
    """Batched front camera of every car of every env copy.

    Args:
        config: Camera configuration.
        track: The track (its ground texture is drawn once here), or the tracks of a core of
            several, in its order (``core.tracks``): copy e sees track
            ``core.track_index[e]``'s texture.
        car: Car parameters (the box size of the cars).
        obstacle_size: (length, width) of the obstacle boxes [m].
    """

    def __init__(self, config: CameraConfig, track: Track | Sequence[Track], car: CarParams,
                 obstacle_size: tuple[float, float] = (0.5, 0.4)) -> None:
        if not isinstance(config, CameraConfig):
            raise TypeError(f"config must be a CameraConfig, got {type(config).__name__}")
        self.config = config
        self.tracks: tuple[Track, ...] = (track,) if isinstance(track, Track) else tuple(track)
        """The tracks whose textures the copies see."""
        drawn: dict[int, GroundTexture] = {}
        for t in self.tracks:
            if id(t) not in drawn:
                drawn[id(t)] = GroundTexture(t, config.texture_resolution_m,
                                             config.max_texture_px)
        self.textures = [drawn[id(t)] for t in self.tracks]
        """The ground texture of each track."""
        self._world_to_texture = np.stack([t.world_to_texture for t in self.textures])
        self.car_size = np.array([car.length, car.width, config.car_height_m])
        self.obstacle_size = np.array([float(obstacle_size[0]), float(obstacle_size[1]),
                                       config.obstacle_height_m])
        w, h = config.width, config.height
        self.focal = config.focal_px
        self.cx, self.cy = 0.5 * (w - 1), 0.5 * (h - 1)
        pitch = math.radians(config.pitch_deg)
        self._sin_p, self._cos_p = math.sin(pitch), math.cos(pitch)
        # First row that sees the ground: rows below the horizon row cy - f tan(pitch).
        self.ground_row = int(min(h, max(0, math.floor(config.horizon_row) + 1)))
        """Rows ``ground_row`` and below show the ground; rows above show the sky."""
        # Lateral offset of each camera from the car's axis [m], left positive.
        half_base = 0.5 * config.stereo_baseline_m
        self._lateral = np.array([half_base, -half_base]) if config.stereo else np.zeros(1)
        # Constant part of the image -> texture map: K^-1 T, with T moving the warped band
        # (which starts at ground_row) back to full-image rows.
        k_inv = np.array([[1.0 / self.focal, 0.0, -self.cx / self.focal],
                          [0.0, 1.0 / self.focal, -self.cy / self.focal],
                          [0.0, 0.0, 1.0]])
        shift = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, float(self.ground_row)], [0.0, 0.0, 1.0]])
        self._k_inv_t = k_inv @ shift
        self._flags = cv2.WARP_INVERSE_MAP | (
            cv2.INTER_LINEAR if config.interpolation == "linear" else cv2.INTER_NEAREST)
        self._hist: UInt8Array | None = None
        self._last_steps: npt.NDArray[np.int64] | None = None
        self._buffers: dict[str, np.ndarray] = {}
        self._tables: dict[str, tuple[np.ndarray, ...]] = {}

    @property
    def track(self) -> Track:
        """The one track (a camera of several tracks has ``tracks``)."""
        return self._only(self.tracks)

    @property
    def texture(self) -> GroundTexture:
        """The one track's ground texture (a camera of several tracks has ``textures``)."""
        return self._only(self.textures)

    def _only(self, values: Sequence[object]) -> object:
        if len(values) != 1:
            raise AttributeError(f"this camera sees {len(values)} tracks: use tracks and "
                                 f"textures, one per track")
        return values[0]

    # ------------------------------------------------------------------ spaces
    def space(self) -> spaces.Box:
        """Observation space of one car: ``Box(0, 255, (H, W, C), uint8)``."""
        cfg = self.config
        return spaces.Box(0, 255, (cfg.height, cfg.width, cfg.channels), np.uint8)

    def reset(self, core: RaceCore | None = None) -> None:
        """Forget the frame history: the next observation repeats its frame in every slot."""
        self._hist = None
        self._last_steps = None

    # ------------------------------------------------------------------ geometry
    def camera_positions(self, position: FloatArray, yaw: FloatArray) -> FloatArray:
        """Optical centres on the ground plane, (E, N, C, 2) [m], for cars at ``position``
        (E, N, 2) [m] heading ``yaw`` (E, N) [rad]: ``p + forward_m f + lateral l``."""
        cam_xy, _ = self.ground_maps(position, yaw)
        return cam_xy

    def ground_maps(self, position: FloatArray, yaw: FloatArray,
                    track_index: npt.NDArray[np.int64] | None = None,
                    ) -> tuple[FloatArray, FloatArray]:
        """Optical centres (E, N, C, 2) [m] and image-band -> texture homographies
        (E, N, C, 3, 3) for ``cv2.WARP_INVERSE_MAP`` into each copy's track's texture
        (``track_index`` (E,); None: track 0); see :func:`ground_maps_kernel`."""
        e_n, n_n = yaw.shape
        c_n = self.config.cameras
        cam_xy = np.empty((e_n, n_n, c_n, 2))
        maps = np.empty((e_n, n_n, c_n, 3, 3))
        if track_index is None:
            track_index = np.zeros(e_n, dtype=np.int64)
        ground_maps_kernel(position, yaw, self.config.forward_m, self._lateral,
                           self.config.height_m, self._sin_p, self._cos_p, self._k_inv_t,
                           self._world_to_texture, track_index, cam_xy, maps)
        return cam_xy, maps

    def _buffer(self, name: str, shape: tuple[int, ...], dtype: type) -> np.ndarray:
        buf = self._buffers.get(name)
        if buf is None or buf.shape != shape:
            buf = np.empty(shape, dtype=dtype)
            self._buffers[name] = buf
        return buf

    # ------------------------------------------------------------------ rendering
    def render_frames(self, core: RaceCore, frames: UInt8Array | None = None) -> UInt8Array:
        """Render the current frame of every camera, (E, N, C_cams, H, W) uint8.

        Args:
            core: The simulation; only its state arrays are read.
            frames: Optional C-contiguous output array of that shape.

        Returns:
            The frames (``frames`` when given). No history is touched.
        """
        cfg = self.config
        e_n, n_n, c_n = core.num_envs, core.num_cars, cfg.cameras
        w, h = cfg.width, cfg.height
        shape = (e_n, n_n, c_n, h, w)
        if frames is None:
            frames = np.empty(shape, dtype=np.uint8)
        elif frames.shape != shape or frames.dtype != np.uint8 or not frames.flags.c_contiguous:
            raise ValueError(f"frames must be a C-contiguous uint8 array of shape {shape}, got "
                             f"{frames.dtype}{frames.shape}; pass None to allocate one")
        if core.num_tracks != len(self.textures):
            raise ValueError(f"this camera holds the textures of {len(self.textures)} tracks, "
                             f"but the core races {core.num_tracks}; build it with the core's "
                             f"tracks (CameraSensor(config, core.tracks, ...))")
        cam_xy, maps = self.ground_maps(core.position, core.yaw, core.track_index)
        boxes, yaws, sizes, shades = self._other_boxes(core)
        num_faces = (n_n - 1 + boxes.shape[1]) * FACES_PER_BOX
        count = self._buffer("count", (e_n, n_n, c_n), np.int64)
        nverts = self._buffer("nverts", (e_n, n_n, c_n, max(num_faces, 1)), np.int64)
        verts = self._buffer("verts", (e_n, n_n, c_n, max(num_faces, 1), MAX_VERTICES, 2),
                             np.int32)
        shade = self._buffer("shade", (e_n, n_n, c_n, max(num_faces, 1)), np.int64)
        box_faces_kernel(cam_xy, core.yaw, core.position,
                         core.yaw, core.done, boxes, yaws,
                         self.car_size, sizes, self._car_shades(n_n),
                         shades, cfg.height_m, self._sin_p, self._cos_p, self.focal,
                         self.cx, self.cy, cfg.near_m, float(w), float(h), count, nverts,
                         verts, shade)
        flat = frames.reshape(-1, h, w)
        r0 = self.ground_row
        flat[:, :r0] = SKY
        if r0 < h:
            maps = maps.reshape(-1, 3, 3)
            size, flags = (w, h - r0), self._flags
            warp = cv2.warpPerspective
            images = [t.image for t in self.textures]
            # Each frame warps its copy's track's texture.
            of_frame = np.repeat(core.track_index, n_n * c_n).tolist()
            for f in range(flat.shape[0]):
                warp(images[of_frame[f]], maps[f], size, dst=flat[f, r0:], flags=flags,
                     borderMode=cv2.BORDER_CONSTANT, borderValue=FLOOR)
        counts = count.reshape(-1)
        if counts.any():
            fill = cv2.fillConvexPoly
            verts_f = verts.reshape(-1, verts.shape[3], MAX_VERTICES, 2)
            nverts_f = nverts.reshape(-1, nverts.shape[3])
            shade_f = shade.reshape(-1, shade.shape[3])
            for f in np.flatnonzero(counts).tolist():
                img = flat[f]
                nv = nverts_f[f].tolist()
                sh = shade_f[f].tolist()
                for k in range(int(counts[f])):
                    fill(img, verts_f[f, k, :nv[k]], sh[k], cv2.LINE_8, SHIFT)
        return frames

    def _car_shades(self, num_cars: int) -> npt.NDArray[np.int64]:
        """Top-face grey level of each car, (N,) (``car_shade``: they repeat every 8 cars)."""
        key = f"car_shades_{num_cars}"
        if key not in self._tables:
            self._tables[key] = (np.array([car_shade(i) for i in range(num_cars)],
                                          dtype=np.int64),)
        return self._tables[key][0]

    def _other_boxes(self, core: RaceCore,
                     ) -> tuple[FloatArray, FloatArray, FloatArray, npt.NDArray[np.int64]]:
        """Obstacles then bot cars: centres (E, K + B, 2), headings (E, K + B), sizes
        (K + B, 3) and top-face shades (K + B,)."""
        k, b = core.num_obstacles, core.num_bots
        key = f"boxes_{k}_{b}"
        table = self._tables.get(key)
        if table is None:
            sizes = np.concatenate([np.broadcast_to(self.obstacle_size, (k, 3)),
                                    np.broadcast_to(self.car_size, (b, 3))])
            shades = np.array([OBSTACLE_SHADE] * k + [BOT_SHADE] * b, dtype=np.int64)
            table = self._tables[key] = (np.ascontiguousarray(sizes), shades)
        if not b:
            return core.obstacle_position, core.obstacle_yaw, table[0], table[1]
        return (np.concatenate([core.obstacle_position, core.bot_position], axis=1),
                np.concatenate([core.obstacle_yaw, core.bot_yaw], axis=1), table[0], table[1])

    def render(self, core: RaceCore, env_index: int = 0, car_index: int = 0) -> UInt8Array:
        """Return the current frame of one car, (H, W, C_cams) uint8, without history."""
        frames = self.render_frames(core)
        return np.ascontiguousarray(frames[env_index, car_index].transpose(1, 2, 0))

    def observe(self, core: RaceCore, out: UInt8Array | None = None) -> UInt8Array:
        """Return the camera observation of every car, (E, N, H, W, C) uint8, C-contiguous.

        With ``frame_stack > 1`` the sensor keeps each car's history. An env copy whose
        ``core.steps`` is 0 (a new episode) has every slot filled with the current frame;
        a later step shifts the history by one frame; observing the same step twice replaces
        the newest frame only.

        Args:
            core: The simulation; only its state arrays are read.
            out: Optional C-contiguous uint8 output of that shape (reused to avoid allocation).

        Returns:
            The observation (``out`` when given).
        """
        cfg = self.config
        e_n, n_n = core.num_envs, core.num_cars
        shape = (e_n, n_n, cfg.height, cfg.width, cfg.channels)
        if out is None:
            out = np.empty(shape, dtype=np.uint8)
        elif out.shape != shape or out.dtype != np.uint8 or not out.flags.c_contiguous:
            raise ValueError(f"out must be a C-contiguous uint8 array of shape {shape}, got "
                             f"{out.dtype}{out.shape}; pass None to allocate one")
        if cfg.channels == 1:
            # (E, N, H, W, 1) has the memory layout of (E, N, 1, H, W): render in place.
            self.render_frames(core, out.reshape(e_n, n_n, 1, cfg.height, cfg.width))
            return out
        cams, stack = cfg.cameras, cfg.frame_stack
        frames = self.render_frames(
            core, self._buffer("frames", (e_n, n_n, cams, cfg.height, cfg.width), np.uint8))
        steps = core.steps
        hist = self._hist
        if hist is None or hist.shape[:2] != (e_n, n_n) or self._last_steps is None:
            hist = np.empty((e_n, n_n, cams * stack, cfg.height, cfg.width), dtype=np.uint8)
            new = np.ones(e_n, dtype=bool)
        else:
            new = steps == 0
        advance = ~new & (steps != self._last_steps)
        if stack > 1 and advance.any():
            hist[advance, :, :-cams] = hist[advance, :, cams:]
        hist[:, :, -cams:] = frames
        if new.any():
            hist[new] = np.tile(frames[new], (1, 1, stack, 1, 1))
        self._hist = hist
        self._last_steps = steps.copy()
        out[...] = hist.transpose(0, 1, 3, 4, 2)
        return out


def save_camera_png(core: RaceCore, car: int, path: str | Path, env: int = 0,
                    config: CameraConfig | None = None, scale: int = 1) -> Path:
    """Save what car ``car`` of env copy ``env`` sees now as a greyscale PNG for people.

    Args:
        core: The simulation (after ``reset``).
        car: Car index in [0, N).
        path: Output file (``.png``).
        env: Env copy index in [0, E).
        config: Camera configuration; None uses the defaults (DeepRacer's camera).
        scale: Integer upscaling (nearest neighbour) for viewing, >= 1.

    Returns:
        The path written. A stereo camera is saved as the left and right images side by side.
    """
    if not 0 <= car < core.num_cars:
        raise ValueError(f"car must be in [0, {core.num_cars - 1}], got {car}")
    if not 0 <= env < core.num_envs:
        raise ValueError(f"env must be in [0, {core.num_envs - 1}], got {env}")
    if not isinstance(scale, int) or scale < 1:
        raise ValueError(f"scale must be an int >= 1, got {scale!r}")
    sensor = CameraSensor(config or CameraConfig(), core.tracks, core.config.car,
                          (core.config.obstacle_length, core.config.obstacle_width))
    frame = sensor.render(core, env, car)
    image = np.concatenate([frame[:, :, c] for c in range(frame.shape[2])], axis=1)
    if scale > 1:
        image = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
    path = Path(path)
    if not cv2.imwrite(str(path), image):
        raise OSError(f"could not write {path}; check that the folder exists and ends in .png")
    return path
