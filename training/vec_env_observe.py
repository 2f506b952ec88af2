"""The observation groups of a ``RacingVecEnv``: what its actor and critic read.

Observation groups (a ``TensorDict`` with batch size ``num_envs * learners``):

- ``policy``: the state vector of the learner car, (B, F) float32;
- ``critic``: privileged state for an asymmetric critic, (B, F + 4 (N - 1)): the state vector and,
  for every other car in car order, its arc gap (wrapped, / 5 m), lateral offset, forward speed
  (/ 4 m/s) and heading error, whatever its distance;
- ``camera`` (with every ``observations`` but ``"state"``): the learner's camera as
  (B, C, H, W) float32 in [0, 1], ready for rsl-rl's ``CNNModel``;
- ``motion`` (with ``observations="camera_only"`` or ``"camera_lidar"``): the learner's own
  forward speed and steering angle, (B, 2) float32 (state features 0 and 3,
  ``MOTION_FEATURES``). A camera-only actor reads ``camera`` and ``motion``: no track geometry
  and no other car's state, as DeepRacer's camera models (which get the image alone) plus the
  car's odometry;
- ``lidar`` (with ``observations="camera_lidar"``): the learner's lidar (``config.lidar``,
  ``h2h_racing.sensors.lidar``; DeepRacer's by default: 64 ranges over +-150 deg, clipped to
  [0.15, 1.0] m, a beam that hits nothing reads 1.0), (B, beams) float32, or (B, sectors)
  with ``mode="sector_lidar"``. It sees the other cars, the boxes and the bot cars, not the
  track's borders. A ``camera_lidar`` actor reads ``camera``, ``lidar`` and ``motion``:
  DeepRacer's head-to-head sensor set (front camera and lidar) plus the car's odometry;
- ``expert`` (with ``expert``): the action a scripted driver would take in the learner's place,
  (B, 2) float32 in [-1, 1], computed from the same state as the other groups. It is the label
  of imitation learning (``h2h_racing.training.teachers.ScriptedTeacher``): the learner drives, the
  expert says what it would have done there (DAgger). No actor reads it.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import torch
from tensordict import TensorDict

from h2h_racing.sensors.state import MOTION_FEATURES, state_observation
from h2h_racing.track.lookup import wrap_arcs

ACTOR_GROUPS: dict[str, tuple[str, ...]] = {
    "state": ("policy",), "camera": ("policy", "camera"), "camera_only": ("camera", "motion"),
    "camera_lidar": ("camera", "lidar", "motion")}
"""Observation groups the actor of each ``observations`` mode reads: the state vector; the
camera and the state vector; the camera and the car's own motion; the camera, the lidar and
the car's own motion. The VecEnv builds the groups of its mode (and always ``policy`` and
``critic``)."""
OBSERVATIONS = tuple(ACTOR_GROUPS)
"""What the actor can be given (the keys of ``ACTOR_GROUPS``)."""


class VecEnvObservations:
    """The observation groups of ``RacingVecEnv`` (a mixin; it reads ``core``, ``learners``,
    ``observation_kind``, the sensors and the experts)."""

    def _observe(self) -> TensorDict:
        core, learners = self.core, self.learners
        e = core.num_envs
        state = state_observation(core)
        policy = state[:, :learners].reshape(e * learners, -1)
        groups = {"policy": self._tensor(policy, torch.float32),
                  "critic": self._tensor(np.concatenate(
                      [policy, self._privileged().reshape(e * learners, -1)], axis=1),
                      torch.float32)}
        if self._camera is not None:
            frames = self._camera.observe(core)[:, :learners]
            frames = frames.reshape(e * learners, *frames.shape[2:]).transpose(0, 3, 1, 2)
            groups["camera"] = self._tensor(frames, torch.float32).div_(255.0)
        if self._lidar is not None:
            ranges = self._lidar.observe(core, self._lidar_rng)[:, :learners]
            groups["lidar"] = self._tensor(ranges.reshape(e * learners, -1), torch.float32)
        if "motion" in ACTOR_GROUPS[self.observation_kind]:
            groups["motion"] = self._tensor(policy[:, list(MOTION_FEATURES)], torch.float32)
        if self._experts is not None:
            # One batched call per learner car (over every copy), as the opponents are driven.
            labels = np.stack([self._experts.act(car) for car in range(learners)], axis=1)
            groups["expert"] = self._tensor(np.clip(labels, -1.0, 1.0).reshape(e * learners, 2),
                                            torch.float32)
        return TensorDict(groups, batch_size=[e * learners], device=self.device)

    def _privileged(self) -> npt.NDArray[np.float32]:
        """Every other car's gap, offset, speed and heading error, (E, L, 4 (N - 1))."""
        core, learners = self.core, self.learners
        e, n = core.num_envs, core.num_cars
        length = core.lengths[:, None, None]
        gap = wrap_arcs(core.s[:, None, :] - core.s[:, :learners, None], length)
        heading = np.empty_like(core.s)
        for rows, view in core.track_views():
            heading[rows] = view.track.heading_at(core.s[rows])
        error = core.yaw - heading
        error = np.arctan2(np.sin(error), np.cos(error))
        per_car = np.stack([np.clip(gap / 5.0, -5, 5),
                            np.broadcast_to(core.d[:, None, :], gap.shape),
                            np.broadcast_to(core.speed[:, None, :] / 4.0, gap.shape),
                            np.broadcast_to(error[:, None, :], gap.shape)], axis=-1)
        others = ~np.eye(learners, n, dtype=bool)
        return per_car[:, others].reshape(e, learners, -1) if n > 1 else np.zeros((e, learners, 0))
