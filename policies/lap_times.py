"""Lap times by track: what the drivers lap alone, and the estimates ``h2h-racing tracks`` prints.

``python -m h2h_racing.policies`` prints :func:`lap_time_table` (each driver's one-lap time
alone on each catalogue track, driven). :func:`track_laps` gives a track's size and two
estimates that drive nothing: the minimum-time reference lap (the racing line's path at the
car's full grip, acceleration and braking: ``racing_line.reference_lap_time``) and the lap of
``racing_line``'s own speed profile on the same path. Both are point-mass figures: a real
car lags them (``racing_line`` laps 9-20 % slower than its profile from a standing start:
policies/README.md).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from dataclasses import dataclass

from h2h_racing.config.env import EnvConfig
from h2h_racing.policies.racing_line import compute_race_line, reference_lap_time
from h2h_racing.policies.registry import make_driver
from h2h_racing.policies.scripted import drive, race_core
from h2h_racing.track.shape import Track


@dataclass(frozen=True)
class TrackLaps:
    """A track's size and its lap-time estimates (``track_laps``)."""

    name: str
    length: float
    """Centre-line length [m]."""
    width_min: float
    """Narrowest total width [m]."""
    width_max: float
    """Widest total width [m]."""
    reference: float
    """Minimum-time reference lap [s] (``reference_lap_time``; an estimate)."""
    racing_line: float
    """Lap of ``racing_line``'s speed profile [s] (``RaceLine.lap_time``; an estimate)."""

    @property
    def margin(self) -> float:
        """How much slower ``racing_line``'s profile laps than the reference [%]."""
        return 100.0 * (self.racing_line / self.reference - 1.0)

    def row(self, width: int = 16) -> str:
        """One row of ``header``'s table (``width``: of the name column)."""
        widths = f"{self.width_min:.2f}-{self.width_max:.2f}"
        return (f"{self.name:<{width}} {self.length:>7.2f} {widths:>10} {self.reference:>11.2f} "
                f"{self.racing_line:>13.2f} {self.margin:>9.1f}")

    @staticmethod
    def header(width: int = 16) -> str:
        """Header of ``row``'s table."""
        return (f"{'track':<{width}} {'lap m':>7} {'width m':>10} {'reference s':>11} "
                f"{'racing_line s':>13} {'margin %':>9}")


def track_laps(track: Track, config: EnvConfig | None = None) -> TrackLaps:
    """Return ``track``'s size and lap-time estimates with ``config``'s car and top speed.

    The reference lap is ``reference_lap_time`` (the racing line's path at the car's full
    grip, acceleration and braking) and ``racing_line`` the lap of that driver's default
    profile on the same path (60 % of the grip in corners); both estimates of a point mass,
    which a real car lags.
    """
    config = config or EnvConfig()
    car, v_max = config.car, config.max_speed
    return TrackLaps(name=track.name, length=track.length, width_min=float(track.width.min()),
                     width_max=float(track.width.max()),
                     reference=reference_lap_time(track, car, v_max),
                     racing_line=compute_race_line(track, car, v_max).lap_time)


def lap_time_table(argv: Sequence[str] | None = None) -> None:
    """Print the one-lap time of each driver alone on each catalogue track, driven from a
    standing start, beside the racing line's profile lap and the minimum-time reference lap
    (estimates; ``track_laps``)."""
    from h2h_racing.track.io import list_tracks, load_track

    parser = argparse.ArgumentParser(description=lap_time_table.__doc__)
    parser.add_argument("--drivers", nargs="+", default=["pure_pursuit", "racing_line", "blocker"],
                        help="driver specs (racing_line:grip_factor=0.7 sets a pace)")
    parser.add_argument("--tracks", nargs="+", default=None,
                        help="tracks (default: the catalogue)")
    args = parser.parse_args(argv)
    tracks = args.tracks or list_tracks()
    print("| track | " + " | ".join(args.drivers) + " | racing_line profile | reference |")
    print("|---|" + "---|" * (len(args.drivers) + 2))
    for name in tracks:
        track = load_track(name)
        cells = []
        for driver_name in args.drivers:
            core = race_core(track, 1)
            drive(core, [make_driver(driver_name)])
            lap = core.lap_times[0][0]
            text = f"{lap[0]:.2f} s" if lap else "DNF"
            if core.off_tracks[0, 0]:
                text += f" ({int(core.off_tracks[0, 0])} off)"
            cells.append(text)
        laps = track_laps(track)
        cells += [f"{laps.racing_line:.2f} s", f"{laps.reference:.2f} s"]
        print(f"| {name} | " + " | ".join(cells) + " |")
