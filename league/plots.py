"""League figures as PNG files: ratings over training time and the head-to-head win-rate
matrix.

matplotlib (the ``league`` extra) is imported inside the functions with its non-interactive
Agg backend, so importing this module needs nothing extra and no display is ever opened.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from h2h_racing.common.extras import missing_extra

DPI = 100
"""Dots per inch of the figures: ``size`` in pixels is ``figsize * DPI``."""


def _pyplot() -> Any:
    try:
        import matplotlib
    except ImportError as error:
        raise missing_extra("league", "league plots", error) from error
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _check_size(size: tuple[int, int]) -> tuple[int, int]:
    if (len(size) != 2 or not all(isinstance(v, (int, np.integer)) and v >= 100
                                  for v in size)):
        raise ValueError(f"size must be (width, height) in pixels, each an int >= 100, got "
                         f"{size!r}")
    return int(size[0]), int(size[1])


def _save(fig: Any, path: str | Path) -> Path:
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ValueError(f"plots are written as PNG; give a path ending in .png, got {path}")
    path.parent.mkdir(parents=True, exist_ok=True)
    # No bbox_inches="tight": it would crop the canvas and change the pixel size asked for.
    fig.savefig(path, dpi=DPI, format="png")
    return path


LINE_STYLES = ("-", (0, (6, 3)), (0, (1.5, 2.5)), (0, (8, 3, 2, 3)))
"""Line styles of the rating lines in turn, later lines drawn over earlier ones: players
with the same ratings (two anchors, a snapshot and its copy) draw one line over another,
and a dashed line over a solid one leaves both colours visible."""
MARKERS = ("o", "s", "^", "D", "v", "P")


def plot_ratings(history: Mapping[str, Sequence[tuple[float, float, float, float]]],
                 path: str | Path, xlabel: str = "training steps",
                 size: tuple[int, int] = (900, 540), title: str = "League ratings") -> Path:
    """Plot each player's rating against training time, with its interval as a band.

    Args:
        history: ``{player: [(x, rating, low, high), ...]}``: x is the training time (steps or
            iterations, as ``xlabel`` says), rating and its interval in Elo. NaN bounds draw
            no band at that point. A player with one point is drawn as a marker.
        path: PNG file to write (folders are created).
        xlabel: Label of the x axis.
        size: (width, height) of the image [px].
        title: Figure title.

    Returns:
        ``path``.
    """
    width, height = _check_size(size)
    series: dict[str, np.ndarray] = {}
    for player, points in history.items():
        array = np.asarray(points, dtype=np.float64)
        if array.ndim != 2 or array.shape[1] != 4 or len(array) == 0:
            raise ValueError(f"history[{player!r}] must be a non-empty list of (x, rating, "
                             f"low, high) tuples, got shape {array.shape}")
        series[player] = array[np.argsort(array[:, 0], kind="stable")]
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(width / DPI, height / DPI), dpi=DPI)
    try:
        for k, (player, array) in enumerate(series.items()):
            x, rating, low, high = array.T
            (line,) = ax.plot(x, rating, linestyle=LINE_STYLES[k % len(LINE_STYLES)],
                              marker=MARKERS[k % len(MARKERS)], markersize=4, zorder=2 + k,
                              label=player)
            band = np.isfinite(low) & np.isfinite(high)
            ax.fill_between(x, low, high, where=band, color=line.get_color(), alpha=0.2,
                            linewidth=0)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("rating [Elo]")
        ax.set_title(title)
        ax.grid(alpha=0.3)
        if series:
            ax.legend(loc="best", fontsize="small")
        fig.tight_layout()
        return _save(fig, path)
    finally:
        plt.close(fig)


def plot_standings(ratings: Mapping[str, tuple[float, float, float]], path: str | Path,
                   size: tuple[int, int] | None = None,
                   title: str = "Ratings with 90 % intervals") -> Path:
    """Plot players' ratings as points with their intervals, best at the top: the ratings
    figure of a tournament, whose players did not train (no time axis to draw them over).

    Args:
        ratings: ``{player: (rating, low, high)}`` in Elo; NaN bounds draw no interval.
        path: PNG file to write (folders are created).
        size: (width, height) [px]; None gives 800 x (160 + 28 per player).
        title: Figure title.

    Returns:
        ``path``.
    """
    rows = sorted(((float(r), float(lo), float(hi), name) for name, (r, lo, hi)
                   in ratings.items()), key=lambda row: (-row[0], row[3]))
    if not rows or not all(np.isfinite(row[0]) for row in rows):
        raise ValueError(f"ratings must be a non-empty mapping of finite ratings, got "
                         f"{dict(ratings)!r}")
    width, height = _check_size((800, 160 + 28 * len(rows)) if size is None else size)
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(width / DPI, height / DPI), dpi=DPI, layout="constrained")
    try:
        rating, low, high = (np.array(column) for column in list(zip(*rows))[:3])
        y = np.arange(len(rows))
        known = np.isfinite(low) & np.isfinite(high)
        ax.errorbar(rating[known], y[known], xerr=[rating[known] - low[known],
                                                   high[known] - rating[known]],
                    fmt="none", ecolor="grey", capsize=3)
        ax.plot(rating, y, "o", color="C0")
        ax.set_yticks(y, [row[3] for row in rows])
        ax.invert_yaxis()
        ax.set_xlabel("rating [Elo]")
        ax.grid(axis="x", alpha=0.3)
        fig.suptitle(title)
        return _save(fig, path)
    finally:
        plt.close(fig)


def plot_win_matrix(players: Sequence[str], win_rate: np.ndarray, games: np.ndarray,
                    path: str | Path, size: tuple[int, int] | None = None,
                    title: str = "Head-to-head win rate (row against column)") -> Path:
    """Draw the head-to-head matrix: cell (i, j) is player i's win rate against player j,
    coloured red (0) to green (1) and annotated with the rate and the games played; pairs that
    never met are grey with a dash.

    Args:
        players: Player names, in row (and column) order.
        win_rate: (P, P) win rates in [0, 1] (NaN where no games).
        games: (P, P) games per pair (>= 0).
        path: PNG file to write (folders are created).
        size: (width, height) [px]; None gives a square of 300 + 60 P pixels.
        title: Figure title.

    Returns:
        ``path``.
    """
    names = list(players)
    count = len(names)
    rates = np.asarray(win_rate, dtype=np.float64)
    played = np.asarray(games, dtype=np.float64)
    for label, array in (("win_rate", rates), ("games", played)):
        if array.shape != (count, count):
            raise ValueError(f"{label} must be ({count}, {count}) for {count} players, got "
                             f"shape {array.shape}")
    if np.any(played < 0) or not np.all(np.isfinite(played)):
        raise ValueError("games must be finite and >= 0")
    met = played > 0
    if np.any(met & ~((rates >= 0) & (rates <= 1))):
        raise ValueError("win_rate must lie in [0, 1] wherever games > 0")
    side = 300 + 60 * count
    width, height = _check_size((side, side) if size is None else size)
    plt = _pyplot()
    # Constrained layout with a figure title: an axes title is centred over the matrix
    # alone, and a long one ran into the colour bar beside it.
    fig, ax = plt.subplots(figsize=(width / DPI, height / DPI), dpi=DPI, layout="constrained")
    try:
        cmap = plt.get_cmap("RdYlGn").with_extremes(bad="lightgrey")
        shown = np.ma.masked_array(np.where(met, rates, 0.0), mask=~met)
        image = ax.imshow(shown, cmap=cmap, vmin=0.0, vmax=1.0)
        for i in range(count):
            for j in range(count):
                text = f"{rates[i, j]:.2f}\n({played[i, j]:.0f})" if met[i, j] else "-"
                ax.text(j, i, text, ha="center", va="center", fontsize="small")
        ax.set_xticks(range(count), names, rotation=45, ha="right")
        ax.set_yticks(range(count), names)
        ax.set_xlabel("opponent")
        ax.set_ylabel("player")
        fig.suptitle(title)
        fig.colorbar(image, ax=ax, label="win rate")
        return _save(fig, path)
    finally:
        plt.close(fig)
