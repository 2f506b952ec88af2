"""Which seed of ppo_generalist's step 8 would ship, from the shipped tracks and the 30
route-like procedural tracks, never the real routes.

    python experiments/routes/retrain/step8/choose_seed_ppo.py

Step 6's rule, unchanged (`../ppo_step6/choose_seed.py`, run here on this step's files; README.md
here), committed before any step 8 training (the routes only check the choice):
1. the seeds that lap every shipped track at 100 % (20 of 20 attempts, `evaluate --track all
   --episodes 20`); if none does, those that lap the most shipped tracks at 100 %;
2. among them, the seeds that lap the most of the 30 route-like tracks (`../ppo_step6/
   routelike.py`: 20 one-lap attempts each) at >= 95 %;
3. among them, the fastest: the lowest mean, over the 7 shipped and 30 route-like tracks
   together (each counted once, those the seed lapped at all), of its mean lap against
   racing_line's there, in % (`../racing_line_shipped.json`,
   `../ppo_step6/racing_line_routelike.json`).
All three seeds must be measured: with a seed's JSONs missing, it names them and chooses none.

Files: `ppo8_sN_shipped.json` and `ppo8_sN_routelike.json` beside this file (run.sh ppo).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

HERE = Path(__file__).parent
NAME = "ppo8"

# Step 6's file holds the rule; loaded by path (experiments/ is no package).
_spec = importlib.util.spec_from_file_location(
    "ppo_step6_choose_seed", HERE.parent / "ppo_step6" / "choose_seed.py")
rule = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rule)


def main(argv: list[str] | None = None) -> None:
    # Read at call time, so that a test may point HERE elsewhere.
    missing = [f"{NAME}_s{seed}_{kind}.json" for seed in rule.SEEDS
               for kind in ("shipped", "routelike")
               if not (HERE / f"{NAME}_s{seed}_{kind}.json").exists()]
    if missing:
        sys.exit(f"not every seed is measured (no {', '.join(missing)} in {HERE}): step 8's rule "
                 "chooses among all three seeds; run run.sh ppo to the end first")
    rule.NAME, rule.SEED_DIR = NAME, HERE
    rule.main(argv if argv is not None else [])


if __name__ == "__main__":
    main()
