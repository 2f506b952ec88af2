"""Evaluate a driver alone on a track: lap completion, lap times, off-tracks and collisions.

Each episode is one lap attempt under DeepRacer's training rules (an infraction ends the
attempt) from a different start point, spread evenly round the lap as DeepRacer's training
starts are; all episodes run at once as env copies of one batched core. The same start points
are used for every driver, so two drivers' figures compare like for like.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.sim.core import RaceCore
from h2h_racing.track.shape import Track
from h2h_racing.track.io import load_track


@dataclass(frozen=True)
class Evaluation:
    """Figures of one driver over ``episodes`` lap attempts."""

    driver: str
    track: str
    episodes: int
    lap_completion: float
    """Fraction of attempts that completed the lap."""
    mean_lap_time: float
    """Mean lap time of the completed attempts [s] (inf if none)."""
    best_lap_time: float
    """Best lap time [s] (inf if none)."""
    off_tracks: int
    """Attempts that ended off track."""
    collisions: int
    """Contacts (with obstacles, when there are any)."""

    def row(self, width: int = 28) -> str:
        """One line of the evaluation table (``width``: of the driver column)."""
        mean = f"{self.mean_lap_time:.2f}" if np.isfinite(self.mean_lap_time) else "-"
        best = f"{self.best_lap_time:.2f}" if np.isfinite(self.best_lap_time) else "-"
        return (f"{self.driver:<{width}} {100 * self.lap_completion:>6.1f} % {mean:>8} {best:>8} "
                f"{self.off_tracks:>5} {self.collisions:>5}")

    @staticmethod
    def header(width: int = 28) -> str:
        """Header line of the evaluation table (``width``: of the driver column)."""
        return (f"{'driver':<{width}} {'laps':>8} {'mean s':>8} {'best s':>8} {'off':>5} "
                f"{'coll':>5}")


def evaluate(driver: Any, track: str | Track, episodes: int = 20, seed: int = 0,
             **config: Any) -> Evaluation:
    """Run ``episodes`` one-lap attempts of ``driver`` alone on ``track``.

    Args:
        driver: A driver name or ``policy.pt`` path (``make_driver``), or a driver object.
        track: Catalogue name, track file, ``random:<seed>``, or a ``Track``.
        episodes: Lap attempts, started at ``k * L / episodes`` for k = 0 .. episodes - 1.
        seed: Seed of the core (obstacle randomisation).
        **config: Further ``EnvConfig`` fields (e.g. ``num_obstacles``).
    """
    from h2h_racing.policies import make_driver

    if isinstance(driver, str):
        driver = make_driver(driver, seed=seed)
    loaded = track if isinstance(track, Track) else load_track(track)
    env_config = lap_config(loaded.name if isinstance(track, Track) else track, **config)
    core = RaceCore(env_config, loaded, num_envs=episodes)
    core.reset(seed=seed, start=lap_starts(loaded, episodes))
    driver.reset(core)
    while not core.done.all():
        core.step(*env_config.commands(np.asarray(driver.act(core, 0))[:, None, :]))
    return lap_figures(driver, core)


def lap_config(track: str, **config: Any) -> EnvConfig:
    """``evaluate``'s config: one car, time-trial training rules (an infraction ends the
    attempt), ``config``'s further fields."""
    rules = RaceRules.preset("time_trial", "training")
    return EnvConfig(track=track, num_cars=1, race_type="time_trial", rules=rules, **config)


def lap_starts(track: Track, episodes: int) -> np.ndarray:
    """``evaluate``'s start points: ``k * L / episodes`` for k = 0 .. episodes - 1 [m]."""
    return np.arange(episodes) * (track.length / episodes)


def lap_figures(driver: Any, core: Any) -> Evaluation:
    """``driver``'s figures over the one-lap attempts of ``core`` (a core of one track, or
    one track's view of a core), once every attempt is done."""
    episodes = core.num_envs
    laps = [t for env in range(episodes) for t in core.lap_times[env][0][:1]]
    return Evaluation(
        driver=getattr(driver, "name", type(driver).__name__), track=core.track.name,
        episodes=episodes, lap_completion=float(core.finished[:, 0].mean()),
        mean_lap_time=float(np.mean(laps)) if laps else float("inf"),
        best_lap_time=float(np.min(laps)) if laps else float("inf"),
        off_tracks=int(core.off_tracks[:, 0].sum()), collisions=int(core.collisions[:, 0].sum()))


RACE_TYPE_CHOICES = ("object_avoidance", "head_to_bot")
"""Race types ``evaluate_races`` runs: one car alone with DeepRacer's boxes, or with its bots."""


@dataclass(frozen=True)
class RaceEvaluation:
    """Figures of one driver over ``races`` races of a race type, alone with its boxes or bots.

    The per-lap figures divide by the laps completed over every race (NaN when none was)."""

    driver: str
    track: str
    race_type: str
    races: int
    laps: int
    """Lap target of each race."""
    finished: int
    """Races that reached the lap target within the time limit."""
    laps_done: int
    """Laps completed, over all races."""
    crashes: int
    """Crashes into a box or a bot (each costs a penalty and a reset), over all races."""
    resets: int
    """Times the car was put back on the track (after a crash or leaving it), over all races."""
    off_tracks: int
    """Times the car left the track, over all races."""
    mean_race_time: float
    """Mean finish time of the finished races [s] (inf if none)."""

    def per_lap(self, count: int) -> float:
        """``count`` per lap completed (NaN without a lap)."""
        return count / self.laps_done if self.laps_done else float("nan")

    @property
    def crashes_per_lap(self) -> float:
        """Crashes per lap completed (NaN without a lap)."""
        return self.per_lap(self.crashes)

    @property
    def resets_per_lap(self) -> float:
        """Resets per lap completed (NaN without a lap)."""
        return self.per_lap(self.resets)


def evaluate_races(driver: Any, track: str | Track, race_type: str, races: int = 20,
                   laps: int = 3, seed: int = 0) -> RaceEvaluation:
    """Run ``races`` races of ``race_type`` for ``driver`` alone (with the race type's boxes
    or bots), all at once as env copies of one batched core.

    Every race starts on the start line, as DeepRacer's do; the races differ by their boxes
    (``object_avoidance``: DeepRacer's 6, re-drawn per race: ``randomize_obstacles``) or by
    their bots' lane changes (``head_to_bot``: 3 bots at 0.75 m/s), drawn from ``seed``. Race
    rules of the race type (``RaceRules.preset``: a 5 s penalty per infraction, a crash is
    also a reset) with ``laps`` laps and a minute a lap (the preset's 180 s for 3).

    Args:
        driver: A driver spec (``make_driver``) or a driver object.
        track: Catalogue name, track file or ``Track``.
        race_type: One of ``RACE_TYPE_CHOICES``.
        races: Races (env copies).
        laps: Lap target of each race.
        seed: Seed of the core and of a driver built from a spec.

    Raises:
        ValueError: For another race type, fewer than one race or lap, or a track the race
            type's boxes or bots do not fit on.
    """
    from h2h_racing.policies import make_driver

    if race_type not in RACE_TYPE_CHOICES:
        raise ValueError(f"race_type must be one of {', '.join(RACE_TYPE_CHOICES)}, got "
                         f"{race_type!r} (time trials: evaluate)")
    if not (isinstance(races, int) and races >= 1 and isinstance(laps, int) and laps >= 1):
        raise ValueError(f"races and laps must be whole numbers >= 1, got {races!r} and "
                         f"{laps!r}")
    if isinstance(driver, str):
        driver = make_driver(driver, seed=seed)
    loaded = track if isinstance(track, Track) else load_track(track)
    env_config = race_config(loaded.name if isinstance(track, Track) else track, race_type,
                             laps)
    core = RaceCore(env_config, loaded, num_envs=races)
    core.reset(seed=seed)
    driver.reset(core)
    while not core.done.all():
        core.step(*env_config.commands(np.asarray(driver.act(core, 0))[:, None, :]))
    return race_figures(driver, core)


def race_config(track: str, race_type: str, laps: int) -> EnvConfig:
    """``evaluate_races``' config: one car, the race type's rules with ``laps`` laps and a
    minute a lap, boxes re-drawn every race in ``object_avoidance``."""
    import dataclasses

    # The preset's 180 s is DeepRacer's limit for its 3 laps: a minute a lap.
    rules = dataclasses.replace(RaceRules.preset(race_type), laps=laps, time_limit=60.0 * laps)
    # DeepRacer re-draws the boxes of every object-avoidance episode; run_race's default
    # keeps them fixed, which would make every race the same one.
    extra = {"randomize_obstacles": True} if race_type == "object_avoidance" else {}
    return EnvConfig(track=track, num_cars=1, race_type=race_type, rules=rules, **extra)


def race_figures(driver: Any, core: Any) -> RaceEvaluation:
    """``driver``'s figures over the races of ``core`` (a core of one track, or one track's
    view of a core), once every race is done."""
    finished = core.finished[:, 0]
    times = core.finish_time[finished, 0]
    rules = core.rules
    return RaceEvaluation(
        driver=getattr(driver, "name", type(driver).__name__), track=core.track.name,
        race_type=core.config.race_type, races=core.num_envs, laps=rules.laps,
        finished=int(finished.sum()),
        laps_done=int(np.minimum(core.laps[:, 0], rules.laps).sum()),
        crashes=int(core.crashes[:, 0].sum()), resets=int(core.resets[:, 0].sum()),
        off_tracks=int(core.off_tracks[:, 0].sum()),
        mean_race_time=float(times.mean()) if times.size else float("inf"))


TIME_TRIAL_EPISODES = 4
"""One-lap attempts behind ``time_trial_lap``'s mean (from start points spread round the lap)."""


def time_trial_lap(driver: Any, track: str | Track, seed: int = 0,
                   episodes: int = TIME_TRIAL_EPISODES) -> float:
    """Return ``driver``'s time-trial lap alone on ``track`` [s]: the mean of the completed laps
    of ``evaluate``'s ``episodes`` one-lap attempts (one batched core; training rules, an
    infraction ends the attempt), inf when it completed none.

    Args:
        driver: A driver spec (``make_driver``; a fresh driver is built) or a driver object.
        track: Catalogue name, track file or ``Track``.
        seed: Seed of the core.
        episodes: Lap attempts.
    """
    return evaluate(driver, track, episodes=episodes, seed=seed).mean_lap_time


def pace_margin(lap: float, other: float) -> float:
    """How much faster ``lap`` is than ``other`` [%] (negative: slower); NaN unless both are
    finite.

    >>> round(pace_margin(6.0, 8.0), 1), round(pace_margin(8.0, 6.0), 1)
    (25.0, -33.3)
    """
    if not (np.isfinite(lap) and np.isfinite(other) and other > 0):
        return float("nan")
    return 100.0 * (other - lap) / other


def lap_text(lap: float) -> str:
    """A time-trial lap as the tables show it: ``6.14``, ``DNF`` (inf) or ``-`` (NaN)."""
    return f"{lap:.2f}" if np.isfinite(lap) else ("DNF" if lap == np.inf else "-")


def margin_text(margin: float) -> str:
    """A pace margin as the tables show it: ``+25.0`` or ``-``."""
    return f"{margin:+.1f}" if np.isfinite(margin) else "-"


START_CHOICES = ("both", "behind", "front")
"""Grid slot of the evaluated driver (driver A) in ``head_to_head``: ``both`` alternates the
two slots on the same start points, ``behind`` always starts it in the slot behind (the
from-behind protocol: every win is a pass), ``front`` always in front (every win is a hold)."""


@dataclass(frozen=True)
class HeadToHead:
    """Outcome of ``races`` 2-car races between two drivers (A, B).

    Tuples hold A's figure, then B's. The grid figures are A's: the slot behind starts
    ``gap`` metres of track behind the front slot, so a race won from behind needed a pass.
    """

    drivers: tuple[str, str]
    track: str
    races: int
    wins: tuple[int, int]
    """Races won by each driver (first across the line after the lap target)."""
    overtakes: tuple[int, int]
    """On-track passes made by each driver, over all races."""
    crashes: tuple[int, int]
    """Contacts each driver was judged to have caused (it was behind)."""
    finished: tuple[int, int]
    """Races each driver finished."""
    races_behind: int = 0
    """Races A started from the slot behind."""
    wins_behind: int = 0
    """Of those, races A won (it passed B and stayed ahead)."""
    races_front: int = 0
    """Races A started from the front slot."""
    wins_front: int = 0
    """Of those, races A won (it kept B behind, or re-passed it)."""
    defences: tuple[int, int] = (0, 0)
    """Defences by each driver, over all races: the other car pressured it (less than
    ``RaceRules.defence_gap`` = 1 m of track behind for at least ``defence_time`` = 2 s, and
    faster at some moment) and dropped back without passing (``h2h_racing.sim.race``)."""
    start: str = "both"
    """A's grid slot (``START_CHOICES``)."""
    gap: float = 0.75
    """Distance between the grid slots [m of track]."""
    rolling: float = 0.0
    """Start speed of both cars [m/s]: 0 for a standing start, else a rolling start."""
    time_trial_laps: tuple[float, float] = (float("nan"), float("nan"))
    """Each driver's time-trial lap alone on the track [s] (``time_trial_lap``; summed over
    tracks by ``combine``): inf when it completed none, NaN when not measured."""

    @property
    def pace_margin(self) -> float:
        """How much faster A's time-trial lap is than B's [%] (negative: slower; NaN unless
        both laps are known): the pace A races with, beside its results."""
        return pace_margin(*self.time_trial_laps)

    def per_race(self, counts: tuple[int, int]) -> float:
        """A's share of ``counts`` (e.g. ``overtakes``) per race."""
        return counts[0] / self.races

    def summary(self) -> str:
        """A short text report."""
        a, b = self.drivers
        grid = {"both": f"{self.races_behind} from behind, {self.races_front} from the front",
                "behind": "all from behind", "front": "all from the front"}[self.start]
        launch = (f"rolling start at {self.rolling:g} m/s" if self.rolling
                  else "standing start")
        return (f"{self.track}, {self.races} races ({grid}, grid gap {self.gap:g} m, {launch}): "
                f"{a} won {self.wins[0]}, {b} won {self.wins[1]}; {a} won "
                f"{self.wins_behind}/{self.races_behind} from behind and "
                f"{self.wins_front}/{self.races_front} from the front; overtakes "
                f"{self.overtakes[0]} / {self.overtakes[1]}; crashes caused {self.crashes[0]} / "
                f"{self.crashes[1]}; defences {self.defences[0]} / {self.defences[1]}; "
                f"finished {self.finished[0]} / {self.finished[1]}")


def grid_slots(races: int, start: str) -> np.ndarray:
    """Grid slot of each car (A, B) in each race, shape (races, 2); slot 1 is behind.

    Raises:
        ValueError: For an unknown ``start``, or ``both`` with an odd or too small ``races``.
    """
    if start not in START_CHOICES:
        raise ValueError(f"start must be one of {', '.join(START_CHOICES)}, got {start!r}")
    if start == "both" and (races < 2 or races % 2):
        raise ValueError(f"races must be an even number >= 2 with start='both' (both seat "
                         f"orders on every start point), got {races}")
    if races < 1:
        raise ValueError(f"races must be at least 1, got {races}")
    behind = {"both": np.arange(races) % 2, "behind": np.ones(races, dtype=np.int64),
              "front": np.zeros(races, dtype=np.int64)}[start]
    return np.stack([behind, 1 - behind], axis=1)


def head_to_head(driver_a: Any, driver_b: Any, track: str, races: int = 20, laps: int = 3,
                 seed: int = 0, start: str = "both", gap: float | None = None,
                 rolling: float = 0.0,
                 progress: Callable[[float, int], None] | None = None) -> HeadToHead:
    """Race two drivers against each other ``races`` times, all at once as env copies.

    With ``start="both"``, race pair k (copies 2k and 2k + 1) starts at a random point of the
    lap drawn from ``seed``, with driver A on grid slot 0 in one copy and slot 1 in the other
    (every start in both seat orders); with ``"behind"`` (``"front"``) every race starts at
    its own random point with A in the slot behind (in front). ``head_to_head`` race rules
    (time penalties, not retirement) and ``laps`` laps counted from the front slot.

    Args:
        gap: Distance of the slot behind [m of track]; None keeps the grid's 0.75 m
            (DeepRacer's). At most a quarter of the lap.
        rolling: Start speed of both cars [m/s]: 0 a standing start; above 0 a rolling start,
            both cars already moving along the track at that speed, ``gap`` apart
            (``RaceCore.reset(rolling=...)``; at most the car's ``max_speed``).
        progress: Called after every step with the share of the races done (the mean over
            races of the larger of the last running car's share of the laps and the share of
            the time limit used) and the number of races finished.
    """
    from h2h_racing.policies import make_driver

    slots = grid_slots(races, start)
    loaded = load_track(track)
    spacing = EnvConfig.grid_spacing if gap is None else gap
    if not (isinstance(spacing, (int, float)) and 0.0 < spacing <= loaded.length / 4):
        raise ValueError(f"gap must be a distance in (0, {loaded.length / 4:.1f}] m (a quarter "
                         f"of {loaded.name}'s lap), got {gap!r}")
    drivers = [make_driver(d, seed=seed + car) if isinstance(d, str) else d
               for car, d in enumerate((driver_a, driver_b))]
    rng = np.random.default_rng(seed)
    starts = (np.repeat(rng.uniform(0.0, loaded.length, races // 2), 2) if start == "both"
              else rng.uniform(0.0, loaded.length, races))
    core = race_batch(track, loaded, drivers, laps, spacing, slots, starts, seed, rolling, progress)
    winner = (core.rank == 1) & core.finished
    behind = slots[:, 0] == 1
    names = tuple(getattr(d, "name", type(d).__name__) for d in drivers)

    def pair(values: np.ndarray) -> tuple[int, int]:
        return int(values[:, 0].sum()), int(values[:, 1].sum())

    return HeadToHead(
        drivers=(names[0], names[1]), track=loaded.name, races=races,
        wins=pair(winner), overtakes=pair(core.overtakes), crashes=pair(core.crashes),
        finished=pair(core.finished), races_behind=int(behind.sum()),
        wins_behind=int(winner[behind, 0].sum()), races_front=int((~behind).sum()),
        wins_front=int(winner[~behind, 0].sum()), defences=pair(core.defences), start=start,
        gap=float(spacing), rolling=float(rolling))


def race_batch(track: str, loaded: Track, drivers: list[Any], laps: int, spacing: float,
               slots: np.ndarray, starts: np.ndarray, seed: int, rolling: float,
               progress: Callable[[float, int], None] | None) -> RaceCore:
    """Race ``drivers`` (car i is ``drivers[i]``) head to head on ``loaded`` (``track``'s
    geometry) in one batched
    core, one race per row of ``slots`` (each car's grid slot) and entry of ``starts`` (start
    line [m]), under race rules with a time limit of a minute per lap; returns the core when
    every race is done. ``head_to_head`` and ``evaluate_field.field_race`` share it."""
    rules = RaceRules(laps=laps, time_limit=60.0 * laps)
    env_config = EnvConfig(track=track, num_cars=len(drivers), race_type="head_to_head",
                           rules=rules, grid_spacing=float(spacing))
    core = RaceCore(env_config, loaded, num_envs=len(starts))
    core.reset(seed=seed, slots=slots, start=starts, rolling=rolling)
    for driver in drivers:
        driver.reset(core)
    while not core.done.all():
        core.step(*env_config.commands(np.stack([d.act(core, car)
                                                 for car, d in enumerate(drivers)], axis=1)))
        if progress is not None:
            progress(_share_done(core, laps), int(core.done.all(axis=1).sum()))
    return core


def _share_done(core: RaceCore, laps: int) -> float:
    """The share of ``core``'s races done (see ``head_to_head``'s ``progress``)."""
    driven = (core.distance - core.lap_origin) / (core.track.length * laps)
    driven[core.done] = 1.0
    share = np.maximum(driven.min(axis=1), core.time / core.rules.time_limit)
    share[core.done.all(axis=1)] = 1.0
    return float(np.clip(share, 0.0, 1.0).mean())


def combine(results: list[HeadToHead], track: str = "all") -> HeadToHead:
    """Sum the races of ``results`` (same two drivers; e.g. one per track) into one record."""
    if not results:
        raise ValueError("combine needs at least one HeadToHead result")

    def total(name: str) -> Any:
        values = [getattr(r, name) for r in results]
        if isinstance(values[0], tuple):
            return tuple(int(sum(v[i] for v in values)) for i in range(2))
        return int(sum(values))

    starts = {r.start for r in results}
    gaps = {r.gap for r in results}
    speeds = {r.rolling for r in results}
    return HeadToHead(
        drivers=results[0].drivers, track=track, races=total("races"), wins=total("wins"),
        overtakes=total("overtakes"), crashes=total("crashes"), finished=total("finished"),
        races_behind=total("races_behind"), wins_behind=total("wins_behind"),
        races_front=total("races_front"), wins_front=total("wins_front"),
        defences=total("defences"), start=starts.pop() if len(starts) == 1 else "both",
        gap=gaps.pop() if len(gaps) == 1 else float("nan"),
        rolling=speeds.pop() if len(speeds) == 1 else float("nan"),
        time_trial_laps=(float(sum(r.time_trial_laps[0] for r in results)),
                         float(sum(r.time_trial_laps[1] for r in results))))


def head_to_head_header(width: int = 16) -> str:
    """Header of ``head_to_head_row``'s table (``width``: of the opponent column)."""
    return (f"{'track':<16} {'opponent':<{width}} {'won':>11} {'from behind':>11} "
            f"{'from front':>11} {'lap s':>15} {'margin %':>8} {'passes/race':>12} "
            f"{'crashes/race':>12} {'defences/race':>13} {'finished':>11}")


def head_to_head_row(result: HeadToHead, opponent: str, width: int = 16) -> str:
    """One row of the evaluation table of ``evaluate --against``: A's wins overall, from
    behind and from the front, the time-trial laps (A's / B's) and A's pace margin, then
    passes, crashes caused and defences per race and finishes as A's / B's (``width``: of
    the opponent column)."""
    def ratio(won: int, of: int) -> str:
        return f"{won} / {of}" if of else "-"

    def per_race(counts: tuple[int, int]) -> str:
        return f"{counts[0] / result.races:.2f} / {counts[1] / result.races:.2f}"

    return (f"{result.track:<16} {opponent:<{width}} {ratio(result.wins[0], result.races):>11} "
            f"{ratio(result.wins_behind, result.races_behind):>11} "
            f"{ratio(result.wins_front, result.races_front):>11} "
            f"{' / '.join(map(lap_text, result.time_trial_laps)):>15} "
            f"{margin_text(result.pace_margin):>8} {per_race(result.overtakes):>12} "
            f"{per_race(result.crashes):>12} "
            f"{per_race(result.defences):>13} "
            f"{ratio(*result.finished):>11}")
