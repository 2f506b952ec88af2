"""The one ratings table of a league file: every player of every stored race, as
``h2h-racing league table`` prints it, and as ``league train`` ends with and ``league plot``
draws.

A league's round lines and placement ratings used to be a second fit (placement races only,
frozen players only), which rated the anchors differently and left the learners out; every
table and figure of a league file now comes from ``table_rows``.
"""

from __future__ import annotations

from typing import Any

from h2h_racing.league.ratings import (Standing, format_standings, format_trends,
                                       rating_trends, standings)

RATING_ANCHOR = "rating_anchor"
"""Meta key of a league's rating anchor (``LeagueConfig.rating_anchor``)."""
DEFAULT_ANCHOR = "racing_line"
"""The player held at 1000 in a file that names none (a tournament's)."""
DEFAULT_BOOT = 200
"""Bootstrap resamples of ``league table``'s intervals."""


def table_anchor(store: Any, anchor: str | None = None) -> str:
    """The player held at 1000: ``anchor`` if given, else the league's rating anchor, else
    ``racing_line``."""
    return anchor or store.meta().get(RATING_ANCHOR) or DEFAULT_ANCHOR


def table_rows(store: Any, context: str | None = None, anchor: str | None = None,
               n_boot: int = DEFAULT_BOOT) -> tuple[list[Standing], int, str | None]:
    """``(rows, races, anchor)``: the standings of every player in the file's finished
    matches (of contexts starting with ``context``), the number of races, and the anchor
    used (None when it did not race: the mean is then 1000).

    Canonical race order and the fixed bootstrap seed: the table is the same whatever order
    the matches were stored in, and equals the one ``tournament`` printed.
    """
    races = store.races(context_prefix=context)
    if not races:
        return [], 0, None
    players = {p for race in races for p in race}
    used = table_anchor(store, anchor)
    used = used if used in players else None  # type: ignore[assignment]
    return standings(races, anchor=used, n_boot=n_boot), len(races), used


def trends_text(store: Any, rows: list[Standing]) -> str:
    """The snapshot-rating trends of each learner lineage, as text ('' without snapshots)."""
    snapshots = [(p.name, p.parent or p.name, p.training_steps)
                 for p in store.players("snapshot")]
    trends = rating_trends(snapshots, {row.player: row.rating for row in rows})
    if not trends:
        return ""
    return ("\nsnapshot ratings over training (rank correlation of rating with training "
            "steps):\n" + format_trends(trends))


def table_text(store: Any, context: str | None = None, anchor: str | None = None,
               n_boot: int = DEFAULT_BOOT) -> str:
    """What ``h2h-racing league table`` prints for ``store``.

    Raises:
        ValueError: The file has no finished matches (of ``context``).
    """
    rows, races, used = table_rows(store, context, anchor, n_boot)
    if not rows:
        raise ValueError(f"{store.path} has no finished matches"
                         + (f" with context {context!r}" if context else ""))
    head = f"{races} races" + (f", anchor {used} = 1000" if used else "")
    return f"{head}\n{format_standings(rows)}\n{trends_text(store, rows)}"
