"""Which seed of camera_generalist's step 11 (the shipped policy distilled from today's
ppo_generalist with labels at 95 % of its speed) would ship, from the shipped tracks and the 30
route-like procedural tracks, never the real routes.

    python experiments/routes/retrain/camera_step11/choose_seed.py

Step 10's rule (`../camera_step10/choose_seed.py`, run here on this step's files), fixed and
committed before any step 11 figure existed (the routes only check it):
1. the seeds that lap every shipped track at 100 % (20 of 20 attempts, `evaluate --track all
   --episodes 20`); if none does, those that lap the most shipped tracks at 100 %;
2. among them, the seeds on issue 36's camera bar on the most of the 30 route-like tracks
   (`../ppo_step6/routelike.py`, 20 one-lap attempts each): >= 95 % laps and a mean lap within
   10 % of today's ppo_generalist's there (exactly 10 % counts);
3. among them, the fastest: the lowest mean, over the 7 shipped and 30 route-like tracks (each
   counted once, those the seed lapped at all), of its mean lap against ppo_generalist's, in %.
ppo_generalist's laps are its step 6 seed 1's JSONs (`../ppo_step6/ppo6_s1_shipped.json`,
`ppo6_s1_routelike.json`). A seed without its JSONs is left out and named.

Files: `camera11_sN_shipped.json` and `camera11_sN_routelike.json` beside this file (run.sh).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

HERE = Path(__file__).parent
PPO = HERE.parent / "ppo_step6"
NAME = "camera11"

# Step 10's file holds the rule; loaded by path (experiments/ is no package).
_spec = importlib.util.spec_from_file_location(
    "camera_step10_choose_seed", HERE.parent / "camera_step10" / "choose_seed.py")
rule = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rule)


def main(argv: list[str] | None = None) -> None:
    # Read at call time, so that a test may point HERE and PPO elsewhere.
    rule.HERE, rule.PPO, rule.NAME = HERE, PPO, NAME
    rule.DESCRIPTION = __doc__.split("\n\n")[0]
    rule.main(argv)


if __name__ == "__main__":
    main()
