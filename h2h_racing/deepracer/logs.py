"""DeepRacer simtrace CSV and metrics JSON, written from the core's arrays.

The community's log analysis (deepracer-utils, deepracer-analysis notebooks, Deep Racer Guru)
reads DeepRacer's per-step *simtrace* and per-episode *metrics* files. ``SimtraceWriter`` writes
both, in the folder layout of DeepRacer-for-Cloud (DRfC), one folder per car::

    ROOT/<agent>/model/model_metadata.json
    ROOT/<agent>/training-simtrace/<i>-iteration.csv          training, one env copy logged
    ROOT/<agent>/<w>/training-simtrace/<i>-iteration.csv      training, env copies w = 0..9
    ROOT/<agent>/metrics/TrainingMetrics.json                 (+ TrainingMetrics_<w>.json)
    ROOT/<agent>/evaluation-<YYYYmmddHHMMSS>/evaluation-simtrace/0-iteration.csv   races
    ROOT/<agent>/metrics/EvaluationMetrics-<YYYYmmddHHMMSS>.json

so that ``deepracer.logs.DeepRacerLog("ROOT/car_0")`` loads it unchanged. Each logged env copy
is one DRfC rollout *worker*.

The files' columns, values and metrics entries are described in
``h2h_racing.deepracer.simtrace_files``.

Episodes: a training episode ends when the car's episode ends. In races (``rules="race"``),
as in DeepRacer's continuous evaluations, every lap is an episode (a *trial*): the row of a lap
completion has ``done`` True, and the next lap starts a new episode whose progress counts from
the line. Training simtraces are split into iterations of ``episodes_per_iteration`` episodes
per worker (DeepRacer's ``num_episodes_between_training``), which keeps deepracer-utils'
``unique_episode`` numbering right.

Evaluation episodes in the training metrics: between training iterations DeepRacer's first
rollout worker runs ``MIN_EVAL_TRIALS`` (5) evaluation episodes and appends them to its
``TrainingMetrics.json`` with ``phase: "evaluation"``, the same fields as a training episode,
and the ``episode`` and ``trial`` of the iteration's last training episode (simapp
``TrainingMetrics.append_episode_metrics`` counts neither), so deepracer-utils puts them in
that iteration. ``log_evaluation`` appends such rows (``evaluation_due`` says when: the first
logged copy has just finished an iteration); ``h2h_racing.training.simtrace_eval`` runs the
episodes. A writer with ``root=None`` writes no files and keeps its metrics entries in memory
(``first_episodes``): that is how those episodes are measured.
"""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import numpy.typing as npt

from h2h_racing.config.env import EnvConfig
from h2h_racing.deepracer.params import ParamsBuilder
from h2h_racing.deepracer.simtrace_files import (SIMTRACE_COLUMNS, STATUS_LABELS, Stream,
                                                 flush_rows, metadata_of, write_metrics)
from h2h_racing.track.shape import Track

if TYPE_CHECKING:
    from h2h_racing.sim.core import RaceCore, StepEvents

__all__ = ["MAX_WORKERS", "SIMTRACE_COLUMNS", "STATUS_LABELS", "SimtraceWriter"]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

MAX_WORKERS = 10
"""deepracer-utils reads a worker's folder name as one character, so at most 10 env copies
are logged as workers 0-9."""

class SimtraceWriter:
    """Write DeepRacer simtrace CSV and metrics JSON for some cars of some env copies.

    Call ``start(core)`` after the core's reset (it writes the ``prepare`` rows),
    ``log_step(core, events, ...)`` after every ``core.step`` (before the copies whose
    episode ended are reset), ``start(core, envs=mask)`` after ``core.reset_envs(mask)``,
    and ``close()`` at the end (it writes the metrics JSON and any unfinished episode).

    Args:
        root: Folder for the logs (created); one sub-folder per logged car. None writes no
            files: the metrics entries stay in memory (``first_episodes``).
        config: The env's configuration (car geometry, action space, sensors, rules).
        track: The track the core races on.
        agents: Name of every car of a copy (folder names); defaults to ``car_<i>``.
        envs: Env copies to log, at most ``MAX_WORKERS`` (each one is a DRfC worker).
        cars: Cars to log in each copy; None logs every car.
        phase: ``"training"`` (iteration files, ``TrainingMetrics.json``) or
            ``"evaluation"`` (one evaluation folder; a single env copy).
        episodes_per_iteration: Training episodes per worker in each iteration file.
        model_metadata: A ``model_metadata.json`` (path or dict) to copy into each car's
            ``model/`` folder; None writes one describing ``config``'s action space.

    Raises:
        ValueError: Bad ``envs``, ``cars``, ``phase`` or ``episodes_per_iteration``.
    """

    def __init__(self, root: str | Path | None, config: EnvConfig, track: Track, *,
                 agents: Sequence[str] | None = None, envs: Sequence[int] = (0,),
                 cars: Sequence[int] | None = None,
                 phase: Literal["training", "evaluation"] = "training",
                 episodes_per_iteration: int = 20,
                 model_metadata: str | Path | dict[str, Any] | None = None) -> None:
        n = config.num_cars
        envs = [int(e) for e in envs]
        cars = list(range(n)) if cars is None else [int(c) for c in cars]
        if phase not in ("training", "evaluation"):
            raise ValueError(f"phase must be 'training' or 'evaluation', got {phase!r}")
        if not envs or len(set(envs)) != len(envs) or min(envs) < 0:
            raise ValueError(f"envs must list distinct env copy indices >= 0, got {envs}")
        limit = 1 if phase == "evaluation" else MAX_WORKERS
        if root is not None and len(envs) > limit:
            raise ValueError(f"{phase} logs take at most {limit} env copies (deepracer-utils "
                             f"reads workers 0-9 and one stream per evaluation), got "
                             f"{len(envs)}; log fewer copies")
        if not cars or len(set(cars)) != len(cars) or not all(0 <= c < n for c in cars):
            raise ValueError(f"cars must list distinct car indices in [0, {n - 1}], got {cars}")
        if not isinstance(episodes_per_iteration, int) or episodes_per_iteration < 1:
            raise ValueError(f"episodes_per_iteration must be an int >= 1, got "
                             f"{episodes_per_iteration!r}")
        agents = list(agents) if agents is not None else [f"car_{i}" for i in range(n)]
        if len(agents) != n:
            raise ValueError(f"agents must name all {n} cars, got {agents}")
        self.root = None if root is None else Path(root)
        self.config = config
        self.track = track
        self.envs = np.asarray(envs, dtype=np.int64)
        self.cars = np.asarray(cars, dtype=np.int64)
        self.phase = phase
        self.episodes_per_iteration = episodes_per_iteration
        self._geometry = ParamsBuilder(track, config.car, 1)
        self._wp_ndist = self._geometry.waypoint_ndist
        self._wp = np.asarray(self._geometry.waypoints)
        self._track_len = repr(self._geometry.track_length)
        self._crash_infraction = config.race_rules.crash_is_infraction
        stamp = datetime.now(timezone.utc).strftime("%Y%m%d%H%M%S")
        metadata = metadata_of(config, model_metadata) if root is not None else {}
        w, c = len(envs), len(cars)
        self._streams: list[list[Stream]] = []
        for wi in range(w):
            row = []
            for car in cars:
                if self.root is None:
                    row.append(Stream(csv_dir=None, metrics_path=None))
                    continue
                folder = self.root / agents[car]
                (folder / "model").mkdir(parents=True, exist_ok=True)
                (folder / "metrics").mkdir(parents=True, exist_ok=True)
                (folder / "model" / "model_metadata.json").write_text(
                    json.dumps(metadata, indent=2))
                if phase == "evaluation":
                    csv_dir = folder / f"evaluation-{stamp}" / "evaluation-simtrace"
                    metrics = folder / "metrics" / f"EvaluationMetrics-{stamp}.json"
                else:
                    csv_dir = (folder / "training-simtrace" if w == 1
                               else folder / str(wi) / "training-simtrace")
                    metrics = folder / "metrics" / (f"TrainingMetrics_{wi}.json" if wi
                                                    else "TrainingMetrics.json")
                csv_dir.mkdir(parents=True, exist_ok=True)
                row.append(Stream(csv_dir=csv_dir, metrics_path=metrics))
            self._streams.append(row)
        self.paths = ([] if self.root is None else
                      sorted({str(self.root / agents[car]) for car in cars}))
        """The per-car log folders (each one loads with ``deepracer.logs.DeepRacerLog``)."""
        # Per (logged copy, logged car) state of the open episode.
        self._active = np.zeros((w, c), dtype=bool)
        self._episode = np.full((w, c), -1, dtype=np.int64)
        self._steps = np.zeros((w, c), dtype=np.int64)
        self._start = np.zeros((w, c))
        self._prev_progress = np.zeros((w, c))
        self._reward = np.zeros((w, c))
        self._start_time = np.zeros((w, c))
        self._counts = np.zeros((5, w, c), dtype=np.int64)  # crash, immob., off, rev., reset
        self._crash_base = np.zeros((w, c), dtype=np.int64)
        self._clock = np.zeros(w)
        self._last_time = np.zeros(w)
        self._closed = False
        self._due = False

    # ------------------------------------------------------------------ public API
    def cut(self, envs: BoolArray | None = None) -> None:
        """End, cut short (``in_progress``), the episodes still open in the copies just reset
        (another car's episode ended the copy): every logged copy, or those where ``envs``
        (shape (E,)) is True. ``start`` does it first; call it alone to have those episodes'
        metrics before ``start`` (before a ``log_evaluation``)."""
        picked = self._picked(envs)
        cut = np.broadcast_to(picked[:, None], self._active.shape) & self._active
        if cut.any():
            self._finish(cut, np.full(cut.shape, "in_progress"))

    def start(self, core: RaceCore, envs: BoolArray | None = None) -> None:
        """Open an episode (and write its ``prepare`` row) for the logged cars of the copies
        just reset: every logged copy, or those where ``envs`` (shape (E,)) is True."""
        picked = self._picked(envs)
        if not picked.any():
            return
        mask = np.broadcast_to(picked[:, None], self._active.shape)
        # Episodes of cars that were still racing when their copy was reset end here.
        self.cut(envs)
        # The simulated clock runs on across episodes: the reset copy's time restarts at 0.
        self._clock[picked] += self._last_time[picked]
        self._last_time[picked] = 0.0
        sel = np.ix_(self.envs, self.cars)
        self._open(mask, core.start_distance[sel] / self.track.length % 1.0,
                   core.crashes[sel])
        # DRfC numbers the prepare row 1.0 (its first step, on which no action is taken).
        self._steps[mask] = 1
        position, yaw = core.position[sel], core.yaw[sel]
        zeros = np.zeros(self._active.shape)
        status = np.where(mask, "prepare", "")
        # The prepare row has taken no action yet: -1 for a discrete action space (keeping
        # the column numeric for deepracer-utils), [steer throttle] of the idle command else.
        none = (np.full(self._active.shape, -1) if self.config.action_type == "discrete"
                else None)
        self._rows(core, mask, position, yaw, zeros, zeros, status,
                   np.zeros(self._active.shape, dtype=bool), zeros, action=none,
                   steer=np.degrees(core.steer_command[sel]), speed=core.speed_command[sel])

    def log_step(self, core: RaceCore, events: StepEvents, racing: BoolArray,
                 reward: FloatArray | None = None, action: npt.ArrayLike | None = None,
                 steer_deg: FloatArray | None = None) -> None:
        """Write one row per logged car whose episode is open, after ``core.step``.

        Args:
            core: The core, after its step (and before resetting any copy).
            events: The step's events.
            racing: Which cars were racing when the step began, shape (E, N) (the core's
                ``racing`` before the step); the others were frozen (``pause`` rows).
            reward: Reward of every car this step, shape (E, N); None writes 0.
            action: Discrete action index of every car, shape (E, N); None writes the
                continuous ``[steer throttle]``.
            steer_deg: Commanded steering [deg], shape (E, N); None converts the core's.
        """
        if self._closed:
            raise RuntimeError("the SimtraceWriter is closed; make a new one")
        sel = np.ix_(self.envs, self.cars)
        mask = self._active.copy()
        if not mask.any():
            return
        self._last_time = core.time[self.envs].astype(np.float64)
        ended = events.terminated[sel] | events.truncated[sel]
        position = np.where(ended[..., None], core.final_position[sel], core.position[sel])
        yaw = np.where(ended, core.final_yaw[sel], core.yaw[sel])
        lap = events.lap_completed[sel]
        was_racing = np.asarray(racing, dtype=bool)[sel]
        crash = events.crashed[sel] & self._crash_infraction
        # DeepRacer's status of a step, first match wins.
        status = np.select(
            [lap, events.off_track[sel], crash, events.reversed[sel], events.immobilised[sel],
             events.truncated[sel], ~was_racing],
            ["lap_complete", "off_track", "crashed", "reversed", "immobilized", "time_up",
             "pause"], "in_progress")
        status = np.where(mask, status, "")
        frozen_left = np.maximum(core.frozen_until[sel] - core.time[self.envs][:, None], 0.0)
        pause = np.where(status == "pause", frozen_left, 0.0)
        rewards = np.zeros(mask.shape) if reward is None else \
            np.asarray(reward, dtype=np.float64)[sel] * mask
        self._reward += rewards
        self._steps += mask
        self._counts += mask * np.stack([
            crash, events.immobilised[sel], events.off_track[sel], events.reversed[sel],
            events.replaced[sel]])
        done = mask & (ended | lap)
        steer = (np.degrees(core.steer_command[sel]) if steer_deg is None
                 else np.asarray(steer_deg, dtype=np.float64)[sel])
        actions = None if action is None else np.asarray(action)[sel]
        self._rows(core, mask, position, yaw, rewards, pause, status, done,
                   core.crashes[sel] - self._crash_base, action=actions, steer=steer,
                   speed=core.speed_command[sel])
        if done.any():
            self._finish(done, status)
            # A lap completed while the car races on: the next lap is a new trial, its
            # progress counted from the line.
            again = done & ~ended
            if again.any():
                line = (core.lap_origin[sel] + core.laps[sel] * self.track.length)
                self._open(again, line / self.track.length % 1.0, core.crashes[sel])

    @property
    def evaluation_due(self) -> bool:
        """Whether the first logged copy has finished a training iteration (its
        ``episodes_per_iteration``-th episode) since the last ``log_evaluation``: DeepRacer
        would run its evaluation episodes now."""
        return self._due

    def log_evaluation(self, trials: Sequence[Sequence[dict[str, Any]]]) -> None:
        """Append DeepRacer's evaluation episodes to the first logged copy's training metrics.

        Call it after the ``log_step`` that finished the iteration (``evaluation_due``) and
        the ``cut`` of the copy's other cars' episodes, and before ``start`` opens the copy's
        next episode. Each trial becomes one row per logged
        car with ``phase: "evaluation"``, the ``episode`` and ``trial`` of that car's last
        training episode (as simapp writes them, so deepracer-utils counts the row in that
        iteration), and ``start_time`` / ``metric_time`` on the copy's simulated clock: the
        trials run one after the other from the end of the iteration, and the clock runs on
        by their length before the next training episode, as Gazebo's does.

        Args:
            trials: Per evaluation episode, per logged car (in ``cars`` order), its metrics
                entry as a ``root=None`` writer keeps them (``first_episodes``):
                ``reward_score``, ``completion_percentage``, ``episode_status`` and
                ``elapsed_time_in_milliseconds``.

        Raises:
            ValueError: Not a training writer, or a trial without one entry per logged car.
        """
        if self.phase != "training":
            raise ValueError("evaluation episodes go into training metrics; this writer logs "
                             "an evaluation")
        if any(len(trial) != len(self.cars) for trial in trials):
            raise ValueError(f"every trial needs one entry per logged car ({len(self.cars)})")
        # A copy's episode ends for all its cars at once: the trial lasts as long as its
        # longest entry.
        elapsed = [max(int(entry["elapsed_time_in_milliseconds"]) for entry in trial)
                   for trial in trials]
        begin = (self._clock[0] + self._last_time[0]) * 1000.0
        for ci, stream in enumerate(self._streams[0]):
            last = next((m for m in reversed(stream.metrics) if m["phase"] == "training"),
                        {"episode": 0, "trial": 0})
            start = begin
            for trial, length in zip(trials, elapsed):
                entry = trial[ci]
                stream.metrics.append({
                    "reward_score": int(entry["reward_score"]),
                    "metric_time": int(round(start + length)),
                    "start_time": int(round(start)),
                    "elapsed_time_in_milliseconds": length,
                    "episode": int(last["episode"]),
                    "trial": int(last["trial"]),
                    "phase": "evaluation",
                    "completion_percentage": int(entry["completion_percentage"]),
                    "episode_status": str(entry["episode_status"]),
                })
                start += length
            write_metrics(stream)
        self._clock[0] += sum(elapsed) / 1000.0
        self._due = False

    def first_episodes(self) -> list[list[dict[str, Any]]] | None:
        """The metrics entry of the first episode of every logged car of every logged copy
        (``[copy][car]``, in ``envs`` and ``cars`` order), or None while one is still open."""
        if any(not stream.metrics for row in self._streams for stream in row):
            return None
        return [[stream.metrics[0] for stream in row] for row in self._streams]

    def clear(self) -> None:
        """Forget every episode (open or finished) and restart the clock, to log afresh from
        the next ``start``; for a ``root=None`` writer that measures episodes."""
        for row in self._streams:
            for stream in row:
                stream.rows.clear()
                stream.metrics.clear()
                stream.trials = 0
                stream.iteration = 0
        self._active[:] = False
        self._episode[:] = -1
        self._clock[:] = 0.0
        self._last_time[:] = 0.0
        self._due = False

    def close(self) -> None:
        """Write the rows of unfinished episodes and every metrics JSON file."""
        if self._closed:
            return
        for wi, row in enumerate(self._streams):
            for ci, stream in enumerate(row):
                if stream.rows:
                    flush_rows(stream)
                write_metrics(stream)
        self._active[:] = False
        self._closed = True

    def __enter__(self) -> SimtraceWriter:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    # ------------------------------------------------------------------ internals
    def _picked(self, envs: BoolArray | None) -> BoolArray:
        """Which logged copies ``envs`` (shape (E,), None: all) names, (W,)."""
        if envs is None:
            return np.ones(len(self.envs), dtype=bool)
        return np.asarray(envs, dtype=bool)[self.envs]

    def _open(self, mask: BoolArray, start_ndist: FloatArray,
              crashes: npt.NDArray[Any]) -> None:
        self._active |= mask
        self._episode += mask
        self._start[mask] = start_ndist[mask]
        self._prev_progress[mask] = 0.0
        self._reward[mask] = 0.0
        self._counts[:, mask] = 0
        self._crash_base[mask] = crashes[mask]
        now = self._clock[:, None] + self._last_time[:, None]
        self._start_time[mask] = np.broadcast_to(now, mask.shape)[mask]

    def _rows(self, core: RaceCore, mask: BoolArray, position: FloatArray, yaw: FloatArray,
              reward: FloatArray, pause: FloatArray, status: npt.NDArray[Any],
              done: BoolArray, crash_count: npt.NDArray[Any], *,
              action: npt.NDArray[Any] | None, steer: FloatArray, speed: FloatArray) -> None:
        """Compute the per-row geometry for every logged car at once, then format rows."""
        model_point, arc, wheels_on = self._geometry.geometry(position.reshape(-1, 2),
                                                              yaw.reshape(-1))
        shape = mask.shape
        model_point = model_point.reshape(*shape, 2)
        nd = arc.reshape(shape) / self._geometry.track_length
        wheels_on = wheels_on.reshape(shape)
        # Progress (simapp rollout_agent_ctrl.py): 100 (nd - start), +100 when <= 0, the
        # +-50 wrap rule against the previous step, capped at 100.
        progress = 100.0 * (nd - self._start)
        progress = np.where(progress <= 0.0, progress + 100.0, progress)
        prev = self._prev_progress
        progress = np.where(prev > progress + 50.0, progress + 100.0, progress)
        progress = np.where(progress > prev + 50.0, progress - 100.0, progress)
        progress = np.minimum(progress, 100.0)
        self._prev_progress = np.where(mask, progress, prev)
        if self.root is None:
            return  # no files: the progress is all the metrics entries need
        # closest_waypoint: of the waypoints bracketing the model point by arc length, the
        # one nearer in Euclidean distance (ties go to the one behind).
        last = len(self._wp_ndist) - 1
        nxt = np.searchsorted(self._wp_ndist, nd, side="right")
        prv = np.where(nxt > 0, nxt - 1, last)
        nxt = np.where(nxt > last, 0, nxt)
        d_next = np.linalg.norm(model_point - self._wp[nxt], axis=-1)
        d_prev = np.linalg.norm(model_point - self._wp[prv], axis=-1)
        closest = np.where(d_next < d_prev, nxt, prv)
        heading = np.degrees(np.arctan2(np.sin(yaw), np.cos(yaw)))
        heading = np.where(heading <= -180.0, heading + 360.0, heading)
        tstamp = np.broadcast_to(self._clock[:, None] + core.time[self.envs][:, None], shape)
        wall = repr(time.time())
        track_len = self._track_len
        for wi, ci in np.argwhere(mask).tolist():
            st, sp = float(steer[wi, ci]), float(speed[wi, ci])
            act = (str(int(action[wi, ci])) if action is not None else f"[{st!r} {sp!r}]")
            values = (
                str(int(self._episode[wi, ci])), repr(float(self._steps[wi, ci])),
                repr(float(model_point[wi, ci, 0])), repr(float(model_point[wi, ci, 1])),
                repr(float(heading[wi, ci])), repr(st), repr(sp), act,
                repr(float(reward[wi, ci])), str(bool(done[wi, ci])),
                str(bool(wheels_on[wi, ci])), repr(float(progress[wi, ci])),
                str(int(closest[wi, ci])), track_len, repr(float(tstamp[wi, ci])),
                str(status[wi, ci]), repr(float(pause[wi, ci])),
                str(int(crash_count[wi, ci])), wall)
            self._streams[wi][ci].rows.append(",".join(values))

    def _finish(self, done: BoolArray, status: npt.NDArray[Any]) -> None:
        """Close the episodes that ended this step: their rows and metrics entries."""
        end_time = self._clock + self._last_time
        for wi, ci in np.argwhere(done).tolist():
            stream = self._streams[wi][ci]
            flush_rows(stream)
            start, end = float(self._start_time[wi, ci]), float(end_time[wi])
            label = STATUS_LABELS[str(status[wi, ci])]
            progress = float(self._prev_progress[wi, ci])
            stream.trials += 1
            if self.phase == "training":
                stream.metrics.append({
                    "reward_score": int(round(float(self._reward[wi, ci]))),
                    "metric_time": int(round(end * 1000.0)),
                    "start_time": int(round(start * 1000.0)),
                    "elapsed_time_in_milliseconds": int(round((end - start) * 1000.0)),
                    "episode": int(self._episode[wi, ci]) + 1,
                    "trial": stream.trials,
                    "phase": "training",
                    "completion_percentage": int(progress),
                    "episode_status": label,
                })
            else:
                crash, immobilised, off, rev, resets = self._counts[:, wi, ci].tolist()
                stream.metrics.append({
                    "completion_percentage": int(progress),
                    "metric_time": int(round(end * 1000.0)),
                    "start_time": int(round(start * 1000.0)),
                    "elapsed_time_in_milliseconds": int(round((end - start) * 1000.0)),
                    "episode_status": label,
                    "crash_count": crash, "immobilized_count": immobilised,
                    "off_track_count": off, "reversed_count": rev, "reset_count": resets,
                    "trial": stream.trials,
                })
            if self.phase == "training" and stream.trials == self.episodes_per_iteration:
                write_metrics(stream)
                stream.iteration += 1
                stream.trials = 0
                self._due = self._due or wi == 0
        self._active &= ~done
