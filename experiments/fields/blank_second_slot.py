"""Why ``league_racer`` loses three- and four-car races: its second opponent slot.

``league_racer`` was trained in two-car races only, so the state observation's second
opponent slot (features 23-26, ``h2h_racing.sensors.state``) was always empty (zeros) in
training. In a field it is filled whenever two other cars are within 5 m. This script races
the policy in the fields of ``evaluate --field`` as it is and with that slot blanked (its
observation shows only the nearest opponent, as in training), on the same start points::

    python experiments/fields/blank_second_slot.py --track all --races 12 --laps 3 --seed 7

A diagnosis, not a driver to ship: the blanked policy does not see the second car.
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from h2h_racing.policies import make_driver
from h2h_racing.track.io import list_tracks
from h2h_racing.training.evaluate_field import combine_fields, field_race

SECOND_SLOT = slice(23, 27)
"""The second opponent slot of the state vector (19 base features + 4 of the first slot)."""
FIELDS = ("racing_line,pure_pursuit,blocker", "racing_line,blocker", "racing_line,pure_pursuit")


class BlankSecondSlot:
    """A trained driver whose state observation has its second opponent slot emptied."""

    def __init__(self, policy: str, seed: int) -> None:
        self.inner = make_driver(policy, seed=seed)
        self.name = f"{self.inner.name}_blanked"
        observe = self.inner._observe

        def blanked(core: Any, car: int) -> dict[str, np.ndarray]:
            groups = observe(core, car)
            state = groups["policy"].copy()
            state[:, SECOND_SLOT] = 0.0
            return {**groups, "policy": state}

        self.inner._observe = blanked

    def reset(self, core: Any) -> None:
        self.inner.reset(core)

    def act(self, core: Any, car: int) -> np.ndarray:
        return self.inner.act(core, car)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policy", default="league_racer")
    parser.add_argument("--track", default="all")
    parser.add_argument("--races", type=int, default=12, help="a multiple of 3 and 4")
    parser.add_argument("--laps", type=int, default=3)
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    tracks = list_tracks() if args.track == "all" else args.track.split(",")
    print(f"{'field':<36} {'observation':<12} {'mean place':>10} {'won':>9} "
          f"{'passes/race':>11} {'crashes/race':>12} {'off/race':>8}")
    for field in FIELDS:
        names = field.split(",")
        for label, blank in (("as trained", False), ("blanked", True)):
            results = []
            for track in tracks:
                driver = (BlankSecondSlot(args.policy, args.seed) if blank
                          else make_driver(args.policy, seed=args.seed))
                opponents = [make_driver(n, seed=args.seed + 1 + i) for i, n in enumerate(names)]
                races = args.races - args.races % (len(names) + 1)
                results.append(field_race(driver, opponents, track, races=races, laps=args.laps,
                                          seed=args.seed))
            f = combine_fields(results).slot_figures()
            print(f"{field:<36} {label:<12} {f['mean_place']:>10.2f} "
                  f"{f['wins']:>4} / {f['races']:<3} {f['passes_per_race']:>11.2f} "
                  f"{f['crashes_per_race']:>12.2f} {f['off_tracks_per_race']:>8.2f}", flush=True)


if __name__ == "__main__":
    main()
