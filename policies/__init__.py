"""Scripted and trained drivers.

>>> from h2h_racing.policies import make_driver
>>> make_driver("racing_line").name
'racing_line'
"""

from h2h_racing.policies.racing_line import RaceLine, compute_race_line, speed_profile
from h2h_racing.policies.scripted import (
    DRIVERS,
    TEACHERS,
    Blocker,
    Driver,
    PurePursuit,
    RacingLine,
    Random,
    drive,
    make_driver,
    race_core,
    to_action,
)

__all__ = [
    "DRIVERS",
    "TEACHERS",
    "Blocker",
    "Driver",
    "PurePursuit",
    "RaceLine",
    "RacingLine",
    "Random",
    "compute_race_line",
    "drive",
    "make_driver",
    "race_core",
    "speed_profile",
    "to_action",
]
