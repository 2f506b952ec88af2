"""Where step 8's ppo seeds leave Tokyo_Training_track: each seed's 20 one-lap attempts
(``evaluate``'s starts, training rules) traced with ``../ppo_step6/tokyo/pace_profile.py``'s
``trace``; for each attempt that did not lap, the lap position [m] and speed [m/s] of its last
step on track.

    python experiments/routes/retrain/step8/tokyo_offs.py [POLICY ...]   # default: ppo8_s0-2
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
TRACK = "../shared/data/deepracer_tracks/Tokyo_Training_track.npy"
DEFAULT = [f"runs/routes_ppo8_s{seed}/policy.pt" for seed in (0, 1, 2)]

# The Tokyo diagnosis's tracer, loaded by path (experiments/ is no package).
_spec = importlib.util.spec_from_file_location(
    "pace_profile", HERE.parent / "ppo_step6" / "tokyo" / "pace_profile.py")
pace_profile = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(pace_profile)


def main(policies: list[str]) -> None:
    for policy in policies or DEFAULT:
        tr = pace_profile.trace(policy, TRACK, 20)
        ends = []
        for e in range(tr["lap"].size):
            if np.isfinite(tr["lap"][e]):
                continue
            last = np.flatnonzero(tr["live"][:, e])[-1]
            ends.append((float(tr["s"][last, e]), float(tr["speed"][last, e])))
        ends.sort()
        where = ", ".join(f"{s:.1f} m at {v:.2f} m/s" for s, v in ends) or "-"
        print(f"{policy}: lapped {int(np.isfinite(tr['lap']).sum())} of {tr['lap'].size}; "
              f"left the track at: {where}")


if __name__ == "__main__":
    main(sys.argv[1:])
