"""Rating maths from race results: batch Bradley-Terry on the Elo scale, bootstrap intervals
and sequential Elo (the tables built from them are in :mod:`h2h_racing.league.ratings`).

A race result is a mapping ``{player: place}``: 1 is first, equal places are ties, and a player
that did not finish gets a place after every finisher (``math.inf`` works; non-finishers may
share it). The players of one race are distinct.

Every race is decomposed into pairwise results: in a race of N players each of the
N(N-1)/2 pairs scores 1 for the better place, 0 for the worse and 1/2 each for a tie.

* ``bradley_terry`` is the tournament rating: the maximum-likelihood fit of the Bradley-Terry
  model P(i beats j) = g_i / (g_i + g_j) to all pairwise results at once, reported as
  400 * log10(g_i) (the Elo scale: a 400-point gap means odds of 10 to 1) and shifted so that
  an anchor player sits at a fixed rating. It depends only on the pairwise totals, so the order
  of the races does not matter.
* ``bootstrap_intervals`` gives its uncertainty by refitting on whole races drawn with
  replacement (the pairs of one race are correlated, so races, not pairs, are resampled).
* ``sequential_elo`` is classic Elo, race by race, for a live view; it depends on race order.

Only numpy is used.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

Race = Mapping[str, float]
"""One race: player name -> finishing place (1 = first; equal places tie)."""
ELO_SCALE = 400.0
"""Elo points per factor of 10 in the odds of winning."""


def expected_score(r_a: float, r_b: float) -> float:
    """Elo expected score of a player rated ``r_a`` against one rated ``r_b``.

    E(a, b) = 1 / (1 + 10^((r_b - r_a) / 400)), so E(a, b) + E(b, a) = 1 and a 400-point lead
    gives 10/11.
    """
    return 1.0 / (1.0 + 10.0 ** ((r_b - r_a) / ELO_SCALE))


def _check_race(race: Any, index: int) -> dict[str, float]:
    """Validate one race result and return it as a plain dict."""
    if not isinstance(race, Mapping):
        raise TypeError(f"race {index}: expected a mapping {{player: place}}, got "
                        f"{type(race).__name__}")
    if not race:
        raise ValueError(f"race {index}: no players; a race needs at least one "
                         f"{{player: place}} entry")
    out = {}
    for name, place in race.items():
        if not isinstance(name, str):
            raise TypeError(f"race {index}: player names must be str, got {name!r}")
        if isinstance(place, bool) or not isinstance(place, (int, float, np.integer,
                                                              np.floating)):
            raise TypeError(f"race {index}: place of {name!r} must be a number, got {place!r}")
        if math.isnan(place):
            raise ValueError(f"race {index}: place of {name!r} is NaN; give a number (1 = first, "
                             f"math.inf for a non-finisher)")
        out[name] = float(place)
    return out


def _races(races: Iterable[Race]) -> list[dict[str, float]]:
    """Validate and materialise ``races`` (an iterable may be read only once)."""
    if isinstance(races, Mapping):
        raise TypeError("races must be an iterable of race mappings, got a single mapping; "
                        "wrap one race in a list: [race]")
    return [_check_race(race, i) for i, race in enumerate(races)]


def pair_scores(race: Race) -> list[tuple[str, str, float]]:
    """The pairwise results of one race: ``(a, b, score of a against b)`` for each pair once.

    The better (lower) place scores 1, the worse 0, a tie 1/2 each.
    """
    items = sorted(_check_race(race, 0).items())
    out = []
    for i, (a, place_a) in enumerate(items):
        for b, place_b in items[i + 1:]:
            score = 1.0 if place_a < place_b else 0.0 if place_a > place_b else 0.5
            out.append((a, b, score))
    return out


def pairwise(races: Iterable[Race], players: Sequence[str] | None = None
             ) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Sum the pairwise results of ``races``.

    Args:
        races: Race results ``{player: place}``.
        players: The players and their order; None means every player in ``races``, sorted by
            name. Given players may have no races; a player in ``races`` missing from
            ``players`` is an error.

    Returns:
        ``(players, wins, games)``: ``wins[i, j]`` is the score of player i against player j
        summed over the races (a tie counts 1/2), ``games[i, j]`` the number of races in which
        they met; both (P, P) float64, ``wins + wins.T == games`` and zero diagonals.
    """
    race_list = _races(races)
    names = _players(race_list, players)
    index = {name: i for i, name in enumerate(names)}
    size = len(names)
    wins = np.zeros((size, size))
    games = np.zeros((size, size))
    for race in race_list:
        for a, b, score in pair_scores(race):
            i, j = index[a], index[b]
            wins[i, j] += score
            wins[j, i] += 1.0 - score
            games[i, j] += 1.0
            games[j, i] += 1.0
    return names, wins, games


def _players(races: list[dict[str, float]], players: Sequence[str] | None) -> list[str]:
    seen = sorted({name for race in races for name in race})
    if players is None:
        return seen
    names = list(players)
    if len(set(names)) != len(names):
        raise ValueError(f"players must be distinct, got {names}")
    missing = sorted(set(seen) - set(names))
    if missing:
        raise ValueError(f"players {missing} race in the results but are not in players="
                         f"{names}; add them or pass players=None")
    return names


def bradley_terry(races: Iterable[Race], anchor: str | None = None,
                  anchor_rating: float = 1000.0, prior: float = 1.0,
                  players: Sequence[str] | None = None, tol: float = 1e-10,
                  max_iter: int = 10_000, method: str = "newton") -> dict[str, float]:
    """Batch Bradley-Terry ratings on the Elo scale.

    The model is P(i beats j) = g_i / (g_i + g_j). With W_i the total score of player i and
    n_ij the games of i against j, the log-likelihood
    l = sum_i W_i ln g_i - sum_{i<j} n_ij ln(g_i + g_j) is maximised where
    W_i = sum_j n_ij g_i / (g_i + g_j) for every i, the fixed point of Hunter's (2004)
    minorise-maximise (MM) iteration

        g_i <- W_i / sum_j n_ij / (g_i + g_j),

    which raises the likelihood at every step. MM converges linearly, and slowly when the
    common level is pinned only by a weak prior (over 10,000 iterations for 400 four-car races
    of 8 players with prior 1), so the default ``method="newton"`` takes Newton steps on
    ln g instead (l is concave in ln g), halved until l does not fall; both stop at the same
    fixed point. The rating is 400 * log10(g_i), shifted so that ``anchor`` is at
    ``anchor_rating`` (or the mean rating is, when ``anchor`` is None).

    The prior: every player also plays ``prior`` virtual games against a virtual player fixed at
    g = 1, scoring half of them (``prior / 2`` virtual draws). Without it the fit does not
    exist for an undefeated or winless player (its g runs off to infinity or zero), nor for
    players that never meet the rest (their level is unconnected). The virtual player fixes
    that for every case: all ratings stay finite and a player with no games sits at the
    virtual player's level. It is chosen over one virtual draw per pair that met because that
    would leave separate groups of players unconnected. Its pull is that of ``prior`` draws
    against an average player, negligible once a player has many races. Players in groups
    that never met one another are compared only through the virtual player, so their
    relative ratings say little; ``pairwise`` shows who met whom.

    Args:
        races: Race results ``{player: place}``.
        anchor: Player fixed at ``anchor_rating`` (e.g. a scripted driver); None fixes the mean.
        anchor_rating: Rating of the anchor (or of the mean) [Elo].
        prior: Virtual games of each player against the virtual player (>= 0). With 0 the plain
            maximum-likelihood fit is returned, which needs every player to have beaten and
            lost to (or tied with) someone in one strongly connected group (Hunter's
            condition); otherwise a ValueError says so.
        players: Players to rate (see ``pairwise``); None means everyone in ``races``.
        tol: Stop when no log10 g moves by more than this between iterations.
        max_iter: Iteration limit; reaching it raises RuntimeError.
        method: ``"newton"`` (fast) or ``"mm"`` (Hunter's iteration, for checking).

    Returns:
        ``{player: rating}`` [Elo].
    """
    if not (isinstance(prior, (int, float)) and math.isfinite(prior) and prior >= 0):
        raise ValueError(f"prior must be a finite number >= 0 (virtual games per player), "
                         f"got {prior!r}")
    if not (isinstance(tol, (int, float)) and tol > 0):
        raise ValueError(f"tol must be a number > 0, got {tol!r}")
    if not (isinstance(max_iter, int) and max_iter >= 1):
        raise ValueError(f"max_iter must be an int >= 1, got {max_iter!r}")
    if method not in ("newton", "mm"):
        raise ValueError(f"method must be 'newton' or 'mm', got {method!r}")
    names, wins, games = pairwise(races, players)
    if not names:
        if anchor is not None:
            raise ValueError(f"unknown anchor {anchor!r}: there are no players")
        return {}
    if anchor is not None and anchor not in names:
        raise ValueError(f"unknown anchor {anchor!r}; the players are {names}")
    log_g = _fit_log10_gamma(wins, games, float(prior), tol, max_iter, method)
    ratings = ELO_SCALE * log_g
    shift = anchor_rating - (ratings[names.index(anchor)] if anchor is not None
                             else ratings.mean())
    out = {name: float(r + shift) for name, r in zip(names, ratings)}
    if anchor is not None:
        out[anchor] = float(anchor_rating)  # exactly, not up to rounding of the shift
    return out


def _fit_log10_gamma(wins: np.ndarray, games: np.ndarray, prior: float, tol: float,
                     max_iter: int, method: str) -> np.ndarray:
    """Maximise the likelihood; return log10 g per player, (P,)."""
    if prior == 0.0:
        _check_mle_exists(wins)
    # S_i: score of i, with half of its virtual games against the virtual player.
    score = wins.sum(axis=1) + prior / 2.0
    step_fn = _mm_step if method == "mm" else _newton_step
    theta = np.zeros(len(wins))  # theta = ln g
    for _ in range(max_iter):
        new = step_fn(theta, score, games, prior)
        if prior == 0.0:
            # Without the virtual player g is defined up to a common factor: fix the geometric
            # mean at 1 so the iteration cannot drift.
            new -= new.mean()
        moved = np.max(np.abs(new - theta)) / math.log(10.0) if len(new) else 0.0
        theta = new
        if moved < tol:
            return theta / math.log(10.0)
    raise RuntimeError(f"Bradley-Terry fit did not converge to tol={tol} in max_iter="
                       f"{max_iter} iterations (method={method!r}); raise max_iter or prior "
                       f"(virtual draws keep the fit well conditioned)")


def _log_likelihood(theta: np.ndarray, score: np.ndarray, games: np.ndarray,
                    prior: float) -> float:
    """l(theta) = sum_i S_i theta_i - sum_{i<j} n_ij ln(g_i + g_j) - prior sum_i ln(g_i + 1)."""
    pairs = np.logaddexp(theta[:, None], theta[None, :])
    return float(score @ theta - 0.5 * np.sum(games * pairs)
                 - prior * np.sum(np.logaddexp(theta, 0.0)))


def _mm_step(theta: np.ndarray, score: np.ndarray, games: np.ndarray,
             prior: float) -> np.ndarray:
    """Hunter's MM update g_i <- S_i / (sum_j n_ij / (g_i + g_j) + prior / (g_i + 1))."""
    gamma = np.exp(theta)
    denominator = (games / (gamma[:, None] + gamma[None, :])).sum(axis=1)
    denominator += prior / (gamma + 1.0)
    with np.errstate(divide="ignore"):
        return np.where(denominator > 0, np.log(score) - np.log(denominator), 0.0)


def _newton_step(theta: np.ndarray, score: np.ndarray, games: np.ndarray,
                 prior: float) -> np.ndarray:
    """A Newton step on theta = ln g, halved until the likelihood does not fall.

    With p_ij = g_i / (g_i + g_j) and p_i = g_i / (g_i + 1) (the virtual player):
    gradient_i = S_i - sum_j n_ij p_ij - prior p_i; minus the Hessian is
    A_ii = sum_j n_ij p_ij p_ji + prior p_i (1 - p_i), A_ij = -n_ij p_ij p_ji. A is positive
    definite with a prior; with prior 0 it is a graph Laplacian whose null space is the common
    level, so the all-ones direction is added to make it invertible (the gradient has no
    component along it then: sum_i gradient_i = 0).
    """
    p = 1.0 / (1.0 + np.exp(theta[None, :] - theta[:, None]))
    p_virtual = 1.0 / (1.0 + np.exp(-theta))
    gradient = score - np.sum(games * p, axis=1) - prior * p_virtual
    curvature = games * p * p.T
    a = np.diag(curvature.sum(axis=1) + prior * p_virtual * (1.0 - p_virtual)) - curvature
    if prior == 0.0:
        a += 1.0 / len(theta)
    direction = np.linalg.solve(a, gradient)
    # Accept a step that loses no more than rounding error: at the optimum the likelihood is
    # flat to ~1e-16 relative, and a strict test would reject the last, tiny steps.
    floor = _log_likelihood(theta, score, games, prior)
    floor -= 1e-12 * max(1.0, abs(floor))
    t = 1.0
    while t > 1e-12:
        new = theta + t * direction
        if _log_likelihood(new, score, games, prior) >= floor:
            return new
        t /= 2.0
    return _mm_step(theta, score, games, prior)


def _check_mle_exists(wins: np.ndarray) -> None:
    """Hunter's (2004) condition for prior 0: in the graph with an edge i -> j whenever i
    scored against j, every player reaches every other (one strongly connected group)."""
    size = len(wins)
    if size == 1:
        return
    beat = wins > 0
    for graph in (beat, beat.T):
        reached = np.zeros(size, dtype=bool)
        reached[0] = True
        frontier = reached.copy()
        while frontier.any():
            frontier = graph[frontier].any(axis=0) & ~reached
            reached |= frontier
        if not reached.all():
            raise ValueError("with prior=0 the Bradley-Terry fit does not exist for these "
                             "results: some player never beat (or never lost to) the others, "
                             "or groups of players never met; use prior > 0 (e.g. 1.0)")


def bootstrap_intervals(races: Iterable[Race], n: int = 200, level: float = 0.9,
                        rng: np.random.Generator | None = None,
                        **bt_kwargs: Any) -> dict[str, tuple[float, float]]:
    """Percentile bootstrap intervals of the Bradley-Terry ratings.

    Each of ``n`` resamples draws as many whole races as there are, with replacement, and
    refits with ``bradley_terry(**bt_kwargs)`` over the same players (a player missing from a
    resample is rated by the prior alone). The interval of a player is the
    ((1 - level) / 2, (1 + level) / 2) quantile pair of its refitted ratings. The anchor's
    interval is a single point: the scale is defined relative to it.

    Args:
        races: Race results ``{player: place}``.
        n: Resamples (>= 1).
        level: Coverage in (0, 1), e.g. 0.9 for a 90 % interval.
        rng: Random generator; None makes a fresh unseeded one.
        **bt_kwargs: ``bradley_terry`` arguments (anchor, anchor_rating, prior, tol, max_iter).

    Returns:
        ``{player: (low, high)}`` [Elo].
    """
    if not (isinstance(n, int) and n >= 1):
        raise ValueError(f"n must be an int >= 1 (resamples), got {n!r}")
    if not (isinstance(level, (int, float)) and 0.0 < level < 1.0):
        raise ValueError(f"level must be in (0, 1), e.g. 0.9, got {level!r}")
    if "players" in bt_kwargs:
        raise TypeError("bootstrap_intervals rates every player in races; do not pass players")
    race_list = _races(races)
    if not race_list:
        return {}
    rng = np.random.default_rng() if rng is None else rng
    names = _players(race_list, None)
    samples = np.empty((n, len(names)))
    for k in range(n):
        picks = rng.integers(0, len(race_list), size=len(race_list))
        fit = bradley_terry([race_list[i] for i in picks], players=names, **bt_kwargs)
        samples[k] = [fit[name] for name in names]
    low, high = np.quantile(samples, [(1.0 - level) / 2.0, (1.0 + level) / 2.0], axis=0)
    return {name: (float(lo), float(hi)) for name, lo, hi in zip(names, low, high)}


def elo_history(races: Iterable[Race], k: float = 32.0, initial: float = 1000.0,
                ratings: Mapping[str, float] | None = None) -> list[dict[str, float]]:
    """Sequential Elo after each race: ``history[t]`` holds every rating after race t.

    Per race of N players, each pair (a, b) moves a by (K / (N - 1)) * (S_ab - E(a, b)) with
    E from the ratings before the race, all pairs at once, so one race moves a rating by at
    most K whatever the field size. A new player starts at ``initial``.

    Args:
        races: Race results ``{player: place}``, in the order they were run.
        k: K-factor (> 0) [Elo per race].
        initial: Rating of a player's first race [Elo].
        ratings: Ratings to start from (not modified).
    """
    if not (isinstance(k, (int, float)) and math.isfinite(k) and k > 0):
        raise ValueError(f"k must be a finite number > 0, got {k!r}")
    current = dict(ratings or {})
    history = []
    for race in _races(races):
        for name in race:
            current.setdefault(name, float(initial))
        if len(race) > 1:
            k_pair = k / (len(race) - 1)
            delta = dict.fromkeys(race, 0.0)
            for a, b, score in pair_scores(race):
                change = k_pair * (score - expected_score(current[a], current[b]))
                delta[a] += change
                delta[b] -= change
            for name, d in delta.items():
                current[name] += d
        history.append(dict(current))
    return history


def sequential_elo(races: Iterable[Race], k: float = 32.0, initial: float = 1000.0,
                   ratings: Mapping[str, float] | None = None) -> dict[str, float]:
    """Classic Elo after all ``races`` in order (see ``elo_history`` for the update)."""
    history = elo_history(races, k=k, initial=initial, ratings=ratings)
    return history[-1] if history else dict(ratings or {})
