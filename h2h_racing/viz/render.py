"""Top-down spectator frames with OpenCV (``render_mode="rgb_array"``, previews, videos).

Nothing reads these frames back into observations: they are for people only. The track
is drawn once into a background image; each frame copies it and draws what moves.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import cv2
import numpy as np
import numpy.typing as npt

from h2h_racing.track.lookup import MAX_SAMPLES

if TYPE_CHECKING:
    from h2h_racing.sim.core import RaceCore
    from h2h_racing.track.shape import Track

FLOOR = (46, 58, 46)
SURFACE = (92, 92, 96)
BORDER = (235, 235, 235)
CENTRE = (225, 190, 40)
START = (230, 60, 60)
OBSTACLE = (160, 110, 60)
BOT = (205, 205, 215)
"""RGB colour of every bot car (drawn darker while the bots are paused)."""
CAR_COLOURS = [(230, 57, 70), (69, 123, 230), (42, 180, 90), (240, 170, 30), (160, 80, 200),
               (30, 190, 200), (240, 110, 170), (130, 130, 60)]
"""RGB colour of car i is ``CAR_COLOURS[i % 8]``."""


def car_colour(index: int) -> tuple[int, int, int]:
    """Return the RGB colour of car ``index`` (the same in every view)."""
    return CAR_COLOURS[index % len(CAR_COLOURS)]


class SpectatorRenderer:
    """Draws a track and the cars on it from above.

    Args:
        track: The track.
        width: Image width in pixels; the height follows the track's aspect ratio.
        margin: Margin around the track's bounding box [m].
    """

    def __init__(self, track: Track, width: int = 720, margin: float = 0.5) -> None:
        self.track = track
        xmin, ymin, xmax, ymax = track.bounds
        self.origin = np.array([xmin - margin, ymax + margin])
        self.scale = (width - 1) / (xmax - xmin + 2 * margin)
        height = int(round((ymax - ymin + 2 * margin) * self.scale)) + 1
        self.size = (width, height)
        self.background = self._draw_track()

    def to_pixels(self, xy: npt.ArrayLike) -> npt.NDArray[np.int32]:
        """Map world points (..., 2) in metres to pixel coordinates (y axis down)."""
        xy = np.asarray(xy, dtype=np.float64)
        px = (xy[..., 0] - self.origin[0]) * self.scale
        py = (self.origin[1] - xy[..., 1]) * self.scale
        return np.round(np.stack([px, py], axis=-1)).astype(np.int32)

    def _draw_track(self) -> npt.NDArray[np.uint8]:
        track = self.track
        w, h = self.size
        img = np.empty((h, w, 3), dtype=np.uint8)
        img[:] = FLOOR
        left = self.to_pixels(track.left_border)
        right = self.to_pixels(track.right_border)
        # The outer border encloses the larger area: fill it with the surface, then cut out
        # the inner one.
        area_left = abs(cv2.contourArea(left.astype(np.float32)))
        area_right = abs(cv2.contourArea(right.astype(np.float32)))
        outer, inner = (left, right) if area_left >= area_right else (right, left)
        cv2.fillPoly(img, [outer], SURFACE, lineType=cv2.LINE_AA)
        cv2.fillPoly(img, [inner], FLOOR, lineType=cv2.LINE_AA)
        thickness = max(1, int(round(0.05 * self.scale)))
        cv2.polylines(img, [left, right], True, BORDER, thickness, cv2.LINE_AA)
        # Dashed centre line: 0.3 m dashes every 0.6 m, sampled no finer than half a pixel and
        # in at most MAX_SAMPLES samples (a lap of thousands of km would not fit in memory).
        step = max(0.1, 0.5 / self.scale, track.length / MAX_SAMPLES)
        s = np.arange(0.0, track.length, step)
        pts = self.to_pixels(track.point_at(s))
        dash = (np.floor(s / 0.3).astype(int) % 2) == 0
        for i in np.flatnonzero(dash[:-1] & dash[1:]):
            cv2.line(img, tuple(pts[i]), tuple(pts[i + 1]), CENTRE, 1, cv2.LINE_AA)
        left0, right0 = track.half_widths_at(np.array([0.0]))
        start = track.point_at(np.array([0.0, 0.0]), np.array([left0[0], -right0[0]]))
        p = self.to_pixels(start)
        cv2.line(img, tuple(p[0]), tuple(p[1]), START, max(2, thickness), cv2.LINE_AA)
        return img

    @staticmethod
    def _box(centre: npt.NDArray[np.float64], yaw: npt.NDArray[np.float64], length: float,
             width: float) -> npt.NDArray[np.float64]:
        """Corners (..., 4, 2) of boxes with the given centres (..., 2) and headings (...)."""
        c, s = np.cos(yaw)[..., None], np.sin(yaw)[..., None]
        local = np.array([[0.5, 0.5], [0.5, -0.5], [-0.5, -0.5], [-0.5, 0.5]]) * [length, width]
        x = centre[..., None, 0] + c * local[:, 0] - s * local[:, 1]
        y = centre[..., None, 1] + s * local[:, 0] + c * local[:, 1]
        return np.stack([x, y], axis=-1)

    def draw(self, core: RaceCore, env_index: int = 0, hud: bool = True) -> npt.NDArray[np.uint8]:
        """Return the frame of env copy ``env_index``, shape (H, W, 3), RGB uint8."""
        img = self.background.copy()
        cfg = core.config
        e = env_index
        if core.num_obstacles:
            boxes = self._box(core.obstacle_position[e], core.obstacle_yaw[e],
                              cfg.obstacle_length, cfg.obstacle_width)
            cv2.fillPoly(img, list(self.to_pixels(boxes)), OBSTACLE, cv2.LINE_AA)
        if core.num_bots:
            paused = core.bot_pause_until[e] > core.time[e]
            colour = tuple(int(0.6 * c) for c in BOT) if paused else BOT
            boxes = self._box(core.bot_position[e], core.bot_yaw[e], cfg.car.length,
                              cfg.car.width)
            cv2.fillPoly(img, list(self.to_pixels(boxes)), colour, cv2.LINE_AA)
            heading = np.stack([np.cos(core.bot_yaw[e]), np.sin(core.bot_yaw[e])], axis=-1)
            for nose in self.to_pixels(core.bot_position[e] + 0.12 * heading).tolist():
                cv2.circle(img, tuple(nose), max(1, int(0.03 * self.scale)), (40, 40, 40), -1,
                           cv2.LINE_AA)
        boxes = self._box(core.position[e], core.yaw[e], cfg.car.length, cfg.car.width)
        pixels = self.to_pixels(boxes)
        frozen = core.frozen[e]
        for i in np.flatnonzero(~core.done[e]):
            colour = car_colour(int(i))
            if frozen[i]:
                colour = tuple(int(0.5 * c + 64) for c in colour)
            cv2.fillPoly(img, [pixels[i]], colour, cv2.LINE_AA)
            nose = self.to_pixels(core.position[e, i] + 0.12 * np.array(
                [np.cos(core.yaw[e, i]), np.sin(core.yaw[e, i])]))
            cv2.circle(img, tuple(int(v) for v in nose), max(1, int(0.03 * self.scale)),
                       (255, 255, 255), -1, cv2.LINE_AA)
        if hud:
            text = f"t={core.time[e]:6.2f}s"
            cv2.putText(img, text, (8, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1,
                        cv2.LINE_AA)
            for i in range(core.num_cars):
                line = f"car_{i} P{core.rank[e, i]} lap {core.laps[e, i]}"
                cv2.putText(img, line, (8, 38 + 18 * i), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                            car_colour(i), 1, cv2.LINE_AA)
        return img
