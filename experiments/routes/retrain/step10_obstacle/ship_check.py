"""Does step 10's chosen seed ship? Step 8's ship rule, unchanged and imported
(``../step9_obstacle/ship_check.py``'s ``check``, which wrote it out for step 9): on the 40
routes it meets object avoidance on more routes than the shipped step 7 (39) and head to bot on
all 40, and then the card's protocol (``experiments/obstacles/evaluate_races.py`` on the 7
shipped tracks and the card's 3 routes, races 1-3: every target of the 30 met).

    python experiments/routes/retrain/step10_obstacle/ship_check.py

The seed is ``choose_seed.py``'s (shipped and narrow route-like tracks only; it refuses fewer
than 3 seeds). Reads ``{seed}_{object_avoidance,head_to_bot}.json`` (run.sh) here and, once the
routes pass, ``{seed}_card.json`` (the command is printed when it is missing).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

HERE = Path(__file__).resolve().parent


def _load(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


CHOOSE = _load("step10_choose_seed", HERE / "choose_seed.py")
SHIP = _load("step9_ship_check", HERE.parent / "step9_obstacle" / "ship_check.py")


def main() -> bool:
    return SHIP.check(CHOOSE.main([]), here=HERE)


if __name__ == "__main__":
    main()
