"""Which seed of obstacle_generalist's step 8 would ship, from the shipped tracks only, never
the real routes.

    python experiments/routes/retrain/step8/choose_seed_obstacle.py

Step 7's rule (`../obstacle_fine/README.md`, fixed in 50a8495; it had no script, so it is
written out here once), unchanged, committed before any step 8 training:
1. the seeds that meet the race targets (>= 90 % of 3-lap races finished, <= 0.5 crashes and
   <= 1 reset per lap) on all 7 shipped tracks in both race types (20 races each, `evaluate
   --track all --race-type object_avoidance|head_to_bot --races 20`);
2. and lap alone within 2 % of the shipped policy's pace: their mean lap against racing_line
   over the shipped tracks (`evaluate --track all --episodes 20`, the summary's mean) at most
   2 percentage points above step 7's, measured the same way (`obstacle7_time_trial_shipped.
   json`; step 7 read it as -0.6 % "so at most +1.4 %");
3. among them, the fewest crashes per lap over both race types on the shipped tracks (all
   crashes over all laps completed, the two race types' races together). Ties (not written in
   step 7's rule; fixed here before any figure): fewer resets per lap, then the faster alone.
All three seeds must be measured: with a seed's JSONs missing, it names them and chooses none.
No seed passing 1 and 2: none ships.

Files: `obstacle8_sN_{time_trial,object_avoidance,head_to_bot}_shipped.json` beside this file
(run.sh obstacle).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HERE = Path(__file__).parent
NAME = "obstacle8"
BASELINE = "obstacle7_time_trial_shipped.json"
SEEDS = (0, 1, 2)
SHIPPED_TRACKS = 7
PACE_MARGIN_PCT = 2.0
RACE_TYPES = ("object_avoidance", "head_to_bot")


def load(path: Path, race_type: str) -> dict:
    """One evaluate JSON, checked to be ``race_type`` on the 7 shipped tracks with 20 races or
    attempts each."""
    data = json.loads(path.read_text())
    settings = data.get("settings", {})
    count = settings.get("episodes" if race_type == "time_trial" else "races")
    tracks = len(data.get("routes", []))
    if data.get("race_type") != race_type or count != 20 or tracks != SHIPPED_TRACKS:
        raise SystemExit(f"{path}: expected {race_type} with 20 attempts or races on each of the "
                         f"{SHIPPED_TRACKS} shipped tracks, got {data.get('race_type')!r}, "
                         f"{count} on {tracks} tracks; measure it as run.sh does")
    return data


def main(argv: list[str] | None = None, *, here: Path | None = None, name: str = NAME,
         baseline: Path | None = None, seeds: tuple[int, ...] = SEEDS) -> str | None:
    """Print the rule's table for the seeds ``{here}/{name}_sN_*_shipped.json`` (``here``:
    this folder) against step 7's pace in ``baseline`` (``here``'s ``BASELINE``), and return
    the chosen run's name (None: none chosen). Later steps call it with their folder and name
    (``../step9_obstacle/choose_seed.py``): the same rule, not a copy. ``seeds``: the seeds
    it chooses among (step 10's ``choose_seed.py`` gives those that passed its own check
    first, having checked that all three are measured)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.parse_args(argv)
    here = HERE if here is None else here
    baseline = here / BASELINE if baseline is None else baseline
    kinds = ("time_trial",) + RACE_TYPES
    missing = [f"{name}_s{seed}_{kind}_shipped.json" for seed in seeds for kind in kinds
               if not (here / f"{name}_s{seed}_{kind}_shipped.json").exists()]
    if not baseline.exists():
        missing.append(str(baseline))
    if missing:
        sys.exit(f"not every seed is measured (no {', '.join(missing)} in {here}): the rule "
                 "chooses among all three seeds; run its run.sh to the end first")
    base = load(baseline, "time_trial")["summary"]["mean_vs_baseline_pct"]
    bar = base + PACE_MARGIN_PCT
    print(f"step 7 alone on the shipped tracks: {base:+.1f} % against racing_line; the bar "
          f"{bar:+.1f} %")
    kept: dict[int, tuple[float, float, float]] = {}
    for seed in seeds:
        run = f"{name}_s{seed}"
        pace = load(here / f"{run}_time_trial_shipped.json", "time_trial")["summary"][
            "mean_vs_baseline_pct"]
        races = {rt: load(here / f"{run}_{rt}_shipped.json", rt)["summary"] for rt in RACE_TYPES}
        on_target = {rt: s["routes_meeting_targets"] for rt, s in races.items()}
        laps = sum(s["laps"] for s in races.values())
        crashes = sum(s["crashes"] for s in races.values()) / max(laps, 1)
        resets = sum(s["resets"] for s in races.values()) / max(laps, 1)
        ok = all(n == SHIPPED_TRACKS for n in on_target.values()) and pace <= bar
        print(f"{run}: on target on {on_target['object_avoidance']} (object avoidance) and "
              f"{on_target['head_to_bot']} (head to bot) of {SHIPPED_TRACKS} shipped tracks; "
              f"alone {pace:+.1f} % against racing_line; {crashes:.3f} crashes and "
              f"{resets:.3f} resets per lap over {laps} laps; "
              f"{'kept' if ok else 'out'}")
        if ok:
            kept[seed] = (crashes, resets, pace)
    if not kept:
        print("chosen: none (no seed meets the targets and the pace bar); nothing ships")
        return None
    chosen = f"{name}_s{min(kept, key=lambda s: kept[s])}"
    print(f"chosen: {chosen}")
    return chosen


if __name__ == "__main__":
    main()
