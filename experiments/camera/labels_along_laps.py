"""Where does a camera student leave the track? Its actions and the teacher's along its laps.

    python experiments/camera/labels_along_laps.py POLICY TRACK [EPISODES]

One-lap attempts (``h2h-racing evaluate``'s protocol) driven by the student; at every step
``ppo_generalist`` labels the same state, as in the distillation. Prints, per step, the arc
position, offset, speed, the student's and the teacher's (steer, speed) actions, and ``<==``
where they differ by more than 0.3 in steering or 0.5 in speed.
"""

from __future__ import annotations

import sys
from typing import Any

import numpy as np

from h2h_racing.policies import make_driver
from h2h_racing.training.evaluate import evaluate


class Labelled:
    """Drives with ``student``; records ``teacher``'s action for the same state."""

    def __init__(self, student: Any, teacher: Any) -> None:
        self.student, self.teacher, self.name = student, teacher, "student"
        self.rows: list[tuple[float, ...]] = []

    def reset(self, core: Any) -> None:
        self.student.reset(core)
        self.teacher.reset(core)

    def act(self, core: Any, car: int) -> np.ndarray:
        mine = np.asarray(self.student.act(core, car))
        label = np.asarray(self.teacher.act(core, car))
        self.rows.append((core.s[0, car], core.d[0, car], core.speed[0, car], *mine[0], *label[0]))
        return mine


def main() -> None:
    policy, track = sys.argv[1], sys.argv[2]
    episodes = int(sys.argv[3]) if len(sys.argv) > 3 else 1
    driver = Labelled(make_driver(policy, seed=0), make_driver("ppo_generalist", seed=0))
    print(evaluate(driver, track, episodes=episodes, seed=0))
    for i, (s, d, v, steer, speed, t_steer, t_speed) in enumerate(driver.rows):
        flag = " <==" if abs(steer - t_steer) > 0.3 or abs(speed - t_speed) > 0.5 else ""
        print(f"{i:4d} s={s:6.2f} d={d:+.2f} v={v:4.2f} student=({steer:+.2f},{speed:+.2f}) "
              f"teacher=({t_steer:+.2f},{t_speed:+.2f}){flag}")


if __name__ == "__main__":
    main()
