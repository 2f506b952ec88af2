"""Race events as text lines: what a recording's ``/events`` log says after each step.

The lines are built from the core's ``StepEvents`` (passes, collisions, bot contacts and the
per-car flags of one step) and the core's counters; :class:`h2h_racing.viz.recorder.RaceRecorder`
logs them with rerun. This module never imports rerun.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from h2h_racing.sim.core import RaceCore, StepEvents

EVENT_KINDS = ("start", "lap", "overtake", "collision", "off_track", "infraction", "penalty",
               "reset", "finish", "retired", "results")
"""Kinds of event lines in ``/events`` (the bracketed tag at the start of each line)."""
EVENT_LEVELS = {"start": "INFO", "lap": "INFO", "overtake": "INFO", "collision": "WARN",
                "off_track": "WARN", "infraction": "WARN", "penalty": "WARN", "reset": "DEBUG",
                "finish": "INFO", "retired": "WARN", "results": "INFO"}
"""Log level of each kind of event line."""

EventLine = tuple[str, str, "int | None"]
"""``(kind, text, car)``: the kind, the text and the car it concerns (None: no one car)."""


def step_event_lines(ev: StepEvents, agents: Sequence[str], core: RaceCore, bot_penalty: float,
                     truncations: dict[str, bool]) -> list[EventLine]:
    """Return the event lines of one step of env copy 0, in logging order.

    Args:
        ev: The core's events of the step.
        agents: Agent names, by car index.
        core: The core after the step (lap, penalty, rank and finish counters are read).
        bot_penalty: Seconds every bot pauses when one is hit from behind [s].
        truncations: The step's truncations (cars stopped by the time limit).
    """
    lines: list[EventLine] = []

    def add(kind: str, text: str, car: int | None = None) -> None:
        lines.append((kind, text, car))

    for _, passer, passed in ev.passes:
        add("overtake", f"{agents[passer]} overtook {agents[passed]}", passer)
    for _, fault, other, is_obstacle in ev.collisions:
        if is_obstacle:
            text = f"{agents[fault]} hit obstacle {other}"
        else:
            text = f"{agents[fault]} hit {agents[other]} ({agents[fault]} was behind, at fault)"
        add("collision", text, fault)
    for _, car, bot, car_at_fault in ev.bot_contacts:
        if car_at_fault:
            text = f"{agents[car]} hit bot_car_{bot} from behind (at fault)"
        else:
            text = (f"bot_car_{bot} ran into {agents[car]} from behind: every bot pauses "
                    f"{bot_penalty:g} s")
        add("collision", text, car)
    flags = {name: getattr(ev, name)[0].tolist()
             for name in ("off_track", "reversed", "immobilised", "penalised", "replaced",
                          "lap_completed", "finished", "terminated")}
    for i, agent in enumerate(agents):
        if flags["off_track"][i]:
            add("off_track", f"{agent} went off track", i)
        if flags["reversed"][i]:
            add("infraction", f"{agent} drove the wrong way", i)
        if flags["immobilised"][i]:
            add("infraction", f"{agent} is immobilised", i)
        if flags["penalised"][i]:
            add("penalty", f"{agent} penalised ({int(core.penalties[0, i])} so far, "
                           f"{float(core.penalty_time[0, i]):.1f} s in all)", i)
        if flags["replaced"][i]:
            add("reset", f"{agent} put back on track", i)
        if flags["lap_completed"][i]:
            add("lap", f"{agent} completed lap {int(core.laps[0, i])} in "
                       f"{float(core.last_lap_time[0, i]):.2f} s", i)
        if flags["finished"][i]:
            add("finish", f"{agent} finished P{int(core.rank[0, i])} in "
                          f"{float(core.finish_time[0, i]):.2f} s", i)
        elif flags["terminated"][i]:
            add("retired", f"{agent} retired", i)
    stopped = [a for a, t in truncations.items() if t]
    if stopped:
        add("retired", f"time limit: {', '.join(stopped)} stopped")
    return lines
