"""DeepRacer's simtrace CSV and metrics JSON files: their columns and values, the
labels of an episode's status, one car's stream of rows and metrics entries and how it is
written, and the ``model_metadata.json`` stored beside them. ``h2h_racing.deepracer.logs``
(``SimtraceWriter``) fills them from the core's arrays.

Simtrace columns (simapp ``metrics/constants.py StepMetrics``, in this order): ``episode,
steps, X, Y, yaw, steer, throttle, action, reward, done, all_wheels_on_track, progress,
closest_waypoint, track_len, tstamp, episode_status, pause_duration, obstacle_crash_counter,
wall_clock``. Their values follow simapp's ``rollout_agent_ctrl.py``:

- ``X``/``Y`` is the model point 0.14 m ahead of the car, ``yaw`` its heading in degrees,
  ``progress`` and ``all_wheels_on_track`` as in the reward ``params``
  (``h2h_racing.deepracer.params``); ``closest_waypoint`` is the Euclidean-nearer of the two
  waypoints that bracket the model point along the centre line;
- ``steer`` [deg] and ``throttle`` [m/s] are the commanded action; ``action`` is the discrete
  action's index, or ``[steer throttle]`` for continuous actions;
- ``tstamp`` is simulated time [s] on a clock that runs on across the worker's episodes, as
  Gazebo's does; ``wall_clock`` is the host's Unix time [s];
- every episode starts with DeepRacer's ``prepare`` row: the car where it starts, before its
  first action, with reward 0 and ``steps`` 1.0; the row of the first action has ``steps`` 2.0,
  as in DeepRacer-for-Cloud's simtraces (deepracer-utils' sample logs). In races, where every
  lap is a trial, ``steps`` runs on across the trials of the stream, as in DRfC's continuous
  evaluations (the trial after a row with ``steps`` 222.0 starts at 223.0, with no new
  ``prepare`` row);
- ``steps`` and the reward function's ``params["steps"]``: DeepRacer counts its ``prepare``
  step, does not call the reward function on it and logs ``params["steps"]`` unchanged, so
  its reward first sees 2.0. This env calls the reward function on every action from the
  first one, which sees ``params["steps"]`` 1.0 (``h2h_racing.deepracer.params``; Capstone-style
  functions need it). A training row therefore has ``steps = params["steps"] + 1``; replaying
  a reward function over our simtrace (deepracer-utils' ``NewRewardUtils``) sees ``steps``
  one higher than our env gave it;
- ``episode_status`` is ``prepare``, ``in_progress``, ``lap_complete``, ``off_track``,
  ``crashed`` (an at-fault contact that counts as an infraction), ``reversed``,
  ``immobilized``, ``time_up`` or ``pause`` (frozen by a race penalty; ``pause_duration`` then
  holds the seconds of penalty left); ``done`` is True on the row that ends the episode;
- ``obstacle_crash_counter`` counts the car's at-fault contacts so far in the episode.

Metrics JSON (simapp ``metrics/s3_metrics.py``): ``{"metrics": [...], "best_model_metric":
"progress"}`` with, per training episode, ``reward_score`` (rounded total reward),
``metric_time``, ``start_time``, ``elapsed_time_in_milliseconds`` (simulated ms),
``episode`` (from 1), ``trial`` (episode within the iteration, from 1), ``phase``,
``completion_percentage`` (int progress) and ``episode_status`` as a label (``"Lap
complete"``, ``"Off track"``, ...); per evaluation trial ``completion_percentage``,
``metric_time``, ``start_time``, ``elapsed_time_in_milliseconds``, ``episode_status``,
``crash_count``, ``immobilized_count``, ``off_track_count``, ``reversed_count``,
``reset_count`` and ``trial``.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from h2h_racing.common.json_files import read_json_file
from h2h_racing.config.env import EnvConfig

SIMTRACE_COLUMNS: tuple[str, ...] = (
    "episode", "steps", "X", "Y", "yaw", "steer", "throttle", "action", "reward", "done",
    "all_wheels_on_track", "progress", "closest_waypoint", "track_len", "tstamp",
    "episode_status", "pause_duration", "obstacle_crash_counter", "wall_clock",
)
"""Simtrace CSV columns, in DeepRacer's order (simapp ``StepMetrics``)."""

STATUS_LABELS: dict[str, str] = {
    "lap_complete": "Lap complete", "crashed": "Crashed", "off_track": "Off track",
    "immobilized": "Immobilized", "in_progress": "In progress", "pause": "Pause",
    "reversed": "Reversed", "park": "Park", "time_up": "Time Up", "prepare": "Prepare",
}
"""``episode_status`` values and their metrics-JSON labels (simapp
``EPISODE_STATUS_LABEL_MAP``)."""

_SENSOR_NAMES = {"camera": "FRONT_FACING_CAMERA", "lidar": "LIDAR"}


@dataclass
class Stream:
    """One car of one logged env copy: its open episode and its finished ones."""

    csv_dir: Path | None
    metrics_path: Path | None
    rows: list[str] = field(default_factory=list)
    metrics: list[dict[str, Any]] = field(default_factory=list)
    iteration: int = 0
    trials: int = 0
    written: set[int] = field(default_factory=set)


def flush_rows(stream: Stream) -> None:
    """Append the stream's pending rows to its iteration's CSV (with the header first in a
    new file); a stream without a folder drops them."""
    if stream.csv_dir is None:
        stream.rows.clear()
        return
    path = stream.csv_dir / f"{stream.iteration}-iteration.csv"
    new = stream.iteration not in stream.written
    with path.open("w" if new else "a") as f:
        if new:
            f.write(",".join(SIMTRACE_COLUMNS) + "\n")
        f.write("\n".join(stream.rows) + "\n")
    stream.written.add(stream.iteration)
    stream.rows.clear()


def write_metrics(stream: Stream) -> None:
    """Write the stream's metrics JSON whole (nothing without a path)."""
    if stream.metrics_path is None:
        return
    body = {"metrics": stream.metrics, "best_model_metric": "progress"}
    stream.metrics_path.write_text(json.dumps(body))


def metadata_of(config: EnvConfig, source: str | Path | dict[str, Any] | None) -> dict[str, Any]:
    """The ``model_metadata.json`` to store with the logs."""
    if isinstance(source, dict):
        return source
    if source is not None:
        data = read_json_file(Path(source), "model metadata (pass a model_metadata.json file "
                                             "or None)")
        if not isinstance(data, dict):
            raise ValueError(f"{source}: model metadata must be a JSON object, got "
                             f"{type(data).__name__}")
        return data
    if config.action_type == "discrete":
        space: Any = [{"steering_angle": float(s), "speed": float(v), "index": i}
                      for i, (s, v) in enumerate(config.discrete_actions)]
    else:
        low, high = config.steer_range
        space = {"steering_angle": {"low": math.degrees(low), "high": math.degrees(high)},
                 "speed": {"low": config.min_speed, "high": config.max_speed}}
    return {"action_space": space, "action_space_type": config.action_type,
            "sensor": [_SENSOR_NAMES.get(s, s) for s in config.sensors],
            "neural_network": "h2h_racing", "training_algorithm": "clipped_ppo",
            "version": "5"}
