"""Several tracks in one batch: ``TrackGroups``, K ``RacingVecEnv`` groups of env copies, each
racing its own track, as one rsl-rl ``VecEnv`` (``[procedural] tracks``).

A ``RaceCore`` holds one track, so with a single group every rollout of a procedural run comes
from one track, and every gradient step of an iteration pulls the policy towards that track:
camera students' laps on the held-out tracks swung from checkpoint to checkpoint (issue 21,
``experiments/camera``). With K groups each rollout, and each mini-batch drawn from it, mixes K
tracks. Rows are the groups' rows in group order (group 0's first). One Python call per group
per step: K is a handful, and each group's step is batched over its copies.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from h2h_racing.track import Track
from h2h_racing.training.vec_env import RacingVecEnv, TensorDict, VecEnv, torch


class TrackGroups(VecEnv):
    """``groups`` of env copies as one ``VecEnv``; ``set_tracks`` gives each its own track.

    Args:
        groups: The groups, each a ``RacingVecEnv`` of the same config and observations (their
            own copies, seeds and tracks).

    Raises:
        ValueError: For no group, or groups whose observations, actions or devices differ.
    """

    def __init__(self, groups: Sequence[RacingVecEnv]) -> None:
        if not groups:
            raise ValueError("TrackGroups needs at least one RacingVecEnv group, got none")
        first = groups[0]
        for k, group in enumerate(groups):
            mine = (group.observation_kind, group.num_actions, str(group.device))
            theirs = (first.observation_kind, first.num_actions, str(first.device))
            if mine != theirs:
                raise ValueError(f"TrackGroups: group {k} has (observations, actions, device) "
                                 f"{mine}, group 0 {theirs}; build every group from one config")
        self.groups = list(groups)
        self.num_envs = sum(group.num_envs for group in groups)
        self.num_actions = first.num_actions
        self.max_episode_length = max(group.max_episode_length for group in groups)
        self.device = first.device
        self._sizes = [group.num_envs for group in groups]
        self._gather()

    @property
    def cfg(self) -> dict[str, Any]:  # type: ignore[override]
        """Group 0's env config as a dict (every group's but its race type, which takes turns
        with ``race_types``)."""
        return self.groups[0].cfg

    @property
    def tracks(self) -> list[Track]:
        """Each group's current track, in group order."""
        return [group.track for group in self.groups]

    def get_observations(self) -> TensorDict:
        """Return the current observation groups, every group's rows in group order."""
        return self._obs

    def step(self, actions: torch.Tensor) -> tuple[TensorDict, torch.Tensor, torch.Tensor,
                                                   dict[str, Any]]:
        """Step every group with its rows of ``actions`` (``RacingVecEnv.step``).

        ``extras["log"]`` holds, for each statistic, the mean over the groups whose episodes
        ended this step and that report it (a group's own figure is already its mean over its
        ended copies).
        """
        if actions.shape[0] != self.num_envs:
            raise ValueError(f"actions must have {self.num_envs} rows (one per learner car of "
                             f"every group), got shape {tuple(actions.shape)}")
        results = [group.step(rows)
                   for group, rows in zip(self.groups, torch.split(actions, self._sizes))]
        self._gather()
        logs = [result[3]["log"] for result in results if result[3]["log"]]
        keys = dict.fromkeys(key for log in logs for key in log)
        log = {key: float(np.mean([entry[key] for entry in logs if key in entry]))
               for key in keys}
        extras = {"time_outs": torch.cat([result[3]["time_outs"] for result in results]),
                  "log": log}
        return (self._obs, torch.cat([result[1] for result in results]),
                torch.cat([result[2] for result in results]), extras)

    def set_tracks(self, tracks: Sequence[Track]) -> None:
        """Race ``tracks[k]`` in group ``k`` from now on (``RacingVecEnv.set_track``).

        Raises:
            ValueError: Unless there is one track per group.
        """
        if len(tracks) != len(self.groups):
            raise ValueError(f"set_tracks needs one track per group ({len(self.groups)}), got "
                             f"{len(tracks)}")
        for group, track in zip(self.groups, tracks):
            group.set_track(track)
        self._gather()

    def close(self) -> None:
        """Close every group."""
        for group in self.groups:
            group.close()

    def _gather(self) -> None:
        """The groups' current observations and episode lengths, in group order."""
        self._obs = torch.cat([group.get_observations() for group in self.groups])
        self.episode_length_buf = torch.cat([group.episode_length_buf for group in self.groups])
