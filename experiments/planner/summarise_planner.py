"""Summarise a JSON of ``evaluate_planner.py`` as Markdown: a row per track and the totals
against issue 34's targets.

    python experiments/planner/summarise_planner.py experiments/planner/figures/default.json
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

OPPONENTS = ("racing_line", "blocker", "pure_pursuit")


def _name(track: str) -> str:
    return Path(track).stem


def summarise(data: dict) -> str:
    """The Markdown report of one run's JSON."""
    rows = data["tracks"]
    races = data["races"]
    lines = [f"`{data['driver']}`, {races} races (or lap attempts) per track and contest, "
             f"seed {data['seed']}, {len(rows)} tracks, {data['seconds']} s", "",
             "| track | won from behind vs racing_line / blocker / pure_pursuit | crashes caused "
             "| off-tracks | 4-car field from the back: won | four planners: all finished, "
             "crashes | in front of league_racer: won | alone: laps, lap / reference, "
             "lap / racing_line |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        behind = [r[f"behind_{o}"] for o in OPPONENTS]
        alone = r["alone"]
        lap = alone["mean_lap"]
        lines.append(
            f"| {_name(r['track'])} | " + " / ".join(str(b["won"]) for b in behind)
            + " | " + " / ".join(str(b["crashes"]) for b in behind)
            + " | " + " / ".join(str(b["off"]) for b in behind)
            + f" | {r['field']['won']} | {r['four']['all_finished']}, {r['four']['crashes']} "
            f"| {r['front_league_racer']['won']} | {100 * alone['laps']:.0f} %, "
            f"{lap / alone['reference_lap']:.2f}, {lap / alone['racing_line_lap']:.3f} |")
    total = len(rows) * races
    lines += ["", f"Totals over {total} races per contest:", ""]
    for o in OPPONENTS:
        key = f"behind_{o}"
        won = sum(r[key]["won"] for r in rows)
        lines.append(f"- behind `{o}`: won {won} ({100 * won / total:.0f} %), passes "
                     f"{sum(r[key]['passes'] for r in rows) / total:.2f}, crashes caused "
                     f"{sum(r[key]['crashes'] for r in rows) / total:.2f}, off-tracks "
                     f"{sum(r[key]['off'] for r in rows) / total:.2f} per race; tracks at "
                     f">= 90 % won: {sum(r[key]['won'] >= 0.9 * races for r in rows)} of "
                     f"{len(rows)}")
    field = sum(r["field"]["won"] for r in rows)
    lines.append(f"- 4-car field from the back: won {field} ({100 * field / total:.0f} %), "
                 f"crashes caused {sum(r['field']['crashes'] for r in rows) / total:.2f} per race")
    four = sum(r["four"]["all_finished"] for r in rows)
    lines.append(f"- four planners: every car finished {four} of {total} races, crashes (all "
                 f"cars) {sum(r['four']['crashes'] for r in rows) / total:.2f} per race")
    front = sum(r["front_league_racer"]["won"] for r in rows)
    lines.append(f"- in front of `league_racer`: won {front} ({100 * front / total:.0f} %)")
    pace = sum(r["pace_0.6_behind_racing_line"]["won"] for r in rows)
    lines.append(f"- at racing_line's grip (0.6) behind it: won {pace} "
                 f"({100 * pace / total:.0f} %)")
    ratios = [r["alone"]["mean_lap"] / r["alone"]["reference_lap"] for r in rows]
    clean = sum(r["alone"]["laps"] == 1.0 and r["alone"]["off"] == 0 for r in rows)
    lines.append(f"- alone: every attempt lapped clean on {clean} of {len(rows)} tracks; lap "
                 f"{min(ratios):.2f}-{max(ratios):.2f} x the minimum-time reference")
    return "\n".join(lines)


if __name__ == "__main__":
    print(summarise(json.loads(Path(sys.argv[1]).read_text())))
