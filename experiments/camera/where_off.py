"""Where does a camera policy leave a track? One-lap attempts from 20 start points
(``h2h-racing evaluate``'s protocol), each printed with where it went off.

    python experiments/camera/where_off.py POLICY TRACK [--cap C] [--mask-around P ...]

``--cap``: the speed action at most C (in [-1, 1]; 1 is no cap), as ``speed_capped.py``.
``--mask-around P``: for each arc position P [m], attempts starting 1.5-3 m before P, with
and without every part of the track outside [P - 4, P + 2] m painted over with the floor in
the camera's ground texture: does the policy get past P without seeing the rest of the lap?
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

import h2h_racing.sensors.camera as camera
from h2h_racing.policies import make_driver
from h2h_racing.track.io import load_track
from h2h_racing.training.evaluate import evaluate
from speed_capped import SpeedCapped  # beside this script


_window: tuple[float, float] | None = None
_draw = camera.GroundTexture._draw


def _masked_draw(self: Any, track: Any, rows: int, cols: int) -> np.ndarray:
    """The texture with the tarmac nearest to arc positions outside ``_window`` floored."""
    image = _draw(self, track, rows, cols)
    if _window is None:
        return image
    x0, y1 = self.origin
    b, a = np.mgrid[0:rows, 0:cols]
    s, d = track.project(np.stack([x0 + a * self.resolution, y1 - b * self.resolution], -1))
    low, high = _window
    outside = (s - low) % track.length > (high - low) % track.length
    image[(np.abs(d) < 0.6) & outside] = camera.FLOOR
    return image


class Recorder(SpeedCapped):
    """``speed_capped.py``'s capped driver, recording arc position, offset and the core's count
    of off-tracks before each step."""

    def reset(self, core: Any) -> None:
        super().reset(core)
        self.s: list[np.ndarray] = []
        self.d: list[np.ndarray] = []
        self.off: list[np.ndarray] = []

    def act(self, core: Any, car: int) -> np.ndarray:
        self.s.append(core.s[:, car].copy())
        self.d.append(core.d[:, car].copy())
        self.off.append(core.off_tracks[:, car].copy())
        return super().act(core, car)


def attempts(policy: str, track: str, cap: float, episodes: int = 20
             ) -> tuple[np.ndarray, np.ndarray, list[int | None]]:
    """Arc positions and offsets of every attempt, shapes (steps, episodes), and the step of
    each attempt's off-track (None if it had none): the last step before the core counted it."""
    recorder = Recorder(make_driver(policy, seed=0), cap)
    print(evaluate(recorder, track, episodes=episodes, seed=0))
    counts = np.array(recorder.off + [recorder.off[-1]])
    ends = []
    for e in range(counts.shape[1]):
        went = np.flatnonzero(np.diff(counts[:, e]) > 0)
        ends.append(int(went[0]) if len(went) else None)
    return np.array(recorder.s), np.array(recorder.d), ends


def main() -> None:
    global _window
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("policy", help="shipped name or policy.pt")
    parser.add_argument("track", help="catalogue name or track file")
    parser.add_argument("--cap", type=float, default=1.0, help="largest speed action (default: 1)")
    parser.add_argument("--mask-around", type=float, nargs="*", default=[],
                        help="arc positions P [m] to test with the rest of the lap hidden")
    args = parser.parse_args()
    camera.GroundTexture._draw = _masked_draw
    if not args.mask_around:
        s, d, ends = attempts(args.policy, args.track, args.cap)
        for e, end in enumerate(ends):
            where = "did not go off" if end is None else \
                f"off at s = {s[end, e]:6.2f} m, d = {d[end, e]:+.2f} m"
            print(f"attempt {e:2d} from s = {s[0, e]:6.2f} m: {where}")
        return
    lap = load_track(args.track).length
    for p in args.mask_around:
        for window in (None, (p - 4.0, p + 2.0)):
            _window = window
            s, d, ends = attempts(args.policy, args.track, args.cap, episodes=40)
            passed = tried = 0
            for e in range(s.shape[1]):
                if not (p - 3.0 - s[0, e]) % lap < 1.5:
                    continue
                tried += 1
                travelled = np.unwrap(s[:, e] * 2 * np.pi / lap) * lap / (2 * np.pi) - s[0, e]
                end = len(travelled) - 1 if ends[e] is None else ends[e]
                passed += travelled[end] >= (p + 0.7 - s[0, e]) % lap
            hidden = "nothing hidden" if window is None else \
                f"hidden outside [{window[0]:.1f}, {window[1]:.1f}] m"
            print(f"past s = {p:5.2f} m, {hidden}: {passed} of {tried}")


if __name__ == "__main__":
    main()
