"""Evaluate a driver on every route of a folder (or a list of tracks): one row per route and
a summary, for the question "will it lap the next track?".

Each route runs what ``evaluate`` runs on one track: one-lap attempts alone from start points
spread round the lap (``training.evaluate.evaluate``), beside a baseline driver on the same
starts (``racing_line`` by default) and the route's minimum-time reference lap
(``policies.racing_line.reference_lap_time``, an estimate); or races of a race type with
DeepRacer's boxes or bots (``training.evaluate.evaluate_races``). The routes race together
as the copies of one batched core (``training.evaluate_tracks``: up to 32 drivers on their
routes in a core), each with its own seeded drivers, its copies laid out as in a core of its
own: the figures of a route are, to the bit, those of ``evaluate`` on it alone, whatever the
other routes, the batches or the worker processes (``run_routes``). A file that cannot be
loaded or raced gives a ``RouteFailure`` (its name and why) and the other routes go on.

The tables and the summary are in ``evaluate_routes_report``.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import dataclasses
import math
import multiprocessing
import os
import sys
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Union

import numpy as np

from h2h_racing.training.evaluate import Evaluation, RaceEvaluation

if TYPE_CHECKING:
    from h2h_racing.track.shape import Track

TRACK_SUFFIXES = (".json", ".npy", ".csv")
"""Suffixes of the files a folder's routes are read from (``h2h_racing.track.io``)."""


@dataclass(frozen=True)
class RouteSource:
    """One route to evaluate."""

    route: str
    """Its label in the tables: a file's name without suffix, or a catalogue name."""
    source: str
    """What ``load_track`` reads: a file path or a catalogue name."""


@dataclass(frozen=True)
class RouteSources:
    """The routes ``--track`` names (``route_sources``)."""

    routes: tuple[RouteSource, ...]
    ignored: tuple[str, ...] = ()
    """Files of the folders given that are not track files (by suffix), left out."""
    folders: int = 0
    """Folders among the items given."""


def route_sources(items: Sequence[str]) -> RouteSources:
    """The routes that ``items`` name, in order: each item may be a comma-separated list of
    catalogue names, ``random:<seed>``, track files, folders (every ``.json``, ``.npy`` and
    ``.csv`` file in it, sorted by name; hidden files and sub-folders left out) or ``all``
    (the catalogue).

    A named file is kept whatever it holds (a broken one fails when it is evaluated, on its
    own row); a name that is neither a file, a folder nor a catalogue track is refused here,
    before anything runs.

    Raises:
        ValueError: For an unknown name, a folder without a track file, or no route at all.
    """
    from h2h_racing.track.io import RANDOM_PREFIX, catalogue

    names = catalogue()
    routes: list[RouteSource] = []
    ignored: list[str] = []
    folders = 0
    for item in (part.strip() for text in items for part in text.split(",")):
        if not item:
            continue
        path = Path(item)
        # Catalogue names first, as load_track reads them.
        if item == "all" and not path.exists():
            routes += [RouteSource(name, name) for name in names]
        elif item in names or item.startswith(RANDOM_PREFIX):
            routes.append(RouteSource(item, item))
        elif path.is_dir():
            folders += 1
            files = sorted(p for p in path.iterdir() if not p.name.startswith("."))
            tracks = [p for p in files if p.is_file() and p.suffix.lower() in TRACK_SUFFIXES]
            if not tracks:
                raise ValueError(f"--track {item!r}: the folder holds no track file (expected "
                                 f"files ending in {', '.join(TRACK_SUFFIXES)})")
            routes += [RouteSource(p.stem, str(p)) for p in tracks]
            ignored += [str(p) for p in files if p not in tracks]
        elif path.is_file():
            routes.append(RouteSource(path.stem, item))
        else:
            raise ValueError(f"--track {item!r} is neither a folder, a track file nor a "
                             f"catalogue track ({', '.join(names)}, 'all' or "
                             f"'{RANDOM_PREFIX}<seed>'); check the path")
    if not routes:
        raise ValueError(f"--track {' '.join(items)!r} names no route")
    return RouteSources(tuple(routes), tuple(ignored), folders)


@dataclass(frozen=True)
class RouteTask:
    """What one worker evaluates: a route and the run's settings (picklable)."""

    source: RouteSource
    policy: str
    """The driver spec (``make_driver``)."""
    race_type: str = "time_trial"
    """``time_trial`` (one-lap attempts) or one of ``evaluate.RACE_TYPE_CHOICES``."""
    episodes: int = 20
    """One-lap attempts (time trial)."""
    races: int = 20
    """Races (race types)."""
    laps: int = 3
    """Laps per race (race types)."""
    seed: int = 0
    baseline: str | None = "racing_line"
    """Driver evaluated on the same starts (time trial); None: none."""

    def __post_init__(self) -> None:
        from h2h_racing.training.evaluate import RACE_TYPE_CHOICES

        kinds = ("time_trial", *RACE_TYPE_CHOICES)
        if self.race_type not in kinds:
            raise ValueError(f"race_type must be one of {', '.join(kinds)}, got "
                             f"{self.race_type!r}")
        for name in ("episodes", "races", "laps"):
            value = getattr(self, name)
            if not (isinstance(value, int) and not isinstance(value, bool) and value >= 1):
                raise ValueError(f"{name} must be a whole number >= 1, got {value!r}")


@dataclass(frozen=True)
class RouteLaps:
    """A route's time-trial figures."""

    route: str
    source: str
    policy: Evaluation
    baseline: Evaluation | None
    """The baseline driver on the same starts (None without one)."""
    reference_lap: float
    """The route's minimum-time reference lap [s] (``reference_lap_time``; an estimate)."""
    length: float
    """Centre-line length [m]."""

    @property
    def vs_baseline(self) -> float:
        """How much slower the policy's mean lap is than the baseline's [%] (negative:
        faster); NaN unless both lapped."""
        if self.baseline is None:
            return float("nan")
        return slower(self.policy.mean_lap_time, self.baseline.mean_lap_time)

    @property
    def vs_reference(self) -> float:
        """How much slower the policy's mean lap is than the reference lap [%]; NaN unless it
        lapped."""
        return slower(self.policy.mean_lap_time, self.reference_lap)


def slower(lap: float, other: float) -> float:
    """How much slower ``lap`` is than ``other`` [%] (negative: faster); NaN unless both are
    finite.

    >>> slower(11.0, 10.0), slower(10.0, 10.0), slower(float("inf"), 10.0)
    (10.0, 0.0, nan)
    """
    if not (np.isfinite(lap) and np.isfinite(other) and other > 0):
        return float("nan")
    return 100.0 * (lap - other) / other


@dataclass(frozen=True)
class RouteRaces:
    """A route's race-type figures."""

    route: str
    source: str
    races: RaceEvaluation
    length: float
    """Centre-line length [m]."""


@dataclass(frozen=True)
class RouteFailure:
    """A route that could not be evaluated."""

    route: str
    source: str
    error: str
    """Why, as the loader or the core said it."""


RouteResult = Union[RouteLaps, RouteRaces, RouteFailure]


def evaluate_route(task: RouteTask) -> RouteResult:
    """Evaluate ``task``'s route (see the module docstring); a file that cannot be loaded or
    raced (``ValueError``, ``OSError``) gives a ``RouteFailure`` instead."""
    from h2h_racing.config.env import EnvConfig
    from h2h_racing.policies import make_driver, reference_lap_time
    from h2h_racing.track.io import load_track
    from h2h_racing.training.evaluate import evaluate, evaluate_races

    route, source = task.source.route, task.source.source
    try:
        track = load_track(source)
        if task.race_type != "time_trial":
            races = evaluate_races(make_driver(task.policy, seed=task.seed), track,
                                   task.race_type, races=task.races, laps=task.laps,
                                   seed=task.seed)
            return RouteRaces(route, source, races, float(track.length))
        policy = evaluate(make_driver(task.policy, seed=task.seed), track,
                          episodes=task.episodes, seed=task.seed)
        baseline = None
        if task.baseline == task.policy:
            baseline = policy
        elif task.baseline is not None:
            baseline = evaluate(make_driver(task.baseline, seed=task.seed), track,
                                episodes=task.episodes, seed=task.seed)
        config = EnvConfig()
        reference = reference_lap_time(track, config.car, config.max_speed)
        return RouteLaps(route, source, policy, baseline, float(reference), float(track.length))
    except (ValueError, OSError) as err:
        return RouteFailure(route, source, str(err) or type(err).__name__)


def evaluate_batch(tasks: Sequence[RouteTask],
                   done: Callable[[int, RouteResult], None] | None = None) -> list[RouteResult]:
    """Evaluate ``tasks`` (the same settings, different routes) as ``evaluate_route`` would,
    their drivers racing as the copies of batched cores (``training.evaluate_tracks``); return
    the results in ``tasks``' order.

    ``done`` gets each task's index and result as the route finishes. A file that cannot be
    loaded fails alone; a core that cannot be built or raced (a route the race type's boxes or
    bots do not fit on) sends the routes it had not finished to ``evaluate_route`` one by one,
    which tells which failed and why.
    """
    from h2h_racing.track.io import load_track
    from h2h_racing.training.evaluate_tracks import Run, race_runs

    results: list[RouteResult | None] = [None] * len(tasks)

    def record(index: int, result: RouteResult) -> None:
        results[index] = result
        if done is not None:
            done(index, result)

    loaded: dict[int, Track] = {}
    for index, task in enumerate(tasks):
        try:
            loaded[index] = load_track(task.source.source)
        except (ValueError, OSError) as err:
            record(index, RouteFailure(task.source.route, task.source.source,
                                       str(err) or type(err).__name__))
    first = tasks[0] if tasks else None
    order = list(loaded)
    try:
        if first is not None and first.race_type != "time_trial":
            def raced(k: int, figures: RaceEvaluation) -> None:
                index = order[k]
                task = tasks[index]
                record(index, RouteRaces(task.source.route, task.source.source, figures,
                                         float(loaded[index].length)))

            race_runs([Run(first.policy, loaded[i], first.seed) for i in order],
                      first.race_type, first.races, first.laps, raced)
        elif first is not None:
            _lap_batch(tasks, loaded, order, record)
    except (ValueError, OSError):
        for index in order:
            if results[index] is None:
                record(index, evaluate_route(tasks[index]))
    return [r for r in results if r is not None]


def _lap_batch(tasks: Sequence[RouteTask], loaded: dict[int, Track], order: list[int],
               record: Callable[[int, RouteResult], None]) -> None:
    """The time trials of ``evaluate_batch``: the policy's and the baseline's runs of every
    loaded route (``order``) in batched cores; a route's row as its last run is done."""
    from h2h_racing.config.env import EnvConfig
    from h2h_racing.policies import reference_lap_time
    from h2h_racing.training.evaluate_tracks import Run, lap_runs

    first = tasks[0]
    same = first.baseline == first.policy
    drivers = [first.policy] + ([first.baseline] if first.baseline and not same else [])
    runs = [Run(spec, loaded[index], first.seed) for index in order for spec in drivers]
    figures: dict[int, dict[str, Evaluation]] = {index: {} for index in order}
    config = EnvConfig()

    def run_done(k: int, evaluation: Evaluation) -> None:
        index = order[k // len(drivers)]
        figures[index][runs[k].driver] = evaluation
        if len(figures[index]) < len(drivers):
            return
        task, track = tasks[index], loaded[index]
        policy = figures[index][first.policy]
        baseline = policy if same else figures[index].get(first.baseline or "")
        try:
            reference = reference_lap_time(track, config.car, config.max_speed)
        except (ValueError, OSError) as err:
            record(index, RouteFailure(task.source.route, task.source.source,
                                       str(err) or type(err).__name__))
            return
        record(index, RouteLaps(task.source.route, task.source.source, policy, baseline,
                                float(reference), float(track.length)))

    lap_runs(runs, first.episodes, run_done)


def default_jobs(routes: int) -> int:
    """Worker processes by default: one per core this process may use, at most one per
    route."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return max(1, min(cores or 1, routes))


def _start_worker(parent: int, death_signal: bool) -> None:
    """A pool worker's first act: die with the parent, and keep torch to one thread (a
    route's network sees a batch of a few copies, which one thread serves best, and the
    thread count changes a network's last bits)."""
    from h2h_racing.common.lifeline import die_with_parent

    die_with_parent(parent, death_signal)
    # Read by torch's OpenMP pool when torch is first imported (by make_driver, later).
    os.environ["OMP_NUM_THREADS"] = "1"


@contextlib.contextmanager
def one_torch_thread() -> Iterator[None]:
    """Run torch on one thread inside, as the worker processes do, if it is imported (a
    trained driver's spec imports it when it is checked; scripted drivers do not use it)."""
    torch = sys.modules.get("torch")
    if torch is None:
        yield
        return
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(threads)


def _batch_jobs(tasks: Sequence[RouteTask], workers: int) -> list[list[int]]:
    """The tasks (their indices) of each ``evaluate_batch`` call: consecutive tasks of the same
    settings, in ``2 * workers`` parts of about equal size (so that workers share the routes
    and report as they go)."""
    groups: list[list[int]] = []
    for index, task in enumerate(tasks):
        if groups and dataclasses.replace(tasks[groups[-1][0]], source=task.source) == task:
            groups[-1].append(index)
        else:
            groups.append([index])
    if workers == 1:
        return groups
    size = max(1, math.ceil(len(tasks) / (2 * workers)))
    return [group[a:a + size] for group in groups for a in range(0, len(group), size)]


def _evaluate_indexed(tasks: Sequence[RouteTask]) -> list[RouteResult]:
    """``evaluate_batch`` in a worker (a module-level function: the pool pickles it)."""
    return evaluate_batch(tasks)


def run_routes(tasks: Sequence[RouteTask], jobs: int,
               done: Callable[[int, RouteResult], None] | None = None) -> list[RouteResult]:
    """Evaluate every task, ``jobs`` at a time; return the results in ``tasks``' order.

    Args:
        tasks: The routes and settings (``RouteTask``).
        jobs: Worker processes (started with ``spawn``: no inherited torch or OpenMP threads,
            which ``fork`` can deadlock on; they die with this process), each evaluating
            batches of routes in turn (``evaluate_batch``); 1 runs every task in this process.
            The figures are the same for any number.
        done: Called with each task's index and result as it finishes (in any order).

    Raises:
        ValueError: For ``jobs`` below 1.
    """
    if not (isinstance(jobs, int) and jobs >= 1):
        raise ValueError(f"jobs must be a whole number >= 1 (1: in this process), got {jobs!r}")
    results: list[RouteResult | None] = [None] * len(tasks)

    def record(index: int, result: RouteResult) -> None:
        results[index] = result
        if done is not None:
            done(index, result)

    if jobs == 1 or len(tasks) <= 1:
        with one_torch_thread():
            for batch in _batch_jobs(tasks, 1):
                evaluate_batch([tasks[i] for i in batch],
                               lambda k, result, batch=batch: record(batch[k], result))
        return [r for r in results if r is not None]
    from h2h_racing.common.lifeline import started_from_main_thread

    batches = _batch_jobs(tasks, jobs)
    workers = min(jobs, len(batches))
    pool = cf.ProcessPoolExecutor(
        workers, mp_context=multiprocessing.get_context("spawn"), initializer=_start_worker,
        initargs=(os.getpid(), started_from_main_thread()))
    try:
        futures = {pool.submit(_evaluate_indexed, [tasks[i] for i in batch]): batch
                   for batch in batches}
        pending = set(futures)
        while pending:
            # A timed wait: an untimed one can hold off Ctrl-C until a route finishes.
            finished, pending = cf.wait(pending, timeout=0.25, return_when=cf.FIRST_COMPLETED)
            for future in sorted(finished, key=lambda f: futures[f][0]):
                for index, result in zip(futures[future], future.result()):
                    record(index, result)
    except BaseException:
        # Ctrl-C or a route's crash: drop the queued routes, and stop the running ones rather
        # than wait minutes for them (the pool's exit handler joins its workers).
        # (shutdown forgets the worker processes, so they are taken first).
        workers_running = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        for process in workers_running:
            process.terminate()
        raise
    pool.shutdown(wait=True)
    return [r for r in results if r is not None]


def finite_or_none(value: float) -> float | None:
    """``value`` for JSON: None for inf and NaN (JSON has neither)."""
    return float(value) if np.isfinite(value) else None
