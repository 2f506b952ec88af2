"""Run a race between drivers in the PettingZoo env and report the results.

This is what ``h2h-racing race`` runs: one car per driver, the race type's rules, until every
car has finished or the time limit ends the race.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from h2h_racing.config.env import RaceRules
from h2h_racing.deepracer.metadata import nearest_discrete
from h2h_racing.envs.parallel import RacingEnv
from h2h_racing.common.progress import WIDTH, Progress
from h2h_racing.envs.results import format_results

VIDEO_CODECS: dict[str, tuple[tuple[str, str], ...]] = {
    ".mp4": (("avc1", "H.264"), ("mp4v", "MPEG-4 Part 2")),
    ".webm": (("VP80", "VP8"),),
}
"""``race --video`` codecs by file suffix, (OpenCV fourcc, name) tried in order. H.264 plays
everywhere, but OpenCV's pip wheels have no H.264 encoder: their MP4 is then MPEG-4 Part 2,
which browsers do not play. WebM's VP8 plays in browsers and pip's OpenCV writes it (VP9 too,
but 3-10x slower: 30-140 ms a frame on the development machine)."""
FALLBACK_CODEC = "MPEG-4 Part 2"


@dataclass(frozen=True)
class RaceResult:
    """The outcome of one race."""

    track: str
    """Track name."""
    drivers: tuple[str, ...]
    """Driver name of car i, in car order."""
    rows: list[dict[str, Any]]
    """One dict per car in race order (see ``h2h_racing.envs.results.race_results``)."""
    steps: int
    """Env steps the race took."""
    rewards: tuple[float, ...] | None = None
    """With ``reward_function``: each car's total DeepRacer reward over the race, car order."""
    simtrace: tuple[str, ...] = ()
    """With ``simtrace``: the per-car DeepRacer log folders written."""
    bots: int = 0
    """Scripted bot cars in the race (not in ``rows``)."""
    bot_speed: float = 0.0
    """Their speed [m/s]."""
    bot_pauses: int = 0
    """How often a bot ran into a car ahead, pausing every bot."""
    video: str | None = None
    """With ``video``: the file written."""
    video_codec: str = ""
    """Its codec (a name in ``VIDEO_CODECS``)."""
    viewer: Any = field(default=None, repr=False, compare=False)
    """With ``serve=True``: the ``h2h_racing.viz.recorder.RaceRecorder`` still serving the web
    viewer (``viewer.viewer_url``); ``viewer.serve_until(seconds)`` keeps it up, then closes
    it."""

    @property
    def table(self) -> str:
        """The results as a text table with a title line."""
        names = {f"car_{i}": name for i, name in enumerate(self.drivers)}
        return f"{self.track}: {' vs '.join(self.drivers)}\n" + format_results(self.rows, names)

    @property
    def winner(self) -> str:
        """Driver name of the winner."""
        return self.drivers[int(self.rows[0]["agent"].split("_")[1])]


def run_race(track: str, drivers: Sequence[str | Any], race_type: str = "head_to_head",
             laps: int | None = None, seed: int = 0, grid: list[int] | None = None,
             video: str | Path | None = None, save: str | Path | None = None,
             spawn: bool = False, serve: bool = False, web_port: int = 9090,
             grpc_port: int = 9876, progress: bool = False,
             simtrace: str | Path | None = None,
             reward_function: str | Path | None = None,
             reward_time_limit: float | None = None, **config: Any) -> RaceResult:
    """Race ``drivers`` (one car each) on ``track`` and return the result.

    Args:
        track: Catalogue name or track file.
        drivers: Driver names (see ``h2h_racing.policies.DRIVERS``) or driver objects (with
            ``reset(core)``, ``act(core, car)`` and a ``name``); car i gets driver i.
        race_type: ``"head_to_head"``, ``"time_trial"``, ``"object_avoidance"`` or
            ``"head_to_bot"`` (3 scripted bot cars by default; ``num_bots=N``,
            ``bot_speed=...`` and the other ``EnvConfig`` bot fields go in ``config``).
        laps: Lap target; None keeps the race type's preset.
        seed: Seed of the race (grid draw and obstacle randomisation).
        grid: Grid slot of each car; None draws it from the seed.
        video: Write a top-down video of the race to this path (``.mp4`` or ``.webm``, see
            ``VIDEO_CODECS``).
        save: Write a rerun recording (``.rrd``) of the race to this path.
        spawn: Stream the race to the native rerun viewer (needs a display).
        serve: Serve the race in the rerun web viewer on 127.0.0.1; the result's
            ``viewer`` keeps serving until ``viewer.serve_until(...)`` returns.
        web_port: HTTP port of the web viewer with ``serve``.
        grpc_port: gRPC port of the rerun server with ``serve``.
        progress: Show a progress bar on stderr once the race has run for a second.
        simtrace: Write DeepRacer simtrace CSV and metrics JSON here, one folder per car
            (``h2h_racing.deepracer.logs``; every lap is an evaluation trial).
        reward_function: A DeepRacer reward file, called for every car on every step (loaded
            once per car); the result's ``rewards`` holds each car's total, and the simtrace
            its per-step values.
        reward_time_limit: Longest one call of ``reward_function`` may run [s]; None: no limit.
        **config: Further ``EnvConfig`` fields.

    Raises:
        ValueError: For an unknown driver, track or race type, or no drivers.
        ImportError: ``save``, ``spawn`` or ``serve`` without rerun-sdk installed.
    """
    from h2h_racing.policies import make_driver

    if not drivers:
        raise ValueError("give at least one driver, e.g. drivers=['racing_line', 'pure_pursuit']")
    policies = [make_driver(d, seed=seed + car) if isinstance(d, str) else d
                for car, d in enumerate(drivers)]
    labels = [d if isinstance(d, str) else getattr(d, "name", type(d).__name__)
              for d in drivers]
    rules = RaceRules.preset(race_type)
    if laps is not None:
        rules = dataclasses.replace(rules, laps=laps)
    env = RacingEnv(track=track, num_cars=len(drivers), race_type=race_type, rules=rules,
                    render_mode="rgb_array" if video else None,
                    reward_function=reward_function, reward_time_limit=reward_time_limit,
                    **config)
    logger = None
    if simtrace is not None:
        from h2h_racing.deepracer.logs import SimtraceWriter

        logger = SimtraceWriter(simtrace, env.config, env.track, agents=env.possible_agents,
                                phase="evaluation")
    totals = np.zeros(len(drivers))
    discrete = env.config.action_type == "discrete"
    options = {"grid": grid} if grid is not None else None
    recorder = None
    if save is not None or spawn or serve:
        from h2h_racing.viz.recorder import RaceRecorder

        recorder = RaceRecorder(env, path=save, spawn=spawn, serve=serve, web_port=web_port,
                                grpc_port=grpc_port)
    names = {f"car_{i}": name for i, name in enumerate(labels)}
    bar = ProgressBar(env) if progress else None
    writer = None
    codec = ""
    steps = 0
    try:
        obs, infos = env.reset(seed=seed, options=options)
        if recorder is not None:
            recorder.log_reset(obs, infos)
        for policy in policies:
            policy.reset(env.core)
        if logger is not None:
            logger.start(env.core)
        if video:
            writer, codec = _video_writer(video, env)
        while env.agents:
            actions = {agent: policies[i].act(env.core, i)[0]
                       for i, agent in enumerate(env.possible_agents) if agent in env.agents}
            index = None
            if discrete:
                # Drivers output [-1, 1]^2; a discrete action space takes the nearest action.
                index = np.zeros((1, len(drivers)), dtype=np.int64)
                for agent, value in actions.items():
                    index[0, env.possible_agents.index(agent)] = nearest_discrete(env.config,
                                                                                  value)
                actions = {a: int(index[0, env.possible_agents.index(a)]) for a in actions}
            racing = env.core.racing
            out = env.step(actions)
            steps += 1
            step_rewards = np.array([[out[1].get(a, 0.0) for a in env.possible_agents]])
            totals += step_rewards[0]
            if logger is not None:
                logger.log_step(env.core, env.last_events, racing, reward=step_rewards,
                                action=index)
            if recorder is not None:
                recorder.log_step(actions, *out)
            if writer is not None:
                writer.write(_bgr(env.render()))
            if bar is not None:
                bar.update()
        rows = env.results()
        if recorder is not None:
            recorder.log_results(rows, names)
    except BaseException:
        if recorder is not None:
            recorder.close()
        raise
    finally:
        if logger is not None:
            logger.close()
        if writer is not None:
            writer.release()
        if bar is not None:
            bar.close()
    if recorder is not None and not serve:
        recorder.close()
    return RaceResult(track=env.track.name, drivers=tuple(labels), rows=rows, steps=steps,
                      rewards=tuple(totals.tolist()) if reward_function is not None else None,
                      simtrace=tuple(logger.paths) if logger is not None else (),
                      bots=env.core.num_bots, bot_speed=env.config.bot_speed,
                      bot_pauses=int(env.core.bot_pauses[0]),
                      video=str(video) if video else None, video_codec=codec,
                      viewer=recorder if serve else None)


class ProgressBar:
    """A race's progress line on stderr (``h2h_racing.common.progress``), shown once the race has
    run a while.

    The fraction done is the larger of the last running car's share of the lap target and
    the share of the time limit used.

    Args:
        env: The env whose race to follow.
        delay: Wall seconds before the bar first appears (short races show none).
        stream: Where to draw (stderr by default).
    """

    WIDTH = WIDTH
    """Characters of the bar itself."""

    def __init__(self, env: RacingEnv, delay: float = 1.0, stream: TextIO | None = None) -> None:
        self.env = env
        self.progress = Progress("race", stream=stream, delay=delay)

    def fraction(self) -> float:
        """Return the fraction of the race done, in [0, 1]."""
        core = self.env.core
        rules = core.rules
        done = 0.0
        if rules.time_limit and math.isfinite(rules.time_limit):
            done = float(core.time[0]) / rules.time_limit
        if rules.laps:
            # The race lasts until the last car still racing finishes.
            driven = (core.distance[0] - core.lap_origin[0]) / (core.track.length * rules.laps)
            driven[core.done[0]] = 1.0
            done = max(done, float(driven.min()))
        return min(max(done, 0.0), 1.0)

    def update(self, force: bool = False) -> None:
        """Redraw the bar (at most ten times a second, unless ``force``)."""
        core = self.env.core
        laps = int(core.laps[0].min())
        target = core.rules.laps
        lap = f" lap {min(laps + 1, target)}/{target}" if target else ""
        self.progress.update(self.fraction(), f"t={float(core.time[0]):6.1f} s{lap}",
                             force=force)

    def close(self) -> None:
        """Draw the race's final state and end the bar's line, if it was shown."""
        # The last throttled redraw can be a good part of a fast race before its end.
        self.update()
        self.progress.close()


def _bgr(frame: Any) -> Any:
    import cv2

    return cv2.cvtColor(frame, cv2.COLOR_RGB2BGR)


def _video_writer(path: str | Path, env: RacingEnv) -> tuple[Any, str]:
    """An open OpenCV writer with the first codec of ``VIDEO_CODECS`` it has, and its name."""
    import cv2
    import cv2.utils.logging as cv_log

    suffix = Path(path).suffix.lower()
    if suffix not in VIDEO_CODECS:
        raise ValueError(f"video {path}: the file name must end in one of "
                         f"{', '.join(VIDEO_CODECS)} (.webm plays in browsers), got {suffix!r}")
    frame = env.render()
    height, width = frame.shape[:2]
    # A codec OpenCV lacks fails with error lines from OpenCV and FFmpeg; the probe is expected
    # to fail, so keep them off the terminal (FFmpeg's level is read on its first use).
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")
    level = cv_log.getLogLevel()
    cv_log.setLogLevel(cv_log.LOG_LEVEL_SILENT)
    try:
        for fourcc, codec in VIDEO_CODECS[suffix]:
            writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc),
                                     env.metadata["render_fps"], (width, height))
            if writer.isOpened():
                break
            writer.release()
        else:
            raise ValueError(f"cannot write a video to {path}: OpenCV has none of the encoders "
                             f"{', '.join(name for _, name in VIDEO_CODECS[suffix])} here")
    finally:
        cv_log.setLogLevel(level)
    writer.write(_bgr(frame))
    return writer, codec
