"""Opponent choice for league training: AlphaStar's payoff table and prioritised fictitious
self-play (PFSP), scaled down to a racing league.

Everything here is pure: results and a random generator go in, decisions come out. The rules
follow the published pseudocode of AlphaStar (Vinyals et al., Nature 2019, ``multiagent.py``):

* ``Payoff`` holds decayed pairwise win rates: every update of a pair multiplies that pair's
  counts by ``decay`` (0.99) before adding the new result, so old results fade; an unplayed
  pair has win rate 1/2.
* ``pfsp_weights`` turns the learner's win rates x against candidates into sampling
  probabilities f(x) / sum f: ``squared`` (1 - x)^2 favours the opponents it loses to,
  ``variance`` x (1 - x) those it beats half the time, ``linear`` 1 - x, ``linear_capped``
  min(1/2, 1 - x).
* ``choose_opponents`` applies the per-role rules for each env copy, ``should_snapshot`` and
  ``resets_on_snapshot`` the checkpoint rules.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from h2h_racing.league.ratings import pair_scores

ROLES = ("main", "main_exploiter", "league_exploiter", "scripted")
"""Roles of pool entries; the first three are also the learner roles."""
WEIGHTINGS = {
    "squared": lambda x: (1.0 - x) ** 2,
    "variance": lambda x: x * (1.0 - x),
    "linear": lambda x: 1.0 - x,
    "linear_capped": lambda x: np.minimum(0.5, 1.0 - x),
}
"""PFSP weighting functions f(x) of the learner's win rate x against a candidate."""
UNIFORM_BELOW = 1e-10
"""When the weights sum to less than this (the learner beats everyone), sample uniformly."""


class Payoff:
    """Decayed pairwise win rates (AlphaStar's payoff table).

    For each pair it keeps ``games`` and ``score`` (the first player's wins plus half its
    draws). ``update(a, b, s)`` does games <- decay * games + 1 and
    score <- decay * score + s for that pair only, so the win rate score / games weighs a
    result k updates old by decay^k. The table is symmetric: win_rate(b, a) = 1 - win_rate(a, b).

    Args:
        decay: Factor in (0, 1] applied to a pair's counts at each of its updates.
    """

    def __init__(self, decay: float = 0.99) -> None:
        if not (isinstance(decay, (int, float)) and 0.0 < decay <= 1.0):
            raise ValueError(f"Payoff decay must be in (0, 1], e.g. 0.99, got {decay!r}")
        self.decay = float(decay)
        self._pairs: dict[tuple[str, str], list[float]] = {}

    @staticmethod
    def _key(a: str, b: str) -> tuple[tuple[str, str], bool]:
        """The stored key of pair (a, b) and whether it is stored as (b, a)."""
        return ((a, b), False) if a < b else ((b, a), True)

    @property
    def players(self) -> list[str]:
        """Every player with a result, sorted."""
        return sorted({name for pair in self._pairs for name in pair})

    def update(self, a: str, b: str, score_a: float) -> None:
        """Record one result of ``a`` against ``b``: ``score_a`` is 1 (a won), 0.5 or 0."""
        if not (isinstance(a, str) and isinstance(b, str)):
            raise TypeError(f"player names must be str, got {a!r} and {b!r}")
        if a == b:
            raise ValueError(f"a player cannot score against itself ({a!r}); the payoff table "
                             f"holds results between different players")
        if score_a not in (0, 0.5, 1):
            raise ValueError(f"score_a must be 1 (a won), 0.5 (tie) or 0 (b won), got "
                             f"{score_a!r}")
        key, swapped = self._key(a, b)
        counts = self._pairs.setdefault(key, [0.0, 0.0])
        counts[0] = self.decay * counts[0] + 1.0
        counts[1] = self.decay * counts[1] + (1.0 - score_a if swapped else float(score_a))

    def games(self, a: str, b: str) -> float:
        """Decayed number of games between ``a`` and ``b``."""
        counts = self._pairs.get(self._key(a, b)[0])
        return 0.0 if counts is None else counts[0]

    def win_rate(self, a: str, b: str) -> float:
        """Decayed score fraction of ``a`` against ``b``; 1/2 if they never met (or a == b)."""
        key, swapped = self._key(a, b)
        counts = self._pairs.get(key)
        if a == b or counts is None or counts[0] == 0.0:
            return 0.5
        rate = counts[1] / counts[0]
        return 1.0 - rate if swapped else rate

    def win_rates(self, a: str, opponents: Sequence[str]) -> np.ndarray:
        """Win rates of ``a`` against each of ``opponents``, (len(opponents),) float64."""
        return np.array([self.win_rate(a, b) for b in opponents], dtype=np.float64)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready data: ``{"decay": d, "pairs": [{"a", "b", "games", "score_a"}]}``."""
        return {"decay": self.decay,
                "pairs": [{"a": a, "b": b, "games": g, "score_a": s}
                          for (a, b), (g, s) in sorted(self._pairs.items())]}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Payoff:
        """Rebuild a table written by ``to_dict``."""
        try:
            payoff = cls(decay=data["decay"])
            for pair in data["pairs"]:
                a, b, games, score = pair["a"], pair["b"], float(pair["games"]), \
                    float(pair["score_a"])
                if not (0.0 <= score <= games) or a == b:
                    raise ValueError(f"pair {pair}: need a != b and 0 <= score_a <= games")
                key, swapped = cls._key(a, b)
                payoff._pairs[key] = [games, games - score if swapped else score]
        except (KeyError, TypeError) as error:
            raise ValueError(f"not a Payoff dict ({error!r}); expected {{'decay': float, "
                             f"'pairs': [{{'a', 'b', 'games', 'score_a'}}]}} as to_dict "
                             f"writes") from error
        return payoff

    @classmethod
    def from_races(cls, races: Iterable[Mapping[str, float]], decay: float = 0.99) -> Payoff:
        """Replay race results ``{player: place}`` in order, each race as its pairwise results
        (see ``h2h_racing.league.ratings.pair_scores``)."""
        payoff = cls(decay=decay)
        for race in races:
            for a, b, score in pair_scores(race):
                payoff.update(a, b, score)
        return payoff


def pfsp_weights(win_rates: np.ndarray | Sequence[float],
                 weighting: str = "squared") -> np.ndarray:
    """PFSP sampling probabilities f(x_i) / sum_j f(x_j) for win rates x (see ``WEIGHTINGS``).

    When the weights sum to less than 1e-10 (e.g. ``squared`` or ``linear`` against opponents
    all beaten every time) every candidate gets the same probability, as in AlphaStar.

    Args:
        win_rates: The learner's win rate against each candidate, (C,) in [0, 1], C >= 1.
        weighting: A ``WEIGHTINGS`` name.

    Returns:
        Probabilities, (C,) float64, summing to 1.
    """
    if weighting not in WEIGHTINGS:
        raise ValueError(f"unknown PFSP weighting {weighting!r}; use one of "
                         f"{sorted(WEIGHTINGS)}")
    x = np.asarray(win_rates, dtype=np.float64)
    if x.ndim != 1 or x.size == 0:
        raise ValueError(f"win_rates must be a non-empty 1-D array, got shape {x.shape}")
    if not np.all((x >= 0.0) & (x <= 1.0)):
        raise ValueError(f"win rates must lie in [0, 1], got {x.tolist()}")
    weights = WEIGHTINGS[weighting](x)
    total = weights.sum()
    if total < UNIFORM_BELOW:
        return np.full(x.size, 1.0 / x.size)
    return weights / total


def pfsp_sample(rng: np.random.Generator, candidates: Sequence[str],
                win_rates: np.ndarray | Sequence[float], weighting: str = "squared",
                size: int | None = None) -> str | list[str]:
    """Draw one candidate (``size=None``) or a list of ``size`` with ``pfsp_weights``."""
    if len(candidates) != len(win_rates):
        raise ValueError(f"{len(candidates)} candidates but {len(win_rates)} win rates; give "
                         f"one win rate per candidate")
    probabilities = pfsp_weights(win_rates, weighting)
    picks = rng.choice(len(candidates), size=size, p=probabilities)
    if size is None:
        return candidates[int(picks)]
    return [candidates[int(i)] for i in picks]


@dataclass(frozen=True)
class PoolEntry:
    """A frozen player in the league pool."""

    name: str
    role: str
    """Role of the learner the snapshot was taken from, or ``"scripted"`` (see ``ROLES``)."""
    parent: str | None = None
    """Name of the learner the snapshot was taken from; None for scripted drivers."""

    def __post_init__(self) -> None:
        if self.role not in ROLES:
            raise ValueError(f"PoolEntry {self.name!r}: role must be one of {ROLES}, got "
                             f"{self.role!r}")
        if (self.role == "scripted") != (self.parent is None):
            raise ValueError(f"PoolEntry {self.name!r}: a scripted entry has no parent and a "
                             f"snapshot has one (the learner it was taken from); got role "
                             f"{self.role!r} with parent {self.parent!r}")


def _remove_monotonic_suffix(win_rates: np.ndarray, names: list[str]
                             ) -> tuple[np.ndarray, list[str]]:
    """Drop the tail of snapshots (oldest first) over which the win rate never rises.

    Against older snapshots the learner should win more, so win rates falling towards the
    newest are expected; AlphaStar's forgetting check keeps everything up to the last place
    where the win rate rises (an older snapshot beaten less than a newer one).
    """
    for i in range(len(win_rates) - 1, 0, -1):
        if win_rates[i - 1] < win_rates[i]:
            return win_rates[:i + 1], names[:i + 1]
    return win_rates[:0], []


def _main_match(rng: np.random.Generator, learner: str, pool: Sequence[PoolEntry],
                mains: Sequence[str], payoff: Payoff) -> str:
    """AlphaStar's main agent: 50 % PFSP (squared) over the whole pool; else a random main,
    checked by the verification branch 15 % of the time, otherwise (35 %) self-play."""
    coin = rng.random()
    everyone = [entry.name for entry in pool]
    if coin < 0.5 and everyone:
        return pfsp_sample(rng, everyone, payoff.win_rates(learner, everyone), "squared")
    main = mains[rng.integers(len(mains))]
    if coin < 0.65:
        # Verification: past main exploiters that still beat the learner...
        exploiters = [entry.name for entry in pool if entry.role == "main_exploiter"]
        rates = payoff.win_rates(learner, exploiters)
        if exploiters and rates.min() < 0.3:
            return pfsp_sample(rng, exploiters, rates, "squared")
        # ...or forgetting: past snapshots of the main that the learner beats too rarely.
        snapshots = [entry.name for entry in pool if entry.parent == main]
        rates, snapshots = _remove_monotonic_suffix(payoff.win_rates(learner, snapshots),
                                                    snapshots)
        if snapshots and rates.min() < 0.7:
            return pfsp_sample(rng, snapshots, rates, "squared")
    # Self-play against the main; if it is too strong, a curriculum of its snapshots.
    if payoff.win_rate(learner, main) > 0.3:
        return main
    snapshots = [entry.name for entry in pool if entry.parent == main]
    if not snapshots:
        return main
    return pfsp_sample(rng, snapshots, payoff.win_rates(learner, snapshots), "variance")


def _main_exploiter_match(rng: np.random.Generator, learner: str, pool: Sequence[PoolEntry],
                          mains: Sequence[str], payoff: Payoff) -> str:
    """A random current main if the exploiter wins more than 10 % against it, else PFSP
    (variance) over that main's snapshots."""
    main = mains[rng.integers(len(mains))]
    snapshots = [entry.name for entry in pool if entry.parent == main]
    if payoff.win_rate(learner, main) > 0.1 or not snapshots:
        return main
    return pfsp_sample(rng, snapshots, payoff.win_rates(learner, snapshots), "variance")


def _league_exploiter_match(rng: np.random.Generator, learner: str,
                            pool: Sequence[PoolEntry], mains: Sequence[str],
                            payoff: Payoff) -> str:
    """PFSP (linear_capped) over the whole pool (a random main while the pool is empty)."""
    everyone = [entry.name for entry in pool]
    if not everyone:
        return mains[rng.integers(len(mains))]
    return pfsp_sample(rng, everyone, payoff.win_rates(learner, everyone), "linear_capped")


_MATCHERS = {"main": _main_match, "main_exploiter": _main_exploiter_match,
             "league_exploiter": _league_exploiter_match}


def choose_opponents(rng: np.random.Generator, learner: str, role: str,
                     pool: Sequence[PoolEntry], mains: Sequence[str], payoff: Payoff,
                     count: int) -> list[str]:
    """Choose the opponent of ``learner`` in each of ``count`` env copies, by its role.

    * ``main``: with probability 0.5 PFSP (squared) over the whole pool; otherwise a random
      main of ``mains``, and with probability 0.15 (of the total) the verification branch
      first: PFSP (squared) over past main-exploiter snapshots if the learner's worst win rate
      against them is under 0.3, else over the main's own past snapshots (less the tail over
      which its win rate never rises) if the worst of those is under 0.7. Failing those (and
      in the remaining 35 %), self-play against that main if the learner's win rate against
      it is over 0.3 (always so when the main is the learner itself: a player against itself
      scores 1/2), else PFSP (variance) over the main's snapshots. Self-play returns the
      learner's own name.
    * ``main_exploiter``: a random main if the learner's win rate against it is over 0.1,
      else PFSP (variance) over that main's snapshots.
    * ``league_exploiter``: PFSP (linear_capped) over the whole pool.

    When a rule's candidate list is empty the rule falls back to the chosen main.

    Args:
        rng: Random generator (the only source of randomness).
        learner: Name of the learning player.
        role: Its role: ``"main"``, ``"main_exploiter"`` or ``"league_exploiter"``.
        pool: Frozen players (snapshots and scripted drivers), oldest first (the forgetting
            check reads snapshot order).
        mains: Names of the current main learners (the learner itself among them when it is a
            main); not in ``pool``.
        payoff: Decayed win rates.
        count: Env copies (>= 0).

    Returns:
        One opponent name per env copy.
    """
    if role not in _MATCHERS:
        raise ValueError(f"unknown learner role {role!r}; use one of {sorted(_MATCHERS)}")
    if not (isinstance(count, (int, np.integer)) and count >= 0):
        raise ValueError(f"count must be an int >= 0 (env copies), got {count!r}")
    names = [entry.name for entry in pool]
    if len(set(names)) != len(names):
        raise ValueError(f"pool names must be distinct, got {names}")
    if learner in names:
        raise ValueError(f"the learner {learner!r} is in the pool; the pool holds frozen "
                         f"snapshots under their own names")
    if not mains:
        raise ValueError("mains is empty; give the names of the current main learners "
                         "(e.g. [learner] for a league with one main)")
    frozen = sorted(set(mains) & set(names))
    if frozen:
        raise ValueError(f"mains {frozen} are also in the pool; mains are the current learners, "
                         f"the pool their frozen snapshots under other names")
    if role == "main" and learner not in mains:
        raise ValueError(f"learner {learner!r} has role 'main' but is not in mains={list(mains)}")
    matcher = _MATCHERS[role]
    return [matcher(rng, learner, pool, mains, payoff) for _ in range(int(count))]


def should_snapshot(min_iterations_done: bool, forced: bool,
                    win_rates: np.ndarray | Sequence[float], threshold: float = 0.7) -> bool:
    """AlphaStar's checkpoint rule: snapshot when the learner has trained the minimum time
    and beats every opponent it is judged against (win rate > ``threshold``), or always once
    the maximum time is up (``forced``).

    Args:
        min_iterations_done: The minimum training time since the last snapshot has passed.
        forced: The maximum time since the last snapshot has passed.
        win_rates: Win rates against the opponents that count (main and league exploiter: the
            whole pool; main exploiter: the mains). Empty counts as beaten.
        threshold: Win rate to beat, in [0, 1].
    """
    if not 0.0 <= threshold <= 1.0:
        raise ValueError(f"threshold must be in [0, 1], got {threshold!r}")
    if forced:
        return True
    if not min_iterations_done:
        return False
    rates = np.asarray(win_rates, dtype=np.float64)
    return bool(rates.size == 0 or rates.min() > threshold)


RESET_PROBABILITY = {"main": 0.0, "main_exploiter": 1.0, "league_exploiter": 0.25}
"""Probability that a learner of each role goes back to its initial weights at a snapshot."""


def resets_on_snapshot(rng: np.random.Generator, role: str) -> bool:
    """Whether a learner resets to its initial weights after a snapshot: a main exploiter
    always (it hunts the current main's new weaknesses), a league exploiter with probability
    0.25 (it keeps some of what it found), a main never. Draws from ``rng`` only for a league
    exploiter."""
    if role not in RESET_PROBABILITY:
        raise ValueError(f"unknown learner role {role!r}; use one of {sorted(RESET_PROBABILITY)}")
    probability = RESET_PROBABILITY[role]
    if probability in (0.0, 1.0):
        return probability == 1.0
    return bool(rng.random() < probability)
