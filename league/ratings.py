"""Ratings tables from race results: the standings (Bradley-Terry rating, bootstrap interval,
sequential Elo, wins, pairwise score) and the trends of snapshot ratings over training.

The maths (pairwise decomposition, Bradley-Terry, bootstrap intervals, Elo) is in
:mod:`h2h_racing.league.rating_math`; its public names are importable from here too.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from h2h_racing.league.rating_math import (
    ELO_SCALE,
    Race,
    _races,
    bootstrap_intervals,
    bradley_terry,
    elo_history,
    expected_score,
    pair_scores,
    pairwise,
    sequential_elo,
)

__all__ = [
    "BOOTSTRAP_SEED", "ELO_SCALE", "Race", "Standing", "Trend", "bootstrap_intervals",
    "bradley_terry", "elo_history", "expected_score", "format_standings", "format_trends",
    "pair_scores", "pairwise", "rank_correlation", "rating_trends", "sequential_elo", "standings",
]

BOOTSTRAP_SEED = 0
"""Seed of ``standings``' bootstrap when no generator is given: the same races, in the same
order, give the same table byte for byte (``tournament`` and ``league table`` agree)."""


@dataclass(frozen=True)
class Standing:
    """One row of the standings."""

    player: str
    rating: float
    """Bradley-Terry rating [Elo]."""
    low: float
    """Lower end of the bootstrap interval [Elo] (NaN without bootstrap)."""
    high: float
    """Upper end of the bootstrap interval [Elo] (NaN without bootstrap)."""
    elo: float
    """Sequential Elo after the races in the order given [Elo]."""
    races: int
    """Races entered."""
    wins: int
    """Races won (best place of the race, shared first places included)."""
    score: float
    """Pairwise score fraction: points against other players / pairs met (NaN if none)."""


def standings(races: Iterable[Race], anchor: str | None, anchor_rating: float = 1000.0,
              n_boot: int = 200, rng: np.random.Generator | None = None, *,
              prior: float = 1.0, level: float = 0.9, k: float = 32.0) -> list[Standing]:
    """The standings of every player in ``races``, best Bradley-Terry rating first.

    Args:
        races: Race results ``{player: place}``, in the order they were run (for ``elo``).
        anchor: Player fixed at ``anchor_rating``; None fixes the mean.
        anchor_rating: [Elo].
        n_boot: Bootstrap resamples for the interval; 0 skips it (NaN bounds).
        rng: Random generator of the bootstrap; None seeds one with ``BOOTSTRAP_SEED``.
        prior: Virtual draws per player (see ``bradley_terry``).
        level: Interval coverage.
        k: K-factor of the sequential Elo column, which starts every player at
            ``anchor_rating``.
    """
    race_list = _races(races)
    ratings = bradley_terry(race_list, anchor=anchor, anchor_rating=anchor_rating, prior=prior)
    if n_boot:
        rng = np.random.default_rng(BOOTSTRAP_SEED) if rng is None else rng
        intervals = bootstrap_intervals(race_list, n=n_boot, level=level, rng=rng,
                                        anchor=anchor, anchor_rating=anchor_rating, prior=prior)
    else:
        intervals = {name: (math.nan, math.nan) for name in ratings}
    elo = sequential_elo(race_list, k=k, initial=anchor_rating)
    names, wins, games = pairwise(race_list)
    entered = dict.fromkeys(names, 0)
    firsts = dict.fromkeys(names, 0)
    for race in race_list:
        best = min(race.values())
        for name, place in race.items():
            entered[name] += 1
            firsts[name] += place == best
    rows = []
    for i, name in enumerate(names):
        met = games[i].sum()
        rows.append(Standing(
            player=name, rating=ratings[name], low=intervals[name][0], high=intervals[name][1],
            elo=elo[name], races=entered[name], wins=firsts[name],
            score=float(wins[i].sum() / met) if met else math.nan))
    rows.sort(key=lambda row: (-row.rating, row.player))
    return rows


def format_standings(rows: Sequence[Standing]) -> str:
    """Format standings as a fixed-width text table (one line per player)."""
    def number(value: float, digits: int = 0) -> str:
        return "-" if not math.isfinite(value) else f"{value:.{digits}f}"

    width = max([24, *(len(row.player) for row in rows)])
    header = (f"{'#':>3}  {'player':<{width}} {'rating':>7} {'low':>7} {'high':>7} {'elo':>7} "
              f"{'races':>5} {'wins':>5} {'score':>6}")
    lines = [header, "-" * len(header)]
    for place, row in enumerate(rows, start=1):
        lines.append(
            f"{place:>3}  {row.player:<{width}} {number(row.rating):>7} {number(row.low):>7} "
            f"{number(row.high):>7} {number(row.elo):>7} {row.races:>5} {row.wins:>5} "
            f"{number(row.score, 3):>6}")
    return "\n".join(lines)


def rank_correlation(x: Sequence[float], y: Sequence[float]) -> float:
    """Spearman's rank correlation: the Pearson correlation of the ranks of ``x`` and ``y``
    (tied values share their mean rank). NaN for fewer than 2 points or a constant input."""
    if len(x) != len(y):
        raise ValueError(f"rank_correlation needs two sequences of one length, got {len(x)} "
                         f"and {len(y)}")
    if len(x) < 2:
        return math.nan

    def ranks(values: Sequence[float]) -> np.ndarray:
        values = np.asarray(values, dtype=np.float64)
        order = np.argsort(values, kind="stable")
        out = np.empty(len(values))
        out[order] = np.arange(1, len(values) + 1)
        for value in np.unique(values):  # ties: the mean of the ranks they span
            tied = values == value
            out[tied] = out[tied].mean()
        return out

    rx, ry = ranks(x), ranks(y)
    rx, ry = rx - rx.mean(), ry - ry.mean()
    norm = math.sqrt(float((rx ** 2).sum() * (ry ** 2).sum()))
    return float((rx * ry).sum() / norm) if norm > 0 else math.nan


@dataclass(frozen=True)
class Trend:
    """How one learner's snapshots are rated against the training steps they were taken at."""

    lineage: str
    snapshots: int
    first: float
    """Mean rating of the first three snapshots [Elo]."""
    last: float
    """Mean rating of the last three snapshots [Elo]."""
    best: str
    """The best-rated snapshot."""
    correlation: float
    """Spearman rank correlation of rating with training steps (+1: every later snapshot is
    rated higher)."""


def rating_trends(snapshots: Iterable[tuple[str, str, float]],
                  ratings: Mapping[str, float]) -> list[Trend]:
    """Trends of snapshot ratings per lineage, from ``(name, lineage, training steps)`` triples
    (snapshots without a rating are left out), lineages in name order."""
    lineages: dict[str, list[tuple[float, float, str]]] = {}
    for name, lineage, steps in snapshots:
        if name in ratings:
            lineages.setdefault(lineage, []).append((steps, ratings[name], name))
    trends = []
    for lineage, rows in sorted(lineages.items()):
        rows.sort()
        values = [rating for _, rating, _ in rows]
        trends.append(Trend(
            lineage=lineage, snapshots=len(rows), first=float(np.mean(values[:3])),
            last=float(np.mean(values[-3:])), best=max(rows, key=lambda r: r[1])[2],
            correlation=rank_correlation([s for s, _, _ in rows], values)))
    return trends


def format_trends(trends: Sequence[Trend]) -> str:
    """Format trends as a text table."""
    lines = [f"{'lineage':<20} {'snapshots':>9} {'first 3':>8} {'last 3':>8} "
             f"{'rank corr':>9}  best", "-" * 72]
    for t in trends:
        corr = "-" if not math.isfinite(t.correlation) else f"{t.correlation:+.2f}"
        lines.append(f"{t.lineage:<20} {t.snapshots:>9} {t.first:>8.0f} {t.last:>8.0f} "
                     f"{corr:>9}  {t.best}")
    return "\n".join(lines)
