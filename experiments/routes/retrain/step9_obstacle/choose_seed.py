"""Which seed of obstacle_generalist's step 9 would ship, from the shipped tracks only, never
the real routes: step 8's rule (step 7's), imported from ``../step8/choose_seed_obstacle.py``
and run on this folder's ``obstacle9_sN_{time_trial,object_avoidance,head_to_bot}_shipped.json``
against step 7's pace alone (``../step8/obstacle7_time_trial_shipped.json``). Refuses to choose
from fewer than 3 seeds.

    python experiments/routes/retrain/step9_obstacle/choose_seed.py
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

HERE = Path(__file__).resolve().parent
STEP8 = HERE.parent / "step8"
NAME = "obstacle9"
_SPEC = importlib.util.spec_from_file_location("choose_seed_obstacle",
                                               STEP8 / "choose_seed_obstacle.py")
RULE = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(RULE)


def main(argv: list[str] | None = None) -> str | None:
    """Step 8's rule on step 9's files; the chosen run's name or None."""
    return RULE.main(argv, here=HERE, name=NAME,
                     baseline=STEP8 / "obstacle7_time_trial_shipped.json")


if __name__ == "__main__":
    main()
