"""Run a race between drivers in the PettingZoo env and report the results.

This is what ``h2h-racing race`` runs: one car per driver, the race type's rules, until every
car has finished or the time limit ends the race.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from h2h_racing.config import RaceRules
from h2h_racing.env import RacingEnv
from h2h_racing.results import format_results


@dataclass(frozen=True)
class RaceResult:
    """The outcome of one race."""

    track: str
    """Track name."""
    drivers: tuple[str, ...]
    """Driver name of car i, in car order."""
    rows: list[dict[str, Any]]
    """One dict per car in race order (see ``h2h_racing.results.race_results``)."""
    steps: int
    """Env steps the race took."""

    @property
    def table(self) -> str:
        """The results as a text table with a title line."""
        names = {f"car_{i}": name for i, name in enumerate(self.drivers)}
        return f"{self.track}: {' vs '.join(self.drivers)}\n" + format_results(self.rows, names)

    @property
    def winner(self) -> str:
        """Driver name of the winner."""
        return self.drivers[int(self.rows[0]["agent"].split("_")[1])]


def run_race(track: str, drivers: list[str], race_type: str = "head_to_head",
             laps: int | None = None, seed: int = 0, grid: list[int] | None = None,
             video: str | Path | None = None, **config: Any) -> RaceResult:
    """Race ``drivers`` (one car each) on ``track`` and return the result.

    Args:
        track: Catalogue name or track file.
        drivers: Driver names (see ``h2h_racing.policies.DRIVERS``), car i gets driver i.
        race_type: ``"head_to_head"``, ``"time_trial"`` or ``"object_avoidance"``.
        laps: Lap target; None keeps the race type's preset.
        seed: Seed of the race (grid draw and obstacle randomisation).
        grid: Grid slot of each car; None draws it from the seed.
        video: Write a top-down MP4 of the race to this path.
        **config: Further ``EnvConfig`` fields.

    Raises:
        ValueError: For an unknown driver, track or race type, or no drivers.
    """
    from h2h_racing.policies import make_driver

    if not drivers:
        raise ValueError("give at least one driver, e.g. drivers=['racing_line', 'pure_pursuit']")
    policies = [make_driver(name) for name in drivers]
    rules = RaceRules.preset(race_type)
    if laps is not None:
        rules = dataclasses.replace(rules, laps=laps)
    env = RacingEnv(track=track, num_cars=len(drivers), race_type=race_type, rules=rules,
                    render_mode="rgb_array" if video else None, **config)
    options = {"grid": grid} if grid is not None else None
    env.reset(seed=seed, options=options)
    for policy in policies:
        policy.reset(env.core)
    writer = _video_writer(video, env) if video else None
    steps = 0
    try:
        while env.agents:
            actions = {agent: policies[i].act(env.core, i)[0]
                       for i, agent in enumerate(env.possible_agents) if agent in env.agents}
            env.step(actions)
            steps += 1
            if writer is not None:
                writer.write(_bgr(env.render()))
    finally:
        if writer is not None:
            writer.release()
    return RaceResult(track=env.track.name, drivers=tuple(drivers), rows=env.results(),
                      steps=steps)


def _bgr(frame: Any) -> Any:
    import cv2

    return cv2.cvtColor(frame, cv2.COLOR_RGB2BGR)


def _video_writer(path: str | Path, env: RacingEnv) -> Any:
    import cv2

    frame = env.render()
    height, width = frame.shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"),
                             env.metadata["render_fps"], (width, height))
    if not writer.isOpened():
        raise ValueError(f"cannot write a video to {path}: OpenCV has no mp4v encoder here")
    writer.write(_bgr(frame))
    return writer
