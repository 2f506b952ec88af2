"""Does step 9's chosen seed ship? Step 8's ship rule (``../step8/README.md``), unchanged: on
the 40 routes it meets object avoidance on more routes than the shipped step 7 (39) and head
to bot on all 40, and then the card's protocol (``experiments/obstacles/evaluate_races.py`` on
the 7 shipped tracks and the card's 3 routes, races 1-3: every target of the 30 met).

    python experiments/routes/retrain/step9_obstacle/ship_check.py

The seed is ``choose_seed.py``'s (shipped tracks only; it refuses fewer than 3 seeds). Reads
``{seed}_{object_avoidance,head_to_bot}.json`` (run.sh) and, once the routes pass,
``{seed}_card.json`` (the command is printed when it is missing).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from choose_seed import main as choose  # noqa: E402

ROUTES = 40
STEP7_OBJECT_AVOIDANCE = 39
"""Routes on target in object avoidance of the shipped step 7 (its card)."""
CARD_TARGETS = 30
"""The card's protocol: 10 tracks x (object avoidance, head to bot, time trial)."""


def routes_on_target(path: Path) -> tuple[int, list[str]]:
    data = json.loads(path.read_text())
    summary = data["summary"]
    if summary["routes"] != ROUTES or data["settings"].get("races") != 20:
        raise SystemExit(f"{path}: expected 20 races on each of the {ROUTES} routes, got "
                         f"{data['settings'].get('races')} on {summary['routes']}; measure it "
                         "as run.sh does")
    return summary["routes_meeting_targets"], summary["routes_missing_targets"]


def card_targets(path: Path) -> int:
    (figures,) = json.loads(path.read_text())["figures"].values()
    return sum(bool(kinds[kind]["ok"]) for kinds in figures.values()
               for kind in ("object_avoidance", "head_to_bot", "time_trial"))


def check(seed: str | None, here: Path | None = None) -> bool:
    """Print the rule's verdict for run ``seed`` (None: none chosen) and return it; its files
    in ``here`` (this folder; ``../step10_obstacle/ship_check.py`` gives its own: the same
    rule, not a copy)."""
    here = HERE if here is None else here
    if seed is None:
        print("ships: no (no seed chosen)")
        return False
    oa, oa_missed = routes_on_target(here / f"{seed}_object_avoidance.json")
    h2b, h2b_missed = routes_on_target(here / f"{seed}_head_to_bot.json")
    print(f"{seed} on the {ROUTES} routes: object avoidance on target on {oa} (step 7: "
          f"{STEP7_OBJECT_AVOIDANCE}; missed {', '.join(oa_missed) or 'none'}), head to bot on "
          f"{h2b} (missed {', '.join(h2b_missed) or 'none'})")
    if not (oa > STEP7_OBJECT_AVOIDANCE and h2b == ROUTES):
        print(f"ships: no (the rule asks for object avoidance on more than "
              f"{STEP7_OBJECT_AVOIDANCE} routes and head to bot on all {ROUTES})")
        return False
    card = here / f"{seed}_card.json"
    if not card.exists():
        print(f"routes pass; the card's protocol is not measured yet: python experiments/"
              f"obstacles/evaluate_races.py runs/{seed}/policy.pt --routes FOLDER "
              f"--json {card} (FOLDER: links to Oval_track.npy, reInvent2019_track.npy and "
              f"reinvent_base.npy of ../shared/data/deepracer_tracks)")
        return False
    met = card_targets(card)
    ok = met == CARD_TARGETS
    print(f"card's protocol: {met} of {CARD_TARGETS} targets met\nships: {'yes' if ok else 'no'}")
    return ok


def main() -> None:
    check(choose([]))


if __name__ == "__main__":
    main()
