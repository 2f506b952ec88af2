"""League plots: PNG files of the size asked for, with something drawn on them."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest

pytest.importorskip("matplotlib")

from h2h_racing.league.plots import plot_ratings, plot_win_matrix  # noqa: E402
from h2h_racing.league.ratings import pairwise  # noqa: E402


def read_png(path: Path) -> np.ndarray:
    assert path.is_file() and path.stat().st_size > 0
    image = cv2.imread(str(path))
    assert image is not None, f"cv2 could not read {path}"
    return image


def test_rating_history_is_drawn_at_the_asked_size(tmp_path: Path) -> None:
    history = {
        "main": [(0, 1000, 950, 1050), (100, 1100, 1040, 1160), (200, 1180, 1120, 1240)],
        "scripted": [(0, 1000, 1000, 1000), (200, 1000, 1000, 1000)],
        "snapshot_1": [(100, 1080, math.nan, math.nan)],  # one point, no band
    }
    path = plot_ratings(history, tmp_path / "out" / "ratings.png", xlabel="iterations",
                        size=(640, 400))
    image = read_png(path)
    assert image.shape == (400, 640, 3)
    # Lines and text in several colours, not a blank canvas.
    assert len(np.unique(image.reshape(-1, 3), axis=0)) > 20


def test_win_matrix_default_size_grows_with_players(tmp_path: Path) -> None:
    races = [{"A": 1, "B": 2, "C": 3}, {"B": 1, "A": 2}, {"A": 1, "B": 2}]
    names, wins, games = pairwise(races, players=["A", "B", "C", "D"])
    with np.errstate(invalid="ignore", divide="ignore"):
        rates = wins / games  # NaN where a pair never met (D)
    image = read_png(plot_win_matrix(names, rates, games, tmp_path / "matrix.png"))
    # 300 + 60 * 4 players = 540 px square.
    assert image.shape == (540, 540, 3)
    assert image.std() > 10


def test_bad_input_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"win_rate must be \(2, 2\) for 2 players"):
        plot_win_matrix(["A", "B"], np.zeros((3, 3)), np.ones((2, 2)), tmp_path / "m.png")
    with pytest.raises(ValueError, match="ending in .png"):
        plot_ratings({"A": [(0, 1000, 990, 1010)]}, tmp_path / "r.jpg")
    with pytest.raises(ValueError, match=r"history\['A'\] must be"):
        plot_ratings({"A": [(0, 1000)]}, tmp_path / "r.png")
    assert not list(tmp_path.iterdir())


def test_win_matrix_rows_are_the_best_rated_plus_anchors() -> None:
    from types import SimpleNamespace

    from h2h_racing.league.cli import matrix_players

    races = [{"a": 1, "b": 2}, {"c": 1, "anchor": 2}, {"d": 1, "a": 2}]
    players = {"anchor": SimpleNamespace(kind="scripted")}
    history = {"a": [(0.0, 900.0, 0, 0), (1.0, 1100.0, 0, 0)], "b": [(0.0, 1050.0, 0, 0)],
               "c": [(0.0, 1000.0, 0, 0)], "anchor": [(0.0, 950.0, 0, 0)]}
    # Latest ratings: a 1100, b 1050, c 1000, anchor 950, d none (ranked last). The 2 best
    # are a and b; the scripted anchor is always kept, in its rating order.
    assert matrix_players(races, history, players, 2) == ["a", "b", "anchor"]
    # Without ratings: share of the field beaten per race, summed: a 1 + 0 = 1, b 0, c 1,
    # d 1, anchor 0 -> a, c, d (ties by name), then anchor, b.
    assert matrix_players(races, {}, players, 3) == ["a", "c", "d", "anchor"]
    with pytest.raises(ValueError, match="--players must be >= 2"):
        matrix_players(races, history, players, 1)


def _colour_pixels(image: np.ndarray, rgb: tuple[int, int, int], tolerance: int = 40) -> int:
    bgr = np.array(rgb[::-1], dtype=np.int32)
    return int(np.sum(np.all(np.abs(image.astype(np.int32) - bgr) <= tolerance, axis=-1)))


def test_identical_ratings_leave_every_line_visible(tmp_path: Path) -> None:
    # Two anchors rated the same: drawn solid, the second line would cover the first entirely
    # (its colour left only in the legend's sample, ~40 pixels).
    flat = [(0, 1000, math.nan, math.nan), (500, 1000, math.nan, math.nan)]
    history = {"racing_line": flat, "pure_pursuit": list(flat),
               "main": [(0, 800, math.nan, math.nan), (500, 1200, math.nan, math.nan)]}
    image = read_png(plot_ratings(history, tmp_path / "ratings.png"))
    first, second = (31, 119, 180), (255, 127, 14)  # matplotlib's C0 and C1
    assert _colour_pixels(image, first) > 200, "the first of the identical lines is hidden"
    assert _colour_pixels(image, second) > 200


def test_win_matrix_title_clears_the_colour_bar(tmp_path: Path, monkeypatch) -> None:
    import matplotlib.text

    from h2h_racing.league import plots

    boxes = {}

    def capture(fig, path):
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        title = next(t for t in fig.findobj(matplotlib.text.Text)
                     if t.get_text() == "Head-to-head win rate (row against column)")
        boxes["title"] = title.get_window_extent(renderer)
        boxes["colour bar"] = fig.axes[-1].get_tightbbox(renderer)  # the colour bar's axes
        boxes["figure"] = fig.bbox
        return Path(path)

    monkeypatch.setattr(plots, "_save", capture)
    names = ["racing_line", "pure_pursuit", "blocker"]
    rates = np.array([[np.nan, 1.0, 0.5], [0.0, np.nan, 0.5], [0.5, 0.5, np.nan]])
    games = np.array([[0, 2, 2], [2, 0, 2], [2, 2, 0]])
    plot_win_matrix(names, rates, games, tmp_path / "m.png")
    assert not boxes["title"].overlaps(boxes["colour bar"])
    assert boxes["figure"].contains(boxes["title"].x0, boxes["title"].y0)
    assert boxes["figure"].contains(boxes["title"].x1, boxes["title"].y1)


def test_a_tournament_plots_ranked_intervals_not_a_training_axis(tmp_path: Path) -> None:
    from h2h_racing.cli.command import main
    from h2h_racing.league.store import LeagueStore, Player

    league = tmp_path / "t.sqlite"
    with LeagueStore(league) as store:
        for name in ("racing_line", "pure_pursuit", "blocker"):
            store.add_player(Player(name=name, kind="scripted"))
        store.record_ratings("bradley_terry", {"racing_line": 1000.0, "pure_pursuit": 800.0,
                                               "blocker": 900.0},
                             intervals={"pure_pursuit": (700.0, 900.0),
                                        "blocker": (850.0, 950.0)})
    assert main(["league", "plot", "--league", str(league), "--out", str(tmp_path)]) == 0
    # plot_standings' size for 3 players, 800 x (160 + 28 per player), not plot_ratings' 900
    # x 540 over "training steps".
    assert read_png(tmp_path / "ratings.png").shape == (244, 800, 3)
