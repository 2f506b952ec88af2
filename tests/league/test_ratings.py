"""Rating maths: Elo expectation, pairwise decomposition, Bradley-Terry, bootstrap, standings."""

from __future__ import annotations

import math

import numpy as np
import pytest

from h2h_racing.league.ratings import (
    Standing,
    bootstrap_intervals,
    bradley_terry,
    elo_history,
    expected_score,
    format_standings,
    pair_scores,
    pairwise,
    sequential_elo,
    standings,
)

A_WINS, B_WINS = {"A": 1, "B": 2}, {"A": 2, "B": 1}


class TestExpectedScore:
    def test_a_400_point_lead_gives_ten_to_one(self) -> None:
        # 1 / (1 + 10^(-400/400)) = 1 / 1.1 = 10/11
        assert expected_score(1400.0, 1000.0) == pytest.approx(10 / 11)
        assert expected_score(1000.0, 1000.0) == 0.5

    @pytest.mark.parametrize(("a", "b"), [(1000.0, 1000.0), (1234.5, 987.0), (-50.0, 2000.0)])
    def test_the_two_expectations_sum_to_one(self, a: float, b: float) -> None:
        assert expected_score(a, b) + expected_score(b, a) == pytest.approx(1.0, abs=1e-15)


class TestPairwise:
    def test_places_decompose_into_pairs_with_ties_and_non_finishers(self) -> None:
        # A first; B and C tie for second; D and E did not finish (tied at inf).
        race = {"A": 1, "B": 2, "C": 2, "D": math.inf, "E": math.inf}
        names, wins, games = pairwise([race])
        assert names == ["A", "B", "C", "D", "E"]
        a, b, c, d, e = range(5)
        assert wins[a, b] == wins[a, c] == wins[a, d] == 1.0 and wins[b, a] == 0.0
        assert wins[b, c] == wins[c, b] == 0.5 and wins[d, e] == wins[e, d] == 0.5
        assert wins[b, d] == 1.0 and wins[d, c] == 0.0
        # 5 players: every off-diagonal pair met once.
        np.testing.assert_array_equal(games, 1.0 - np.eye(5))
        np.testing.assert_array_equal(wins + wins.T, games)

    def test_sums_over_races_in_the_given_player_order(self) -> None:
        names, wins, games = pairwise([A_WINS, A_WINS, B_WINS], players=["B", "A", "C"])
        assert names == ["B", "A", "C"]
        assert wins[1, 0] == 2.0 and wins[0, 1] == 1.0 and games[0, 1] == 3.0
        assert games[2].sum() == 0.0

    def test_pair_scores_lists_each_pair_once(self) -> None:
        assert pair_scores({"C": 1, "A": 3, "B": 2}) == [("A", "B", 0.0), ("A", "C", 0.0),
                                                        ("B", "C", 0.0)]

    def test_bad_races_say_what_is_wrong(self) -> None:
        with pytest.raises(ValueError, match="race 1: place of 'B' is NaN"):
            pairwise([A_WINS, {"A": 1, "B": math.nan}])
        with pytest.raises(ValueError, match="race 0: no players"):
            pairwise([{}])
        with pytest.raises(TypeError, match="single mapping"):
            pairwise(A_WINS)
        with pytest.raises(ValueError, match=r"players \['B'\] race in the results"):
            pairwise([A_WINS], players=["A"])


class TestBradleyTerry:
    def test_three_wins_in_four_is_a_gamma_ratio_of_three(self) -> None:
        races = [A_WINS, A_WINS, A_WINS, B_WINS]
        # MLE with no prior: g_A / g_B = 3 / 1, so 400 * log10(3) = 190.849 Elo apart.
        ratings = bradley_terry(races, anchor="B", prior=0.0)
        assert ratings["B"] == 1000.0
        assert ratings["A"] == pytest.approx(1000.0 + 190.849, abs=1e-3)
        centred = bradley_terry(races, prior=0.0)
        assert centred["A"] == pytest.approx(1000.0 + 190.849 / 2, abs=1e-3)
        assert centred["B"] == pytest.approx(1000.0 - 190.849 / 2, abs=1e-3)

    def test_three_players_whose_results_agree_with_gammas_4_2_1(self) -> None:
        # A-B 2:1, B-C 2:1, A-C 4:1 match g = (4, 2, 1) pair by pair, so they solve every
        # likelihood equation: A - C = 400 log10 4 = 240.82, A - B = B - C = 120.41.
        races = ([A_WINS] * 2 + [B_WINS] + [{"B": 1, "C": 2}] * 2 + [{"C": 1, "B": 2}]
                 + [{"A": 1, "C": 2}] * 4 + [{"C": 1, "A": 2}])
        ratings = bradley_terry(races, anchor="C", anchor_rating=0.0, prior=0.0)
        assert ratings["A"] == pytest.approx(240.824, abs=1e-3)
        assert ratings["B"] == pytest.approx(120.412, abs=1e-3)

    def test_the_prior_keeps_an_undefeated_player_finite(self) -> None:
        races = [A_WINS] * 3
        with pytest.raises(ValueError, match="prior > 0"):
            bradley_terry(races, prior=0.0)
        ratings = bradley_terry(races, anchor_rating=0.0, prior=1.0)
        # Mirror symmetry (swap A and B, wins and losses) gives g_B = 1 / g_A, so the mean is
        # the virtual player's level and the centred ratings are the internal ones. The
        # likelihood equation of A with S_A = 3 + 1/2 virtual draws:
        #   3.5 = 3 g_A / (g_A + g_B) + g_A / (g_A + 1).
        g_a, g_b = (10 ** (ratings[p] / 400) for p in "AB")
        assert g_a * g_b == pytest.approx(1.0)
        assert 3 * g_a / (g_a + g_b) + g_a / (g_a + 1) == pytest.approx(3.5, abs=1e-9)
        assert 0 < ratings["A"] < 1000

    def test_newton_and_hunters_mm_reach_the_same_fixed_point(self) -> None:
        rng = np.random.default_rng(3)
        races = [dict(zip(rng.permutation(list("ABCDE"))[:3], (1, 2, 3))) for _ in range(40)]
        newton = bradley_terry(races, anchor="A", prior=1.0)
        mm = bradley_terry(races, anchor="A", prior=1.0, method="mm", tol=1e-12,
                           max_iter=200_000)
        for name in "ABCDE":
            assert newton[name] == pytest.approx(mm[name], abs=1e-6)

    def test_the_fit_does_not_depend_on_race_order(self) -> None:
        rng = np.random.default_rng(0)
        races = [dict(zip(rng.permutation(list("ABCD")), (1, 2, 3, 4))) for _ in range(30)]
        shuffled = [races[i] for i in rng.permutation(len(races))]
        first = bradley_terry(races, anchor="A")
        second = bradley_terry(shuffled, anchor="A")
        for name in "ABCD":
            assert first[name] == pytest.approx(second[name], abs=1e-9)

    def test_anchor_and_unknown_anchor(self) -> None:
        races = [A_WINS, {"B": 1, "C": 2}, {"C": 1, "A": 2}]
        assert bradley_terry(races, anchor="C", anchor_rating=1500.0)["C"] == 1500.0
        ratings = bradley_terry(races)
        assert np.mean(list(ratings.values())) == pytest.approx(1000.0)
        with pytest.raises(ValueError, match=r"unknown anchor 'Z'; the players are \['A', 'B', "
                                             r"'C'\]"):
            bradley_terry(races, anchor="Z")

    def test_separate_groups_and_players_without_races_stay_finite(self) -> None:
        ratings = bradley_terry([A_WINS, {"C": 1, "D": 2}], players=list("ABCDE"),
                                anchor_rating=0.0)
        # Each group is the mirror case above (g_winner = 1 / g_loser) and E, with no races,
        # sits at the virtual player's level g = 1; so the mean is 0 and E is at 0.
        assert ratings["E"] == pytest.approx(0.0, abs=1e-9)
        assert ratings["A"] == pytest.approx(-ratings["B"])
        assert ratings["A"] == pytest.approx(ratings["C"])
        assert all(math.isfinite(r) for r in ratings.values())

    def test_bad_arguments(self) -> None:
        with pytest.raises(ValueError, match="prior must be"):
            bradley_terry([A_WINS], prior=-1.0)
        with pytest.raises(ValueError, match="method must be"):
            bradley_terry([A_WINS], method="gradient")
        with pytest.raises(RuntimeError, match="did not converge"):
            bradley_terry([A_WINS] * 3 + [B_WINS], method="mm", max_iter=2)


class TestBootstrap:
    def test_intervals_hold_the_estimate_and_narrow_with_more_races(self) -> None:
        block = [A_WINS, A_WINS, A_WINS, B_WINS, {"A": 1, "S": 2}, {"S": 1, "B": 2},
                 {"B": 1, "S": 2}]
        few, many = block * 3, block * 30
        widths = []
        for races in (few, many):
            ratings = bradley_terry(races, anchor="S")
            intervals = bootstrap_intervals(races, n=100, rng=np.random.default_rng(1),
                                            anchor="S")
            assert intervals["S"] == (1000.0, 1000.0)  # the anchor defines the scale
            for name in "AB":
                low, high = intervals[name]
                assert low <= ratings[name] <= high
            widths.append(intervals["A"][1] - intervals["A"][0])
        # Ten times the races: the standard error shrinks ~sqrt(10) = 3.2 times; ask for 2.
        assert widths[1] < widths[0] / 2

    def test_a_seed_gives_the_same_intervals(self) -> None:
        races = [A_WINS, B_WINS, A_WINS, {"A": 1, "B": 2, "C": 3}]
        first = bootstrap_intervals(races, n=20, rng=np.random.default_rng(7))
        assert bootstrap_intervals(races, n=20, rng=np.random.default_rng(7)) == first
        with pytest.raises(ValueError, match="level must be"):
            bootstrap_intervals(races, level=90)


class TestSequentialElo:
    def test_one_update_by_hand_and_order_dependence(self) -> None:
        # Race 1 from 1000 each: E = 0.5, so A += 32 * 0.5 = 16 and B -= 16.
        # Race 2, B (984) beats A (1016): E_B = 1 / (1 + 10^(32/400)) = 1 / 2.202264 = 0.454078,
        # B += 32 * (1 - 0.454078) = 17.4695.
        ratings = sequential_elo([A_WINS, B_WINS])
        assert ratings["B"] == pytest.approx(984.0 + 17.4695, abs=1e-3)
        assert ratings["A"] == pytest.approx(1016.0 - 17.4695, abs=1e-3)
        reversed_order = sequential_elo([B_WINS, A_WINS])
        assert reversed_order["A"] == pytest.approx(ratings["B"], abs=1e-9)
        assert reversed_order["A"] != pytest.approx(ratings["A"], abs=1.0)
        # Bradley-Terry on the same two races does not care about the order.
        assert bradley_terry([A_WINS, B_WINS]) == bradley_terry([B_WINS, A_WINS])

    def test_three_cars_share_k_over_n_minus_one_from_pre_race_ratings(self) -> None:
        start = {"A": 1200.0, "B": 1000.0, "C": 1000.0}
        # K / (N - 1) = 32 / 2 = 16 per pair. E(A, B) = E(A, C) = 1 / (1 + 10^-0.5) = 0.759747.
        # A last:  2 * 16 * (0 - 0.759747)                = -24.3119
        # B 2nd:   16 * (1 - 0.240253) + 16 * (0 - 0.5)   = +4.1560
        # C first: 16 * (1 - 0.240253) + 16 * (1 - 0.5)   = +20.1560
        ratings = sequential_elo([{"C": 1, "B": 2, "A": 3}], ratings=start)
        assert ratings["A"] == pytest.approx(1200.0 - 24.3119, abs=1e-3)
        assert ratings["B"] == pytest.approx(1000.0 + 4.1560, abs=1e-3)
        assert ratings["C"] == pytest.approx(1000.0 + 20.1560, abs=1e-3)
        assert start["A"] == 1200.0  # not modified

    def test_history_has_one_entry_per_race_and_new_players_start_at_initial(self) -> None:
        history = elo_history([A_WINS, {"A": 1, "C": 2}], initial=1500.0)
        assert len(history) == 2 and "C" not in history[0]
        assert history[0]["A"] == 1516.0
        # C enters at 1500 against A at 1516: C -= 32 * E(C loses) = 32 / (1 + 10^(16/400)).
        assert history[1]["C"] == pytest.approx(1500.0 - 32.0 / (1.0 + 10 ** (16 / 400)))


class TestStandings:
    def test_rows_count_races_wins_and_pairwise_score(self) -> None:
        races = [{"A": 1, "B": 2, "S": 3}, {"B": 1, "A": 2, "S": 3}, {"A": 1, "S": 2}]
        rows = standings(races, anchor="S", n_boot=20, rng=np.random.default_rng(0))
        # A and B split their meeting and both always beat S, but A beat S once more.
        assert [row.player for row in rows] == ["A", "B", "S"]
        a, b, s = rows
        # A: pairs 1+1, 0+1, 1 -> 4 of 5; B: 0+1, 1+1 -> 3 of 4; S: 0 of 5.
        assert (a.races, a.wins, a.score) == (3, 2, pytest.approx(0.8))
        assert (b.races, b.wins, b.score) == (2, 1, pytest.approx(0.75))
        assert (s.races, s.wins, s.score) == (3, 0, 0.0)
        assert s.rating == s.low == s.high == 1000.0
        assert a.low <= a.rating <= a.high
        table = format_standings(rows)
        lines = table.splitlines()
        assert lines[0].split() == ["#", "player", "rating", "low", "high", "elo", "races",
                                    "wins", "score"]
        assert lines[2].split()[:3] == ["1", "A", f"{a.rating:.0f}"]
        assert len(lines) == 2 + 3

    def test_without_bootstrap_the_bounds_are_blank(self) -> None:
        rows = standings([A_WINS], anchor=None, n_boot=0)
        assert math.isnan(rows[0].low)
        assert isinstance(rows[0], Standing)
        assert format_standings(rows).splitlines()[2].split()[3] == "-"


class TestTrends:
    """Spearman rank correlation and per-lineage snapshot trends."""

    def test_rank_correlation_hand_cases(self) -> None:
        from h2h_racing.league.ratings import rank_correlation

        # Ranks of y: 1, 2, 4, 3; d = 0, 0, 1, 1; rho = 1 - 6 * 2 / (4 * (16 - 1)) = 0.8.
        assert rank_correlation([1, 2, 3, 4], [10, 20, 40, 30]) == pytest.approx(0.8)
        assert rank_correlation([1, 2, 3], [3, 2, 1]) == pytest.approx(-1.0)
        # Ties share the mean rank: y ranks 1.5, 1.5, 3; centred x -1, 0, 1 and y -0.5, -0.5, 1;
        # rho = 1.5 / sqrt(2 * 1.5) = 0.866.
        assert rank_correlation([1, 2, 3], [5, 5, 6]) == pytest.approx(1.5 / math.sqrt(3.0))
        assert math.isnan(rank_correlation([1], [2]))
        assert math.isnan(rank_correlation([1, 2], [7, 7]))
        with pytest.raises(ValueError, match="one length"):
            rank_correlation([1, 2], [1])

    def test_rating_trends_per_lineage(self) -> None:
        from h2h_racing.league.ratings import rating_trends

        snapshots = [("a_v1", "a", 100), ("a_v3", "a", 300), ("a_v2", "a", 200),
                     ("a_v4", "a", 400), ("b_v1", "b", 100), ("b_v2", "b", 200),
                     ("c_v1", "c", 50)]
        ratings = {"a_v1": 900, "a_v2": 950, "a_v3": 1000, "a_v4": 1100, "b_v1": 1000,
                   "b_v2": 980}  # c_v1 unrated: left out
        a, b = rating_trends(snapshots, ratings)
        # Ordered by steps: 900, 950, 1000, 1100: first 3 mean 950, last 3 mean 1016.7.
        assert (a.lineage, a.snapshots, a.best) == ("a", 4, "a_v4")
        assert a.first == pytest.approx(950.0) and a.last == pytest.approx(3050 / 3)
        assert a.correlation == pytest.approx(1.0)
        assert (b.lineage, b.best) == ("b", "b_v1") and b.correlation == pytest.approx(-1.0)
