"""Object-avoidance figures of trained policies on the shipped tracks (issue 22 probe).

    python experiments/obstacles/evaluate_oa.py POLICY [POLICY ...] > figures.txt

For each policy and catalogue track: 3-lap object-avoidance races with DeepRacer's 6 boxes at
randomised places (seeds 1-3), and one time trial (seed 0) for the lap time.
"""

import sys

from h2h_racing.match import run_race
from h2h_racing.track.io import list_tracks

SEEDS = (1, 2, 3)

for policy in sys.argv[1:]:
    print(f"== {policy}")
    done = races = 0
    for track in list_tracks():
        rows = [run_race(track, [policy], race_type="object_avoidance", laps=3, seed=s,
                         randomize_obstacles=True).rows[0] for s in SEEDS]
        tt = run_race(track, [policy], race_type="time_trial", laps=3, seed=0).rows[0]
        finished = sum(r["finished"] for r in rows)
        laps = sum(r["laps"] for r in rows)
        done += finished
        races += len(rows)
        print(f"{track:15s} finished {finished}/{len(rows)}  laps {laps:2d}  "
              f"crashes {sum(r['crashes'] for r in rows):3d}  "
              f"resets {sum(r['resets'] for r in rows):3d}  "
              f"time-trial best lap {tt['best_lap']:.2f} s ({tt['laps']} laps)", flush=True)
    print(f"total: {done}/{races} object-avoidance races finished", flush=True)
