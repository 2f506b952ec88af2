"""Scripted and trained drivers.

>>> from h2h_racing.policies import make_driver
>>> make_driver("racing_line").name
'racing_line'
>>> make_driver("racing_line:grip_factor=0.7").name
'racing_line:grip_factor=0.7'
"""

from h2h_racing.policies.racing_line import (
    RaceLine,
    compute_race_line,
    reference_lap_time,
    speed_profile,
)
from h2h_racing.policies.registry import (
    DriverSpec,
    Setting,
    canonical_spec,
    make_driver,
    parse_driver_spec,
)
from h2h_racing.policies.scripted import (
    DRIVERS,
    TEACHERS,
    Blocker,
    Driver,
    PurePursuit,
    RacingLine,
    Random,
    drive,
    race_core,
    to_action,
)

__all__ = [
    "DRIVERS",
    "TEACHERS",
    "Blocker",
    "Driver",
    "DriverSpec",
    "PurePursuit",
    "RaceLine",
    "RacingLine",
    "Random",
    "Setting",
    "canonical_spec",
    "compute_race_line",
    "drive",
    "make_driver",
    "parse_driver_spec",
    "race_core",
    "reference_lap_time",
    "speed_profile",
    "to_action",
]
