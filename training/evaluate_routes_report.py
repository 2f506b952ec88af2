"""The tables, summary and JSON of ``evaluate`` over many routes (``evaluate_routes``), and the
command that prints them as the routes finish.

A time trial's summary: the routes the policy laps at least ``LAP_TARGET`` of the attempts
on (N of M), the worst routes, and its mean lap against the baseline driver's on the same
starts and against the route's minimum-time reference lap. A race type's: the routes where it
meets ``RACE_TARGETS`` (issue 36's obstacle_generalist targets), on each target, over all
routes, and the worst routes. Files that could not be evaluated get one line each and are
counted.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from h2h_racing.common.progress import Mode, Progress
from h2h_racing.training.evaluate_routes import (RouteFailure, RouteLaps, RouteRaces,
                                                 RouteResult, RouteTask,
                                                 finite_or_none, run_routes)

LAP_TARGET = 0.95
"""Share of the one-lap attempts a route counts as lapped at (issue 36: >= 95 %)."""
RACE_TARGETS = {"finished": 0.9, "crashes_per_lap": 0.5, "resets_per_lap": 1.0}
"""A race type's targets on a route (issue 36's obstacle_generalist targets): at least 90 %
of the races finished, at most 0.5 crashes and 1 reset per lap completed."""
WORST = 3
"""Routes the summary names at least as the worst (all that miss the target, if more)."""


def _num(value: float, digits: int = 2, sign: bool = False) -> str:
    """``value`` as a table cell: ``-`` for NaN, ``DNF`` for inf."""
    if np.isnan(value):
        return "-"
    if np.isinf(value):
        return "DNF"
    return f"{value:+.{digits}f}" if sign else f"{value:.{digits}f}"


def _file(result: RouteResult) -> str:
    return Path(result.source).name


# ------------------------------------------------------------------ time trial


def laps_header(width: int, baseline: str | None) -> str:
    """Header of ``laps_row``'s table (``width``: of the route column)."""
    base = (f" {baseline + ' s':>{max(8, len(baseline) + 2)}} "
            f"{'vs ' + baseline + ' %':>{max(8, len(baseline) + 5)}}") if baseline else ""
    return (f"{'route':<{width}} {'lap m':>6} {'laps':>7} {'mean s':>7} {'best s':>7} "
            f"{'off':>4}{base} {'ref s':>6} {'vs ref %':>8}")


def laps_row(result: RouteLaps, width: int, baseline: str | None) -> str:
    """One route's time-trial row: lap length, the share of attempts lapped, the policy's
    mean and best lap and off-tracks, the baseline's mean lap and how much slower the
    policy's is, the reference lap and how much slower the policy's is."""
    p = result.policy
    base = ""
    if baseline:
        mean = result.baseline.mean_lap_time if result.baseline else float("nan")
        base = (f" {_num(mean):>{max(8, len(baseline) + 2)}} "
                f"{_num(result.vs_baseline, 1, True):>{max(8, len(baseline) + 5)}}")
    return (f"{result.route:<{width}} {result.length:>6.1f} {100 * p.lap_completion:>5.1f} % "
            f"{_num(p.mean_lap_time):>7} {_num(p.best_lap_time):>7} {p.off_tracks:>4}{base} "
            f"{_num(result.reference_lap):>6} {_num(result.vs_reference, 1, True):>8}")


def _spread(values: list[tuple[float, str]]) -> str:
    """``+1.2 % on average (-3.0 % on A to +8.1 % on B)`` over (value, route) pairs."""
    low, high = min(values), max(values)
    mean = float(np.mean([v for v, _ in values]))
    return (f"{mean:+.1f} % on average ({low[0]:+.1f} % on {low[1]} to {high[0]:+.1f} % on "
            f"{high[1]})")


def laps_summary(results: Sequence[RouteLaps], failures: Sequence[RouteFailure],
                 baseline: str | None) -> tuple[list[str], dict[str, Any]]:
    """The summary lines of a time trial over routes, and its figures for ``--json``."""
    at_target = [r for r in results if r.policy.lap_completion >= LAP_TARGET - 1e-12]
    # Fewest laps first, then the slowest against the baseline, then against the reference.
    order = sorted(results, key=lambda r: (r.policy.lap_completion,
                                           -np.nan_to_num(r.vs_baseline, nan=-np.inf),
                                           -np.nan_to_num(r.vs_reference, nan=-np.inf)))
    worst = order[:max(WORST, len(results) - len(at_target))]
    lines = [f"summary: {len(at_target)} of {len(results)} routes at >= "
             f"{100 * LAP_TARGET:.0f} % laps" + _failures_text(failures)]

    def worst_text(r: RouteLaps) -> str:
        pace = (f" ({r.vs_baseline:+.1f} % vs {baseline})" if np.isfinite(r.vs_baseline)
                else "")
        return f"{r.route} {100 * r.policy.lap_completion:.0f} %{pace}"

    if worst:
        lines.append("worst routes: " + "; ".join(map(worst_text, worst)))
    figures: dict[str, Any] = {
        "routes": len(results), "files_not_evaluated": len(failures),
        "lap_target": LAP_TARGET, "routes_at_target": len(at_target),
        "routes_below_target": [r.route for r in results if r not in at_target],
        "worst_routes": [r.route for r in worst]}
    paces = [(r.vs_baseline, r.route) for r in results if np.isfinite(r.vs_baseline)]
    if baseline:
        lines.append(f"mean lap vs {baseline}'s: " + (
            _spread(paces) + f" over the {len(paces)} routes both lapped" if paces
            else "no route that both lapped"))
        figures["mean_vs_baseline_pct"] = (float(np.mean([v for v, _ in paces])) if paces
                                           else None)
    refs = [(r.vs_reference, r.route) for r in results if np.isfinite(r.vs_reference)]
    lines.append("mean lap vs the reference lap: " + (
        _spread(refs) + f" over the {len(refs)} routes it lapped" if refs
        else "no route lapped"))
    figures["mean_vs_reference_pct"] = float(np.mean([v for v, _ in refs])) if refs else None
    return lines, figures


def laps_json(result: RouteLaps) -> dict[str, Any]:
    """A route's time-trial figures for ``--json`` (None for a lap time without a lap)."""
    p, b = result.policy, result.baseline
    return {"route": result.route, "file": result.source, "length_m": result.length,
            "episodes": p.episodes, "laps": p.lap_completion,
            "at_target": bool(p.lap_completion >= LAP_TARGET - 1e-12),
            "mean_lap_s": finite_or_none(p.mean_lap_time),
            "best_lap_s": finite_or_none(p.best_lap_time), "off_tracks": p.off_tracks,
            "collisions": p.collisions,
            "baseline_laps": None if b is None else b.lap_completion,
            "baseline_mean_lap_s": None if b is None else finite_or_none(b.mean_lap_time),
            "vs_baseline_pct": finite_or_none(result.vs_baseline),
            "reference_lap_s": finite_or_none(result.reference_lap),
            "vs_reference_pct": finite_or_none(result.vs_reference)}


# ------------------------------------------------------------------ race types


def missed_targets(result: RouteRaces) -> list[str]:
    """The ``RACE_TARGETS`` a route misses (a per-lap figure without a lap misses)."""
    r = result.races
    missed = []
    if r.finished < RACE_TARGETS["finished"] * r.races - 1e-9:
        missed.append("finished")
    for key, value in (("crashes_per_lap", r.crashes_per_lap),
                       ("resets_per_lap", r.resets_per_lap)):
        if not value <= RACE_TARGETS[key]:
            missed.append(key.split("_")[0])
    return missed


def races_header(width: int) -> str:
    """Header of ``races_row``'s table (``width``: of the route column)."""
    return (f"{'route':<{width}} {'lap m':>6} {'finished':>9} {'laps':>5} {'crashes/lap':>11} "
            f"{'resets/lap':>10} {'off':>4} {'mean race s':>11}  targets")


def races_row(result: RouteRaces, width: int) -> str:
    """One route's race row: races finished, laps completed, crashes and resets per lap,
    off-tracks, mean finish time, and the targets it meets (``ok``) or misses."""
    r = result.races
    missed = missed_targets(result)
    return (f"{result.route:<{width}} {result.length:>6.1f} {f'{r.finished}/{r.races}':>9} "
            f"{r.laps_done:>5} {_num(r.crashes_per_lap):>11} {_num(r.resets_per_lap):>10} "
            f"{r.off_tracks:>4} {_num(r.mean_race_time, 1):>11}  "
            f"{'ok' if not missed else 'missed ' + ', '.join(missed)}")


def races_summary(results: Sequence[RouteRaces],
                  failures: Sequence[RouteFailure]) -> tuple[list[str], dict[str, Any]]:
    """The summary lines of a race type over routes, and its figures for ``--json``."""
    met = [r for r in results if not missed_targets(r)]
    on = {key: sum(key.split("_")[0] not in missed_targets(r) for r in results)
          for key in RACE_TARGETS}
    t = RACE_TARGETS
    lines = [f"summary: {len(met)} of {len(results)} routes meet the targets (>= "
             f"{100 * t['finished']:.0f} % of races finished, <= {t['crashes_per_lap']:g} "
             f"crashes and <= {t['resets_per_lap']:g} reset per lap)" + _failures_text(failures),
             f"by target: >= {100 * t['finished']:.0f} % finished on {on['finished']}, <= "
             f"{t['crashes_per_lap']:g} crashes per lap on {on['crashes_per_lap']}, <= "
             f"{t['resets_per_lap']:g} reset per lap on {on['resets_per_lap']} of "
             f"{len(results)} routes"]
    races = sum(r.races.races for r in results)
    finished = sum(r.races.finished for r in results)
    laps = sum(r.races.laps_done for r in results)
    crashes = sum(r.races.crashes for r in results)
    resets = sum(r.races.resets for r in results)
    if results:
        lines.append(f"all routes: {finished} of {races} races finished, {laps} laps, "
                     f"{_num(crashes / laps if laps else np.nan)} crashes and "
                     f"{_num(resets / laps if laps else np.nan)} resets per lap")

    def badness(r: RouteRaces) -> tuple[float, ...]:
        share = r.races.finished / r.races.races
        return (not missed_targets(r), share, -np.nan_to_num(r.races.crashes_per_lap, nan=np.inf),
                -np.nan_to_num(r.races.resets_per_lap, nan=np.inf))

    worst = sorted(results, key=badness)[:max(WORST, len(results) - len(met))]
    if worst:
        lines.append("worst routes: " + "; ".join(
            f"{r.route} ({r.races.finished}/{r.races.races} finished, "
            f"{_num(r.races.crashes_per_lap)} crashes and {_num(r.races.resets_per_lap)} "
            f"resets per lap)" for r in worst))
    figures = {"routes": len(results), "files_not_evaluated": len(failures),
               "targets": dict(RACE_TARGETS), "routes_meeting_targets": len(met),
               "routes_by_target": on, "routes_missing_targets": [
                   r.route for r in results if missed_targets(r)],
               "worst_routes": [r.route for r in worst], "races": races, "finished": finished,
               "laps": laps, "crashes": crashes, "resets": resets}
    return lines, figures


def races_json(result: RouteRaces) -> dict[str, Any]:
    """A route's race figures for ``--json``."""
    r = result.races
    return {"route": result.route, "file": result.source, "length_m": result.length,
            "races": r.races, "laps_target": r.laps, "finished": r.finished,
            "laps": r.laps_done, "crashes": r.crashes, "resets": r.resets,
            "off_tracks": r.off_tracks, "crashes_per_lap": finite_or_none(r.crashes_per_lap),
            "resets_per_lap": finite_or_none(r.resets_per_lap),
            "mean_race_time_s": finite_or_none(r.mean_race_time),
            "missed_targets": missed_targets(result)}


# ------------------------------------------------------------------ the command


def _failures_text(failures: Sequence[RouteFailure]) -> str:
    if not failures:
        return ""
    files = ", ".join(_file(f) for f in failures)
    return f"; {len(failures)} file{'s' * (len(failures) != 1)} not evaluated ({files})"


def failure_line(failure: RouteFailure) -> str:
    """A file that could not be evaluated, on one line: its name and why."""
    return f"{_file(failure)}: not evaluated: {' '.join(failure.error.split())}"


def check_json_path(path: str | None) -> Path | None:
    """``--json``'s path, checked before anything runs (a run is not lost for a typo).

    Raises:
        ValueError: When the path is a folder or its folder does not exist.
    """
    if path is None:
        return None
    out = Path(path)
    if out.is_dir():
        raise ValueError(f"--json {path!r} is a folder; give a file path, e.g. "
                         f"{out / 'routes.json'}")
    if not out.parent.is_dir():
        raise ValueError(f"--json {path!r}: the folder {str(out.parent)!r} does not exist; "
                         "create it first")
    return out


def write_json(path: Path, data: dict[str, Any]) -> None:
    """Write ``data`` to ``path`` whole: a temporary file beside it, then renamed into place,
    so a reader never sees half a file."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(data, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    os.replace(tmp, path)


def evaluate_routes_command(items: Sequence[str], policy: str, *,
                            race_type: str = "time_trial", episodes: int = 20, races: int = 20,
                            laps: int = 3, seed: int = 0, baseline: str = "racing_line",
                            jobs: int | None = None, json_path: str | None = None,
                            progress: Mode = "auto") -> int:
    """``h2h-racing evaluate`` over several routes: evaluate ``policy`` on every route that
    ``items`` name (``route_sources``) and print the table (rows as the routes finish, in
    order), the files that could not be evaluated and the summary; write ``json_path`` if
    given. Returns 0, or 1 when a file could not be evaluated.

    Args:
        items: ``--track``'s values: names, files, folders, 'all', comma lists.
        policy: The driver spec.
        race_type: ``time_trial`` or one of ``evaluate.RACE_TYPE_CHOICES``.
        episodes: One-lap attempts per route (time trial).
        races: Races per route (race types).
        laps: Laps per race (race types).
        seed: Seed of every route's core and drivers.
        baseline: ``--baseline``: its first driver is compared with (time trial); '' none.
        jobs: Worker processes; None: ``default_jobs``.
        json_path: Where to write the figures (checked before anything runs).
        progress: The progress line's mode (``h2h_racing.common.progress``).

    Raises:
        ValueError: For a bad setting, policy, baseline, ``--json`` path or ``--track`` name,
            before anything runs.
    """
    import dataclasses

    from h2h_racing.policies import make_driver
    from h2h_racing.training.evaluate_routes import RouteSource, default_jobs, route_sources

    for flag, value in (("--episodes", episodes), ("--races", races), ("--laps", laps)):
        if not (isinstance(value, int) and value >= 1):
            raise ValueError(f"{flag} must be a whole number >= 1, got {value!r}")
    sources = route_sources(items)
    base = baseline.split(",")[0].strip() or None
    task = RouteTask(RouteSource("", ""), policy, race_type=race_type, episodes=episodes,
                     races=races, laps=laps, seed=seed, baseline=base)
    out = check_json_path(json_path)
    routes = sources.routes
    jobs = default_jobs(len(routes)) if jobs is None else jobs
    if not (isinstance(jobs, int) and jobs >= 1):
        raise ValueError(f"--jobs must be a whole number >= 1 (1: in this process), got {jobs}")
    # A bad policy or baseline is the user's error once, not a failure on every route.
    make_driver(task.policy, seed=task.seed)
    baseline = task.baseline if task.race_type == "time_trial" else None
    if baseline is not None:
        make_driver(baseline, seed=task.seed)
    tasks = [dataclasses.replace(task, source=source) for source in routes]
    width = max(16, *(len(r.route) for r in routes))
    workers = min(jobs, len(routes))
    where = ("in this process" if workers == 1
             else f"{workers} worker processes")
    if task.race_type == "time_trial":
        base = f"; {baseline} on the same starts" if baseline else ""
        print(f"{task.policy}: {task.episodes} one-lap attempts alone on each of {len(routes)} "
              f"routes from start points spread round the lap (training rules: an infraction "
              f"ends the attempt){base}; {where}")
        print(laps_header(width, baseline))
    else:
        print(f"{task.policy}: {task.races} {task.race_type} races of {task.laps} laps on each "
              f"of {len(routes)} routes (race rules: a 5 s penalty per infraction, a crash is "
              f"also a reset); {where}")
        print(races_header(width))
    for ignored in sources.ignored:
        print(f"{Path(ignored).name}: left out: not a track file (expected "
              f"{', '.join(('.json', '.npy', '.csv'))})")
    bar = Progress("evaluate", mode=progress)
    finished: dict[int, RouteResult] = {}
    shown = [0]
    start = time.monotonic()

    def print_row(r: RouteResult) -> None:
        if isinstance(r, RouteFailure):
            print(failure_line(r), flush=True)
        elif isinstance(r, RouteLaps):
            print(laps_row(r, width, baseline), flush=True)
        else:
            print(races_row(r, width), flush=True)

    def show(index: int, result: RouteResult) -> None:
        finished[index] = result
        bar.clear()
        while shown[0] in finished:
            print_row(finished[shown[0]])
            shown[0] += 1
        bar.update(len(finished) / len(tasks), f"{len(finished)}/{len(tasks)} routes")

    interrupted = False
    try:
        results = run_routes(tasks, workers, show)
    except KeyboardInterrupt:
        # Ctrl-C: the routes done so far are kept, summed up and written like a whole run.
        interrupted = True
        results = [finished[i] for i in sorted(finished)]
        bar.close()
        for index in sorted(i for i in finished if i >= shown[0]):
            print_row(finished[index])
    bar.close()
    wall = time.monotonic() - start
    failures = [r for r in results if isinstance(r, RouteFailure)]
    if task.race_type == "time_trial":
        done_laps = [r for r in results if isinstance(r, RouteLaps)]
        lines, figures = laps_summary(done_laps, failures, baseline)
        rows = [laps_json(r) for r in done_laps]
        lines.append(f"laps: share of the attempts that completed the lap; mean s, best s: "
                     f"the policy's laps{f'; {baseline} s: its mean lap' if baseline else ''};"
                     f" ref s: the minimum-time reference lap (an estimate, "
                     f"policies.racing_line.reference_lap_time); vs %: how much slower the "
                     f"policy's mean lap is (negative: faster)")
    else:
        done_races = [r for r in results if isinstance(r, RouteRaces)]
        lines, figures = races_summary(done_races, failures)
        rows = [races_json(r) for r in done_races]
        lines.append("finished: races that completed their laps within a minute a lap; "
                     "per lap: over the laps completed; off: times off the track")
    lines.append(f"wall time {wall:.0f} s ({where})")
    if interrupted:
        lines.insert(0, f"interrupted (Ctrl-C) after {len(results)} of {len(tasks)} routes; "
                        "the summary covers those")
    print("\n".join(lines))
    if out is not None:
        settings = ({"episodes": task.episodes, "baseline": baseline}
                    if task.race_type == "time_trial" else {"races": task.races, "laps": task.laps})
        write_json(out, {
            "policy": task.policy, "race_type": task.race_type,
            "settings": {**settings, "seed": task.seed, "jobs": workers},
            "routes": rows,
            "files_not_evaluated": [{"route": f.route, "file": f.source, "error": f.error}
                                    for f in failures],
            "files_left_out": list(sources.ignored),
            "summary": figures, "wall_s": round(wall, 1),
            "interrupted": interrupted, "routes_given": len(tasks)})
        print(f"figures -> {out}")
    # 130: the shell's status of a command stopped by Ctrl-C.
    return 130 if interrupted else 1 if failures else 0
