"""Which seed of ppo_generalist's step 5 would ship, from the shipped tracks alone.

    python experiments/routes/retrain/ppo_more/choose_seed.py   # reads ppo5_s*_shipped.json here

The rule, fixed before any route figure of step 5 was read (the routes only check the choice):
1. the seeds that lap every shipped track at 100 % (20 of 20 attempts); if none does, the seeds
   that lap the most shipped tracks at 100 %;
2. among them, the fastest: the lowest mean, over the shipped tracks, of the seed's mean lap
   against today's racing_line's (`../racing_line_shipped.json`, in %).
A seed without its JSON is left out and named.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).parent


def shipped_figures(path: Path, line_laps: dict[str, float]) -> tuple[int, float]:
    """(tracks lapped at 100 %, mean lap vs racing_line in %) of one evaluate JSON."""
    data = json.loads(path.read_text())
    tracks = sorted(r["route"] for r in data["routes"])
    if data.get("race_type") != "time_trial" or tracks != sorted(line_laps):
        raise SystemExit(f"{path}: expected `evaluate --track all --json` (a time trial on "
                         f"the shipped tracks {sorted(line_laps)}), got race type "
                         f"{data.get('race_type')!r} on {tracks}; measure it as run.sh does")
    full = sum(r["laps"] >= 1.0 for r in data["routes"])
    paces = [100 * (r["mean_lap_s"] / line_laps[r["route"]] - 1) for r in data["routes"]
             if r["mean_lap_s"]]
    return full, sum(paces) / len(paces) if paces else float("inf")


def main() -> None:
    line = json.loads((HERE.parent / "racing_line_shipped.json").read_text())
    line_laps = {r["route"]: r["mean_lap_s"] for r in line["routes"]}
    figures = {}
    for seed in range(3):
        path = HERE / f"ppo5_s{seed}_shipped.json"
        if not path.exists():
            print(f"ppo5_s{seed}: no {path.name} (not measured)")
            continue
        figures[seed] = shipped_figures(path, line_laps)
        full, pace = figures[seed]
        print(f"ppo5_s{seed}: {full} of {len(line_laps)} shipped tracks at 100 %, mean lap "
              f"{pace:+.1f} % against racing_line")
    if not figures:
        sys.exit("no seed measured yet")
    most = max(full for full, _ in figures.values())
    chosen = min((s for s, (full, _) in figures.items() if full == most),
                 key=lambda s: figures[s][1])
    print(f"chosen: ppo5_s{chosen}")


if __name__ == "__main__":
    main()
