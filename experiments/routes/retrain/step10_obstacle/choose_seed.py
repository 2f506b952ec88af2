"""Which seed of obstacle_generalist's step 10 would ship, from the shipped tracks and the
narrow route-like tracks only, never the real routes.

    python experiments/routes/retrain/step10_obstacle/choose_seed.py

The rule (README.md here, fixed before any step 10 training):
1. head to bot on the 20 narrow route-like tracks (``routelike_narrow.py``, 20 races each,
   ``obstacle10_sN_routelike_narrow.json``): on target on at least as many tracks as step 7
   (``obstacle7_routelike_narrow.json``, measured the same way: 18 of 20), and resets per lap
   over all of them at most step 7's + ``RESET_MARGIN``. Step 9's students, which went over 1
   reset a lap on 2-13 narrow real routes, are measured there the same way
   (``obstacle9_sN_routelike_narrow.json``): the check sees them (README.md);
2. among the seeds that pass 1: step 8's rule (step 7's), imported from
   ``../step8/choose_seed_obstacle.py``, on ``obstacle10_sN_*_shipped.json``, against step 7's
   pace alone (``../step8/obstacle7_time_trial_shipped.json``): the race targets on all 7
   shipped tracks in both race types, alone within 2 points of step 7's pace, then the fewest
   crashes a lap (ties: resets, then pace).
All three seeds must be measured (every file of 1 and 2): else it names what is missing and
chooses none. No seed passing 1 and 2: none ships.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
STEP8 = HERE.parent / "step8"
NAME = "obstacle10"
SEEDS = (0, 1, 2)
NARROW_TRACKS = 20
RESET_MARGIN = 0.1
"""Resets per lap over the narrow route-like tracks allowed above step 7's."""
_SPEC = importlib.util.spec_from_file_location("choose_seed_obstacle",
                                               STEP8 / "choose_seed_obstacle.py")
RULE = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(RULE)


def narrow(path: Path) -> tuple[int, float]:
    """``(tracks on target, resets per lap)`` of a routelike_narrow.py JSON, checked to be head
    to bot with 20 races on each of the 20 tracks."""
    data = json.loads(path.read_text())
    summary = data.get("summary", {})
    races = data.get("settings", {}).get("races")
    if (data.get("race_type") != "head_to_bot" or races != 20
            or summary.get("routes") != NARROW_TRACKS):
        raise SystemExit(f"{path}: expected head_to_bot with 20 races on each of the "
                         f"{NARROW_TRACKS} narrow route-like tracks, got "
                         f"{data.get('race_type')!r}, {races} races on {summary.get('routes')} "
                         "tracks; measure it with routelike_narrow.py as run.sh does")
    return summary["routes_meeting_targets"], summary["resets"] / max(summary["laps"], 1)


def main(argv: list[str] | None = None, *, here: Path | None = None) -> str | None:
    """Print the rule's table for ``{here}/obstacle10_sN_*`` and return the chosen run's name
    (None: none chosen)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.parse_args(argv)
    here = HERE if here is None else here
    kinds = ("time_trial_shipped", "object_avoidance_shipped", "head_to_bot_shipped",
             "routelike_narrow")
    missing = [f"{NAME}_s{seed}_{kind}.json" for seed in SEEDS for kind in kinds
               if not (here / f"{NAME}_s{seed}_{kind}.json").exists()]
    if not (here / "obstacle7_routelike_narrow.json").exists():
        missing.append("obstacle7_routelike_narrow.json")
    if missing:
        sys.exit(f"not every seed is measured (no {', '.join(missing)} in {here}): the rule "
                 "chooses among all three seeds; run run.sh to the end first")
    base_on, base_resets = narrow(here / "obstacle7_routelike_narrow.json")
    bar = base_resets + RESET_MARGIN
    print(f"step 7 in head to bot on the {NARROW_TRACKS} narrow route-like tracks: on target on "
          f"{base_on}, {base_resets:.3f} resets per lap; a seed needs {base_on} or more and "
          f"at most {bar:.3f}")
    passed = []
    for seed in SEEDS:
        on, resets = narrow(here / f"{NAME}_s{seed}_routelike_narrow.json")
        ok = on >= base_on and resets <= bar + 1e-9
        print(f"{NAME}_s{seed}: on target on {on} of {NARROW_TRACKS} narrow route-like tracks, "
              f"{resets:.3f} resets per lap: {'passes' if ok else 'out'}")
        if ok:
            passed.append(seed)
    if not passed:
        print("chosen: none (no seed passes head to bot on the narrow route-like tracks); "
              "nothing ships")
        return None
    print(f"step 8's rule among {', '.join(f'{NAME}_s{s}' for s in passed)}:")
    return RULE.main([], here=here, name=NAME, baseline=STEP8 / "obstacle7_time_trial_shipped.json",
                     seeds=tuple(passed))


if __name__ == "__main__":
    main()
