"""Four shipped tracks, each as it ships and re-drawn through waypoints spaced as step 7's
training tracks were (``training.tracks.resample``: 30 cm evenly, 60-80 cm, 5-80 cm), written
as track files into a folder for ``h2h-racing evaluate --track FOLDER``.

    python experiments/routes/retrain/obstacle_fine/why_slow/resampled_tracks.py OUT
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from h2h_racing.track.io import load_track, save_track
from h2h_racing.track.shape import Track
from h2h_racing.training.tracks import resample

GAPS = ((0.3, 0.3), (0.6, 0.8), (0.05, 0.8))


def main(out: Path) -> None:
    rng = np.random.default_rng(5)
    out.mkdir(parents=True, exist_ok=True)
    for name in ("grand_loop", "hairpin_valley", "kidney", "technical"):
        track = load_track(name)
        save_track(track, out / f"{name}_orig.json")
        for gap in GAPS:
            # As training.tracks._finished: a draw whose border folds is drawn again.
            for _ in range(5):
                centre, widths = resample(rng, track.centre,
                                          (track.width_left, track.width_right), gap)
                try:
                    redrawn = Track(centre, *widths, name=f"{name}_g{gap[0]}_{gap[1]}")
                    break
                except ValueError:
                    continue
            save_track(redrawn, out / f"{name}_g{gap[0]}_{gap[1]}.json")


if __name__ == "__main__":
    main(Path(sys.argv[1]))
