"""Which seed of ppo_generalist's step 9 would ship, from the shipped tracks and the 30
route-like procedural tracks, never the real routes.

    python experiments/routes/retrain/step9/choose_seed.py      # choose_seed.txt

Step 8's ppo rule, which is step 6's (`../ppo_step6/choose_seed.py`), run by import on this
step's files (`ppo9_sN_shipped.json`, `ppo9_sN_routelike.json` beside this file; README.md
here): the seeds that lap every shipped track at 100 % (or the most of them); among them those
that lap the most route-like tracks at >= 95 %; among them the fastest against racing_line
over the 37. It refuses to choose until all three seeds are measured.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

HERE = Path(__file__).parent
NAME = "ppo9"

# Step 8's file runs step 6's rule on a step's files; loaded by path (experiments/ is no
# package), its NAME and HERE pointed at this step's.
_spec = importlib.util.spec_from_file_location(
    "step8_choose_seed_ppo", HERE.parent / "step8" / "choose_seed_ppo.py")
step8 = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(step8)


def main(argv: list[str] | None = None) -> None:
    step8.NAME, step8.HERE = NAME, HERE
    step8.main(argv if argv is not None else [])


if __name__ == "__main__":
    main()
