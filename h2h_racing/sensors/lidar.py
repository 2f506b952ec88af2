"""DeepRacer's lidar for every car, batched: ray-box intersection in one compiled pass.

The lidar is a planar scanner at ``mount`` in the car's frame. Beam ``k`` of ``B`` points at
the bearing ``alpha_k = -fov/2 + k fov / (B - 1)`` from the car's heading (counter-clockwise
positive, so beam 0 looks right-rearward and beam B-1 left-rearward, as Gazebo orders them).
It sees the other cars, the obstacles and the bot cars of the same env copy as boxes of
unlimited height (DeepRacer tracks have no walls); cars whose episode is over (parked) are not
seen.

Each beam is intersected with each box by the slab method, in the box's frame: with the ray
``o + t d`` (``o``, ``d`` rotated into the box frame, ``t`` in metres) and half-extents
``(hx, hy)``::

    t_lo,a = min((-h_a - o_a) / d_a, (h_a - o_a) / d_a)     a in {x, y}
    t_hi,a = max((-h_a - o_a) / d_a, (h_a - o_a) / d_a)
    t_near = max(t_lo,x, t_lo,y),  t_far = min(t_hi,x, t_hi,y)
    hit  <=>  t_far >= max(t_near, 0),  range = max(t_near, 0)

(a beam parallel to a slab misses unless ``|o_a| <= h_a``). The reading is the nearest hit.

Modes:
- ``"lidar"``: the ``B`` ranges, clipped to ``[min_range, max_range]``; a beam that hits
  nothing reads ``max_range``. With ``noise_std > 0`` each hit gets Gaussian noise
  ``N(0, noise_std^2)`` from the generator passed to :meth:`LidarSensor.observe` before
  clipping (beams that hit nothing stay exactly ``max_range``).
- ``"sector_lidar"``: DeepRacer's ``SECTOR_LIDAR``: the beams are split into ``sectors``
  consecutive groups of ``B / sectors``; a sector reads 1.0 if its nearest (noisy) range is
  below ``sector_clip``, else 0.0.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
from gymnasium import spaces
from numba import njit

from h2h_racing.config.env import LidarConfig

if TYPE_CHECKING:
    from h2h_racing.config.env import CarParams
    from h2h_racing.sim.core import RaceCore

FloatArray = npt.NDArray[np.float64]
Float32Array = npt.NDArray[np.float32]



@njit(cache=True)
def scan_kernel(position, yaw, done, obs_pos, obs_yaw, car_half, obs_half, mount, cos_a,
                sin_a, reach, out):  # pragma: no cover
    """Nearest hit of every beam of every car, or ``inf`` when nothing lies within ``reach``.

    Args:
        position, yaw, done: Cars (E, N, 2) [m], (E, N) [rad], parked flags (E, N).
        obs_pos, obs_yaw: Other boxes (obstacles, then bots) (E, K, 2) [m], (E, K) [rad].
        car_half: Half length and half width of the cars, (2,) [m].
        obs_half: Half length and half width of each other box, (K, 2) [m].
        mount: Scanner position in the car frame, (2,) [m].
        cos_a, sin_a: Cosine and sine of the beam bearings, (B,).
        reach: Boxes farther than this are skipped [m].
        out: Out, ranges (E, N, B) [m], ``inf`` for no hit.
    """
    num_envs, num_cars = yaw.shape
    num_obs = obs_yaw.shape[1]
    beams = cos_a.shape[0]
    for e in range(num_envs):
        for i in range(num_cars):
            row = out[e, i]
            for k in range(beams):
                row[k] = np.inf
            psi = yaw[e, i]
            c, s = math.cos(psi), math.sin(psi)
            ox = position[e, i, 0] + c * mount[0] - s * mount[1]
            oy = position[e, i, 1] + s * mount[0] + c * mount[1]
            for b in range(num_cars + num_obs):
                if b < num_cars:
                    if b == i or done[e, b]:
                        continue
                    bx, by, byaw = position[e, b, 0], position[e, b, 1], yaw[e, b]
                    hx, hy = car_half[0], car_half[1]
                else:
                    bx, by = obs_pos[e, b - num_cars, 0], obs_pos[e, b - num_cars, 1]
                    byaw = obs_yaw[e, b - num_cars]
                    hx, hy = obs_half[b - num_cars, 0], obs_half[b - num_cars, 1]
                rx, ry = ox - bx, oy - by
                if math.hypot(rx, ry) - math.hypot(hx, hy) > reach:
                    continue
                cb, sb = math.cos(byaw), math.sin(byaw)
                # Ray origin in the box frame: R(-yaw_b) (o - c_b).
                px = cb * rx + sb * ry
                py = -sb * rx + cb * ry
                # Beam direction in the box frame: bearing alpha_k + (psi - yaw_b).
                cd, sd = math.cos(psi - byaw), math.sin(psi - byaw)
                for k in range(beams):
                    dx = cos_a[k] * cd - sin_a[k] * sd
                    dy = sin_a[k] * cd + cos_a[k] * sd
                    t_near = -np.inf
                    t_far = np.inf
                    if dx != 0.0:
                        t1 = (-hx - px) / dx
                        t2 = (hx - px) / dx
                        t_near = max(t_near, min(t1, t2))
                        t_far = min(t_far, max(t1, t2))
                    elif abs(px) > hx:
                        continue
                    if dy != 0.0:
                        t1 = (-hy - py) / dy
                        t2 = (hy - py) / dy
                        t_near = max(t_near, min(t1, t2))
                        t_far = min(t_far, max(t1, t2))
                    elif abs(py) > hy:
                        continue
                    t = max(t_near, 0.0)
                    if t_far >= t and t < row[k]:
                        row[k] = t


@njit(cache=True)
def _finish_kernel(raw, noise, noise_std, min_range, max_range, out):  # pragma: no cover
    """Noisy hits clipped to [min_range, max_range]; misses read max_range; into float32."""
    num_envs, num_cars, beams = raw.shape
    noisy = noise.shape[0] > 0
    for e in range(num_envs):
        for i in range(num_cars):
            for k in range(beams):
                r = raw[e, i, k]
                if r == np.inf:
                    out[e, i, k] = max_range
                    continue
                if noisy:
                    r += noise_std * noise[e, i, k]
                out[e, i, k] = min(max(r, min_range), max_range)


class LidarSensor:
    """Batched lidar of every car of every env copy.

    Args:
        config: Lidar configuration.
        car: Car parameters (the box size of the cars).
        obstacle_size: (length, width) of the obstacle boxes [m].
    """

    def __init__(self, config: LidarConfig, car: CarParams,
                 obstacle_size: tuple[float, float] = (0.5, 0.4)) -> None:
        if not isinstance(config, LidarConfig):
            raise TypeError(f"config must be a LidarConfig, got {type(config).__name__}")
        self.config = config
        self._car_half = 0.5 * np.array([car.length, car.width])
        self._obs_half = 0.5 * np.array([float(obstacle_size[0]), float(obstacle_size[1])])
        self._mount = np.array([config.mount_forward_m, config.mount_left_m])
        angles = config.angles
        self._cos, self._sin = np.cos(angles), np.sin(angles)
        # Ranges beyond what the observation can show need not be measured exactly.
        self._reach = max(config.max_range, config.sector_clip) + 3.0 * config.noise_std
        self._no_noise = np.zeros((0, 0, 0))

    def space(self) -> spaces.Box:
        """Observation space of one car: ranges ``Box(min_range, max_range, (B,), float32)``
        or sector flags ``Box(0, 1, (sectors,), float32)`` with values in {0, 1}."""
        cfg = self.config
        if cfg.mode == "lidar":
            return spaces.Box(np.float32(cfg.min_range), np.float32(cfg.max_range),
                              (cfg.beams,), np.float32)
        return spaces.Box(0.0, 1.0, (cfg.sectors,), np.float32)

    def ranges(self, core: RaceCore) -> FloatArray:
        """Exact range of the nearest hit of every beam, (E, N, B) [m], ``inf`` for none
        within ``max(max_range, sector_clip)`` (plus three noise deviations)."""
        out = np.empty((core.num_envs, core.num_cars, self.config.beams))
        boxes, yaws, halves = self._other_boxes(core)
        scan_kernel(core.position, core.yaw, core.done, boxes, yaws, self._car_half, halves,
                    self._mount, self._cos, self._sin, self._reach, out)
        return out

    def _other_boxes(self, core: RaceCore) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Obstacles then bot cars: centres (E, K + B, 2), headings (E, K + B), halves
        (K + B, 2)."""
        k, b = core.num_obstacles, core.num_bots
        halves = np.concatenate([np.broadcast_to(self._obs_half, (k, 2)),
                                 np.broadcast_to(self._car_half, (b, 2))])
        if not b:
            return core.obstacle_position, core.obstacle_yaw, halves
        return (np.concatenate([core.obstacle_position, core.bot_position], axis=1),
                np.concatenate([core.obstacle_yaw, core.bot_yaw], axis=1), halves)

    def observe(self, core: RaceCore, rng: np.random.Generator | None = None) -> Float32Array:
        """Return the lidar observation of every car, (E, N, B) or (E, N, sectors) float32.

        Args:
            core: The simulation; only its state arrays are read.
            rng: Source of the range noise; required when ``noise_std > 0`` (it draws
                ``E * N * B`` standard normals per call), unused otherwise.

        Returns:
            Values inside :meth:`space`.
        """
        cfg = self.config
        raw = self.ranges(core)
        noise = self._no_noise
        if cfg.noise_std > 0.0:
            if not isinstance(rng, np.random.Generator):
                raise ValueError(f"LidarSensor.observe needs an np.random.Generator when "
                                 f"noise_std > 0 (got {type(rng).__name__}); pass the env's "
                                 f"seeded generator")
            noise = rng.standard_normal(raw.shape)
        if cfg.mode == "lidar":
            out = np.empty(raw.shape, dtype=np.float32)
            _finish_kernel(raw, noise, cfg.noise_std, cfg.min_range, cfg.max_range, out)
            return out
        if noise.size:
            raw = raw + cfg.noise_std * noise
        per = cfg.beams // cfg.sectors
        nearest = raw.reshape(core.num_envs, core.num_cars, cfg.sectors, per).min(axis=3)
        return (nearest < cfg.sector_clip).astype(np.float32)
