"""How much error can a student of the box-aware racing line make before it hits boxes?

    python experiments/obstacles/teacher_margins.py [--bias B] [--sigma S] [OPTION=VALUE ...]

Object-avoidance races of ``evaluate_races.py`` (3 laps, 6 random boxes, seeds 1-3, the 7
shipped tracks and the DeepRacer route files) driven by ``racing_line`` with the bot settings
of the recipes (``follow_gap=2.0, closing_speed=0.3``) and the given options (e.g.
``box_clearance=0.2 box_speed_cap=1.8 box_bend_grip=0.35``), its speed action raised by B
and its steering action given Gaussian noise of standard deviation S (a student's errors).
Prints races finished and boxes hit.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from h2h_racing.match import run_race
from h2h_racing.policies import make_driver
from h2h_racing.track.io import list_tracks

sys.path.insert(0, str(Path(__file__).resolve().parent))
from evaluate_races import ROUTES, SEEDS  # type: ignore[import-not-found]  # noqa: E402


class Erring:
    """``driver`` with its speed action raised by ``bias`` and noise on its steering."""

    def __init__(self, driver: Any, bias: float, sigma: float, seed: int) -> None:
        self.driver, self.bias, self.sigma = driver, bias, sigma
        self.name, self.rng = "erring", np.random.default_rng(seed)

    def reset(self, core: Any) -> None:
        self.driver.reset(core)

    def act(self, core: Any, car: int) -> np.ndarray:
        action = np.array(self.driver.act(core, car), dtype=np.float64)
        action[:, 1] += self.bias
        action[:, 0] += self.sigma * self.rng.standard_normal(len(action))
        return np.clip(action, -1.0, 1.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bias", type=float, default=0.0, help="added to the speed action")
    parser.add_argument("--sigma", type=float, default=0.0, help="steering noise (std)")
    parser.add_argument("options", nargs="*", help="racing_line options, KEY=VALUE")
    args = parser.parse_args()
    options = {"follow_gap": 2.0, "closing_speed": 0.3}
    options.update({k: float(v) for k, v in (o.split("=") for o in args.options)})
    tracks = list_tracks() + sorted(str(p) for p in ROUTES.glob("*.npy"))
    finished = crashes = races = 0
    for track in tracks:
        for seed in SEEDS:
            driver = Erring(make_driver("racing_line", seed=seed, **options), args.bias,
                            args.sigma, seed)
            row = run_race(track, [driver], race_type="object_avoidance", laps=3, seed=seed,
                           randomize_obstacles=True).rows[0]
            races += 1
            finished += int(row["finished"])
            crashes += row["crashes"]
    print(f"{options} bias {args.bias} sigma {args.sigma}: {finished}/{races} finished, "
          f"{crashes} boxes hit")


if __name__ == "__main__":
    main()
