"""Race results: finishing order and per-car statistics, and a plain-text table."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from h2h_racing.sim import race

if TYPE_CHECKING:
    from h2h_racing.sim.core import RaceCore


def race_results(core: RaceCore, env_index: int, agents: list[str]) -> list[dict[str, Any]]:
    """Return one dict per car of env copy ``env_index``, in race order (winner first).

    Keys: ``position``, ``agent``, ``finished``, ``laps``, ``total_time`` (finish time in
    simulated seconds, inf if not finished; in a race without a lap target, a time trial, the
    time of the laps completed, inf without one), ``best_lap`` (best valid lap, inf if none),
    ``lap_times``, ``resets``, ``penalties``, ``penalty_time``, ``off_tracks``, ``crashes``,
    ``collisions``, ``overtakes``, ``defences``, ``distance``.
    """
    e = env_index
    rank = race.race_ranks(core.distance[e:e + 1], core.finished[e:e + 1],
                           core.finish_time[e:e + 1], core.best_lap_time[e:e + 1],
                           core.rules.ranking)[0]
    order = np.argsort(rank, kind="stable").tolist()
    rows = []
    for position, car in enumerate(order, start=1):
        total = float(core.finish_time[e, car])
        if core.rules.laps == 0 and not core.finished[e, car] and core.lap_times[e][car]:
            # A time trial has no lap target, so nobody finishes: its total is the time of the
            # laps driven (the clock when the last completed lap ended).
            total = float(sum(core.lap_times[e][car]))
        rows.append({
            "position": position,
            "agent": agents[car],
            "finished": bool(core.finished[e, car]),
            "laps": int(core.laps[e, car]),
            "total_time": total,
            "best_lap": float(core.best_lap_time[e, car]),
            "lap_times": list(core.lap_times[e][car]),
            "resets": int(core.resets[e, car]),
            "penalties": int(core.penalties[e, car]),
            "penalty_time": float(core.penalty_time[e, car]),
            "off_tracks": int(core.off_tracks[e, car]),
            "crashes": int(core.crashes[e, car]),
            "collisions": int(core.collisions[e, car]),
            "overtakes": int(core.overtakes[e, car]),
            "defences": int(core.defences[e, car]),
            "distance": float(core.distance[e, car]),
        })
    return rows


def _seconds(value: float) -> str:
    return "-" if not math.isfinite(value) else f"{value:.2f}"


def format_results(rows: list[dict[str, Any]], names: dict[str, str] | None = None) -> str:
    """Format results as a fixed-width text table (one line per car; the car column as wide
    as its longest label). ``DNF``: a lap target not reached."""
    names = names or {}
    labels = [r["agent"] + (f" ({names[r['agent']]})" if r["agent"] in names else "")
              for r in rows]
    width = max([24, *map(len, labels)])
    header = (f"{'pos':>3}  {'car':<{width}} {'laps':>4} {'total s':>8} {'best lap':>8} "
              f"{'resets':>6} {'pen s':>6} {'off':>4} {'crash':>5} {'overt':>5} {'def':>4}")
    lines = [header, "-" * len(header)]
    for r, label in zip(rows, labels):
        total = _seconds(r["total_time"]) if math.isfinite(r["total_time"]) else "DNF"
        lines.append(
            f"{r['position']:>3}  {label:<{width}} {r['laps']:>4} {total:>8} "
            f"{_seconds(r['best_lap']):>8} {r['resets']:>6} {r['penalty_time']:>6.1f} "
            f"{r['off_tracks']:>4} {r['crashes']:>5} {r['overtakes']:>5} {r['defences']:>4}")
    return "\n".join(lines)
