"""Per-route old vs new table of two ``h2h-racing evaluate --json`` files: laps, mean lap [s],
its change [%], and the reference lap [s].

    python compare_json.py OLD.json NEW.json
"""
import json
import sys

import numpy as np


def main(old_path: str, new_path: str) -> None:
    with open(old_path) as f:
        old = {r["route"]: r for r in json.load(f)["routes"]}
    with open(new_path) as f:
        new = json.load(f)["routes"]
    print(f"{'route':<28}{'laps old/new':>14}{'lap old':>9}{'lap new':>9}{'chg %':>8}"
          f"{'ref old':>9}{'ref new':>9}")
    changes = []
    for r in new:
        a = old[r["route"]]
        both = r["mean_lap_s"] and a["mean_lap_s"]
        change = 100 * (r["mean_lap_s"] / a["mean_lap_s"] - 1) if both else float("nan")
        changes.append(change)
        print(f"{r['route']:<28}{a['laps']:>6.2f}/{r['laps']:<6.2f}{a['mean_lap_s'] or 0:>9.2f}"
              f"{r['mean_lap_s'] or 0:>9.2f}{change:>+8.1f}{a['reference_lap_s']:>9.2f}"
              f"{r['reference_lap_s']:>9.2f}")
    c = np.array(changes)
    print(f"mean change {np.nanmean(c):+.2f} %, min {np.nanmin(c):+.1f}, max {np.nanmax(c):+.1f};"
          f" faster by >1%: {(c < -1).sum()}, slower by >1%: {(c > 1).sum()}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
