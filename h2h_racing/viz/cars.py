"""The per-car streams of a race recording: box, trail, camera image, lidar and scalars.

:class:`CarStreams` is the part of :class:`h2h_racing.viz.recorder.RaceRecorder` that logs every car
after a reset or a step (entity paths in :mod:`h2h_racing.viz.recorder`). It never imports rerun: it
logs through the recorder's stream (``self.rec``) and the rerun module the recorder imported
(``self._rr``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import cv2
import numpy as np
import numpy.typing as npt

from h2h_racing.sim import rewards
from h2h_racing.viz.render import car_colour

if TYPE_CHECKING:
    from h2h_racing.envs.parallel import RacingEnv

TRAJECTORY_PIECE = 128
"""Points per trajectory piece entity."""
REWARD_TERMS = rewards.TERMS
"""Names of the reward terms (``infos[agent]["reward_<term>"]``), in logging order."""
BOT_COLOUR = (205, 205, 215)


def _box_corners(centre: npt.NDArray[np.float64], yaw: npt.NDArray[np.float64],
                 length: float, width: float) -> npt.NDArray[np.float64]:
    """Closed outlines (..., 5, 2) of boxes with centres (..., 2) and headings (...)."""
    c, s = np.cos(yaw)[..., None], np.sin(yaw)[..., None]
    local = np.array([[0.5, 0.5], [0.5, -0.5], [-0.5, -0.5], [-0.5, 0.5], [0.5, 0.5]])
    local = local * [length, width]
    x = centre[..., None, 0] + c * local[:, 0] - s * local[:, 1]
    y = centre[..., None, 1] + s * local[:, 0] + c * local[:, 1]
    return np.stack([x, y], axis=-1)


class CarStreams:
    """Per-car logging of :class:`h2h_racing.viz.recorder.RaceRecorder` (a mixin: the recorder
    sets the attributes below in its ``__init__``)."""

    _rr: Any
    rec: Any
    env: RacingEnv
    agents: list[str]
    cameras: bool
    camera_every: int
    jpeg_quality: int
    lidar: bool
    _own_camera: Any
    _own_lidar: Any
    _lidar_angles: npt.NDArray[np.float64]
    _lidar_mount: npt.NDArray[np.float64]
    _step: int
    _trail: dict[str, list[list[float]]]
    _piece: dict[str, int]

    def _log_cars(self, obs: dict[str, Any], actions: dict[str, Any],
                  infos: dict[str, dict[str, Any]],
                  rewards: dict[str, float] | None = None) -> None:
        rr, rec, core = self._rr, self.rec, self.env.core
        strips = rr.LineStrips2D.from_fields
        cfg = core.config
        if core.num_bots:
            outlines = _box_corners(core.bot_position[0], core.bot_yaw[0], cfg.car.length,
                                    cfg.car.width)
            ticks = np.stack([0.5 * (outlines[:, 0] + outlines[:, 1]), core.bot_position[0]],
                             axis=1)
            rec.log("/map/bots", rr.LineStrips2D(list(outlines) + list(ticks), radii=0.015,
                                                 colors=BOT_COLOUR, draw_order=4.0))
        live = [i for i, a in enumerate(self.agents) if a in infos or not infos]
        boxes = _box_corners(core.position[0], core.yaw[0], cfg.car.length, cfg.car.width)
        position = core.position[0].tolist()
        frames = None
        if (self.cameras and self._own_camera is not None and live
                and self._step % self.camera_every == 0):
            frames = self._own_camera.render_frames(core)[0]
        ranges = None
        if self._own_lidar is not None:
            ranges = np.minimum(self._own_lidar.ranges(core)[0], cfg.lidar.max_range)
        parked = core.done[0].tolist()
        for i in live:
            agent = self.agents[i]
            colour = car_colour(i)
            base = f"/map/cars/{agent}"
            if parked[i]:
                # A finished or retired car is parked off the track: log its numbers only.
                self._log_numbers(i, agent, actions, infos, rewards)
                continue
            rec.log(f"{base}/box", strips(strips=[boxes[i], [0.5 * (boxes[i, 0] + boxes[i, 1]),
                                                           position[i]]]))
            self._log_trajectory(agent, position[i], colour)
            agent_obs = obs.get(agent)
            if self.cameras and self._step % self.camera_every == 0:
                image = None
                if frames is not None:
                    image = np.hstack(list(frames[i]))
                elif isinstance(agent_obs, dict) and "camera" in agent_obs:
                    stack = agent_obs["camera"]
                    cams = cfg.camera.cameras
                    image = np.hstack([stack[..., c] for c in
                                       range(stack.shape[-1] - cams, stack.shape[-1])])
                if image is not None:
                    self._log_image(f"/cars/{agent}/camera", image)
            if self.lidar:
                scan = None
                if ranges is not None:
                    scan = ranges[i]
                elif (isinstance(agent_obs, dict) and "lidar" in agent_obs
                      and cfg.lidar.mode == "lidar"):
                    scan = np.asarray(agent_obs["lidar"], dtype=np.float64)
                if scan is not None:
                    self._log_lidar(base, i, scan)
            self._log_numbers(i, agent, actions, infos, rewards)

    def _log_numbers(self, i: int, agent: str, actions: dict[str, Any],
                     infos: dict[str, dict[str, Any]], rewards: dict[str, float] | None,
                     ) -> None:
        rr, rec, core = self._rr, self.rec, self.env.core
        info = infos.get(agent)
        if info is not None:
            values = {"speed": float(core.speed[0, i]), "progress": info["progress"],
                      "rank": info["rank"], "gap_to_leader": info["gap_to_leader"]}
            if rewards is not None and agent in rewards:
                values["reward"] = rewards[agent]
                rec.log(f"/cars/{agent}/reward_terms",
                        rr.Scalars([info[f"reward_{t}"] for t in REWARD_TERMS]))
            for name, value in values.items():
                rec.log(f"/metrics/{name}/{agent}", rr.Scalars(float(value)))
        action = actions.get(agent)
        if action is not None:
            action = np.asarray(action, dtype=np.float64)
            if action.ndim == 0:
                rec.log(f"/cars/{agent}/action", rr.AnyValues(discrete_action=int(action)))
            else:
                rec.log(f"/cars/{agent}/action", rr.Scalars(action.ravel()))

    def _log_trajectory(self, agent: str, point: list[float], colour: tuple[int, int, int],
                        ) -> None:
        trail = self._trail[agent]
        trail.append(point)
        fresh = len(trail) == 1
        if len(trail) > TRAJECTORY_PIECE:
            # Start a new piece that begins where the last one ended.
            self._piece[agent] += 1
            del trail[:-2]
            fresh = True
        entity = f"/map/cars/{agent}/trajectory/{self._piece[agent]}"
        if fresh:
            self.rec.log(entity, self._rr.LineStrips2D.from_fields(
                radii=0.012, colors=colour, draw_order=5.0), static=True)
        self.rec.log(entity, self._rr.LineStrips2D.from_fields(strips=[trail]))

    def _log_image(self, entity: str, image: npt.NDArray[np.uint8]) -> None:
        ok, jpeg = cv2.imencode(".jpg", np.ascontiguousarray(image),
                                [cv2.IMWRITE_JPEG_QUALITY, self.jpeg_quality])
        if not ok:
            raise RuntimeError(f"OpenCV could not JPEG-encode a {image.shape} camera image")
        self.rec.log(entity, self._rr.EncodedImage(contents=jpeg.tobytes(),
                                                   media_type="image/jpeg"))

    def _log_lidar(self, base: str, car: int, scan: npt.NDArray[np.float64]) -> None:
        core = self.env.core
        yaw = float(core.yaw[0, car])
        c, s = np.cos(yaw), np.sin(yaw)
        mount = self._lidar_mount
        origin = core.position[0, car] + np.array([c * mount[0] - s * mount[1],
                                                   s * mount[0] + c * mount[1]])
        angles = yaw + self._lidar_angles
        ends = origin + scan[:, None] * np.stack([np.cos(angles), np.sin(angles)], axis=1)
        strips = np.stack([np.broadcast_to(origin, ends.shape), ends], axis=1)
        hits = ends[scan < self.env.config.lidar.max_range - 1e-6]
        self.rec.log(f"{base}/lidar/beams", self._rr.LineStrips2D.from_fields(strips=strips))
        self.rec.log(f"{base}/lidar/hits", self._rr.Points2D.from_fields(positions=hits))
