"""Payoff table, PFSP weights and sampling, and the league's role rules."""

from __future__ import annotations

import json

import numpy as np
import pytest

from h2h_racing.league.pfsp import (
    Payoff,
    PoolEntry,
    _remove_monotonic_suffix,
    choose_opponents,
    pfsp_sample,
    pfsp_weights,
    resets_on_snapshot,
    should_snapshot,
)


def within_binomial(count: int, n: int, p: float, sigmas: float = 4.0) -> bool:
    """Whether ``count`` successes in ``n`` draws are within ``sigmas`` standard deviations
    of n p (sd = sqrt(n p (1 - p)))."""
    return abs(count - n * p) <= sigmas * np.sqrt(n * p * (1 - p)) + 1e-9


def payoff_with(decay: float = 0.99, **results: list[float]) -> Payoff:
    """A payoff table from ``{"X_vs_Y": [scores of X against Y, in order]}``."""
    payoff = Payoff(decay)
    for pair, scores in results.items():
        a, b = pair.split("_vs_")
        for score in scores:
            payoff.update(a, b, score)
    return payoff


class TestPayoff:
    def test_decay_after_two_updates(self) -> None:
        payoff = payoff_with(A_vs_B=[1, 0])
        # games = 0.99 * 1 + 1 = 1.99; score = 0.99 * 1 + 0 = 0.99.
        assert payoff.games("A", "B") == pytest.approx(1.99)
        assert payoff.win_rate("A", "B") == pytest.approx(0.99 / 1.99)
        assert payoff.win_rate("B", "A") == pytest.approx(1.0 / 1.99)

    def test_only_the_updated_pair_decays(self) -> None:
        payoff = payoff_with(A_vs_B=[1, 0])
        payoff.update("C", "A", 0.5)
        payoff.update("B", "C", 1)
        assert payoff.win_rate("A", "B") == pytest.approx(0.99 / 1.99)
        assert payoff.win_rate("A", "C") == 0.5 and payoff.win_rate("C", "B") == 0.0

    def test_unplayed_pairs_and_self_are_even(self) -> None:
        payoff = payoff_with(A_vs_B=[1])
        assert payoff.win_rate("A", "Z") == 0.5 and payoff.win_rate("A", "A") == 0.5
        np.testing.assert_array_equal(payoff.win_rates("A", ["B", "Z"]), [1.0, 0.5])

    def test_from_races_replays_the_pairs_in_order(self) -> None:
        payoff = Payoff.from_races([{"A": 1, "B": 2, "C": 3}, {"C": 1, "B": 2, "A": 3}])
        # Every pair: the first race's winner won, then lost: 0.99 / 1.99 for it.
        for a, b in (("A", "B"), ("A", "C"), ("B", "C")):
            assert payoff.win_rate(a, b) == pytest.approx(0.99 / 1.99)
        assert payoff.players == ["A", "B", "C"]

    def test_round_trip_through_json(self) -> None:
        payoff = payoff_with(decay=0.9, A_vs_B=[1, 0.5], C_vs_A=[1])
        again = Payoff.from_dict(json.loads(json.dumps(payoff.to_dict())))
        assert again.decay == 0.9
        for a, b in (("A", "B"), ("B", "A"), ("A", "C"), ("C", "B")):
            assert again.win_rate(a, b) == payoff.win_rate(a, b)
            assert again.games(a, b) == payoff.games(a, b)

    def test_bad_input(self) -> None:
        with pytest.raises(ValueError, match="score_a must be 1"):
            Payoff().update("A", "B", 2)
        with pytest.raises(ValueError, match="against itself"):
            Payoff().update("A", "A", 1)
        with pytest.raises(ValueError, match="decay must be in"):
            Payoff(decay=0.0)
        with pytest.raises(ValueError, match="not a Payoff dict"):
            Payoff.from_dict({"pairs": []})


class TestWeights:
    # Win rates x = [0, 0.5, 1, 0.25].
    X = np.array([0.0, 0.5, 1.0, 0.25])

    @pytest.mark.parametrize(("weighting", "raw"), [
        ("squared", [1.0, 0.25, 0.0, 0.5625]),        # (1 - x)^2, sum 1.8125
        ("variance", [0.0, 0.25, 0.0, 0.1875]),       # x (1 - x), sum 0.4375
        ("linear", [1.0, 0.5, 0.0, 0.75]),            # 1 - x, sum 2.25
        ("linear_capped", [0.5, 0.5, 0.0, 0.5]),      # min(0.5, 1 - x), sum 1.5
    ])
    def test_each_weighting_by_hand(self, weighting: str, raw: list[float]) -> None:
        expected = np.array(raw) / sum(raw)
        np.testing.assert_allclose(pfsp_weights(self.X, weighting), expected, rtol=1e-12)

    def test_uniform_when_every_weight_vanishes(self) -> None:
        np.testing.assert_allclose(pfsp_weights([1.0, 1.0, 1.0], "squared"), [1 / 3] * 3)
        np.testing.assert_allclose(pfsp_weights([0.0, 1.0], "variance"), [0.5, 0.5])

    def test_bad_input(self) -> None:
        with pytest.raises(ValueError, match=r"unknown PFSP weighting 'hard'; use one of "
                                             r"\['linear', 'linear_capped', 'squared', "
                                             r"'variance'\]"):
            pfsp_weights([0.5], "hard")
        with pytest.raises(ValueError, match=r"must lie in \[0, 1\]"):
            pfsp_weights([1.5])
        with pytest.raises(ValueError, match="non-empty"):
            pfsp_weights([])

    def test_sampling_frequencies_follow_the_weights(self) -> None:
        # squared on x = [0, 0.5, 0.75]: raw (1, 0.25, 0.0625), sum 1.3125.
        probabilities = np.array([1.0, 0.25, 0.0625]) / 1.3125
        n = 20_000
        draws = pfsp_sample(np.random.default_rng(0), ["a", "b", "c"], [0.0, 0.5, 0.75],
                            "squared", size=n)
        for name, p in zip("abc", probabilities):
            assert within_binomial(draws.count(name), n, p)
        one = pfsp_sample(np.random.default_rng(0), ["a", "b"], [1.0, 0.0], "squared")
        assert one == "b"  # a has weight 0


POOL_S = PoolEntry("scripted_s", "scripted")


class TestMainRole:
    N = 4000

    def test_no_pool_means_pure_self_play(self) -> None:
        picks = choose_opponents(np.random.default_rng(0), "L", "main", [], ["L"], Payoff(), 50)
        assert picks == ["L"] * 50

    def test_half_pfsp_over_the_pool_and_the_rest_self_play(self) -> None:
        # The pool holds one scripted driver and nothing to verify against, so the PFSP half
        # (coin < 0.5) picks it and every other branch ends in self-play.
        picks = choose_opponents(np.random.default_rng(1), "L", "main", [POOL_S], ["L"],
                                 Payoff(), self.N)
        assert set(picks) == {"L", "scripted_s"}
        assert within_binomial(picks.count("scripted_s"), self.N, 0.5)

    def test_verification_against_an_exploiter_that_beats_the_main(self) -> None:
        pool = [PoolEntry("X_1", "main_exploiter", parent="X")]
        payoff = payoff_with(L_vs_X_1=[0, 0, 0])  # win rate 0 < 0.3
        picks = choose_opponents(np.random.default_rng(2), "L", "main", pool, ["L"], payoff,
                                 self.N)
        # PFSP (50 %) and verification (15 %) both pick X_1; self-play the other 35 %.
        assert within_binomial(picks.count("X_1"), self.N, 0.65)
        assert picks.count("L") == self.N - picks.count("X_1")

    def test_forgetting_check_over_the_mains_own_snapshots(self) -> None:
        pool = [PoolEntry("L_1", "main", parent="L"), PoolEntry("L_2", "main", parent="L")]
        # Win rate 0.2 against the older, 0.6 against the newer: it rises, so both stay, and
        # the worst (0.2) is under 0.7. squared weights 0.8^2 : 0.4^2 = 0.64 : 0.16, so L_1
        # gets 0.8 of the 50 % PFSP and of the 15 % verification draws: 0.52; L_2 0.13.
        payoff = payoff_with(L_vs_L_1=[1, 0, 0, 0, 0], L_vs_L_2=[1, 1, 1, 0, 0])
        assert payoff.win_rate("L", "L_1") == pytest.approx(0.2, abs=0.01)
        picks = choose_opponents(np.random.default_rng(3), "L", "main", pool, ["L"], payoff,
                                 self.N)
        rates = payoff.win_rates("L", ["L_1", "L_2"])
        share = (1 - rates) ** 2 / ((1 - rates) ** 2).sum()
        assert within_binomial(picks.count("L_1"), self.N, 0.65 * share[0])
        assert within_binomial(picks.count("L"), self.N, 0.35)

    def test_monotonic_suffix(self) -> None:
        names = ["s1", "s2", "s3"]
        # Falling all the way (expected): nothing left to check.
        assert _remove_monotonic_suffix(np.array([0.9, 0.5, 0.2]), names)[1] == []
        # Rises from s1 to s2, then falls: keep up to s2.
        assert _remove_monotonic_suffix(np.array([0.2, 0.6, 0.5]), names)[1] == ["s1", "s2"]
        # Rises at the end: keep everything.
        assert _remove_monotonic_suffix(np.array([0.5, 0.4, 0.6]), names)[1] == names

    def test_a_too_strong_main_gives_a_curriculum_of_its_snapshots(self) -> None:
        # Two mains; L loses every race to M (0 <= 0.3), so instead of self-play against M,
        # PFSP (variance) over M's snapshots, of which only M_1 (x = 0.5) has weight.
        pool = [PoolEntry("M_1", "main", parent="M"), PoolEntry("M_2", "main", parent="M")]
        payoff = payoff_with(L_vs_M=[0, 0], L_vs_M_1=[1, 0], L_vs_M_2=[1, 1])
        picks = choose_opponents(np.random.default_rng(4), "L", "main", pool, ["L", "M"],
                                 payoff, 400)
        assert "M" not in picks and "L" in picks
        assert "M_1" in picks


class TestExploiterRoles:
    POOL = [PoolEntry("M_1", "main", parent="M"), PoolEntry("M_2", "main", parent="M"),
            POOL_S]

    def test_main_exploiter_plays_the_main_while_it_wins_some(self) -> None:
        payoff = payoff_with(X_vs_M=[1, 0, 0])  # 0.99^2 / (1 + 0.99 + 0.99^2) = 0.33 > 0.1
        picks = choose_opponents(np.random.default_rng(0), "X", "main_exploiter", self.POOL,
                                 ["M"], payoff, 100)
        assert picks == ["M"] * 100

    def test_main_exploiter_falls_back_to_the_mains_snapshots(self) -> None:
        # X never beats M (0 <= 0.1): PFSP variance over M_1 (x = 0.5, weight 0.25) and M_2
        # (x = 1, weight 0); the scripted driver is not M's snapshot.
        payoff = payoff_with(X_vs_M=[0], X_vs_M_1=[1, 0], X_vs_M_2=[1])
        payoff.update("X", "scripted_s", 0)
        picks = choose_opponents(np.random.default_rng(0), "X", "main_exploiter", self.POOL,
                                 ["M"], payoff, 100)
        assert picks == ["M_1"] * 100

    def test_league_exploiter_uses_linear_capped_over_the_pool(self) -> None:
        # x: M_1 0 -> 0.5, M_2 1 -> 0, scripted 0.9 -> 0.1 (approximately; decayed counts).
        payoff = payoff_with(Y_vs_M_1=[0], Y_vs_M_2=[1], Y_vs_scripted_s=[1] * 9 + [0])
        rates = payoff.win_rates("Y", ["M_1", "M_2", "scripted_s"])
        weights = np.minimum(0.5, 1 - rates)
        n = 4000
        picks = choose_opponents(np.random.default_rng(5), "Y", "league_exploiter", self.POOL,
                                 ["M"], payoff, n)
        assert "M_2" not in picks and "M" not in picks
        assert within_binomial(picks.count("M_1"), n, weights[0] / weights.sum())

    def test_bad_calls_say_what_is_wrong(self) -> None:
        rng = np.random.default_rng(0)
        with pytest.raises(ValueError, match="unknown learner role 'coach'"):
            choose_opponents(rng, "L", "coach", [], ["L"], Payoff(), 1)
        with pytest.raises(ValueError, match="is in the pool"):
            choose_opponents(rng, "M_1", "league_exploiter", self.POOL, ["M"], Payoff(), 1)
        with pytest.raises(ValueError, match="mains is empty"):
            choose_opponents(rng, "X", "main_exploiter", [], [], Payoff(), 1)
        with pytest.raises(ValueError, match="not in mains"):
            choose_opponents(rng, "L", "main", [], ["M"], Payoff(), 1)
        with pytest.raises(ValueError, match="scripted entry has no parent"):
            PoolEntry("s", "scripted", parent="L")
        with pytest.raises(ValueError, match="role must be one of"):
            PoolEntry("s", "historical", parent="L")


class TestSnapshots:
    def test_snapshot_rule(self) -> None:
        assert should_snapshot(False, True, [0.0])  # forced
        assert not should_snapshot(False, False, [1.0])  # too early
        assert should_snapshot(True, False, [0.8, 0.75])
        assert not should_snapshot(True, False, [0.8, 0.7])  # must beat 0.7, not equal it
        assert should_snapshot(True, False, [])
        assert should_snapshot(True, False, [0.6], threshold=0.5)

    def test_reset_rule(self) -> None:
        rng = np.random.default_rng(0)
        assert all(resets_on_snapshot(rng, "main_exploiter") for _ in range(20))
        assert not any(resets_on_snapshot(rng, "main") for _ in range(20))
        n = 4000
        resets = sum(resets_on_snapshot(rng, "league_exploiter") for _ in range(n))
        assert within_binomial(resets, n, 0.25)
        with pytest.raises(ValueError, match="unknown learner role"):
            resets_on_snapshot(rng, "scripted")
