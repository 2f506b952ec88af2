"""Self-play league: config files, per-copy opponents, a smoke run that resumes."""

from __future__ import annotations

import dataclasses
import io
from pathlib import Path

import numpy as np
import pytest

from h2h_racing.league.config import (REMOVED, LeagueConfig, LearnerSpec, LearnerTraining,
                                      MainRestore, Matchmaking)
from h2h_racing.league.selfplay import League
from h2h_racing.training.vec_env import PoolOpponent
from h2h_racing.policies import make_driver, race_core

LEAGUE_DIR = Path(__file__).resolve().parents[2] / "league"
# The recorded runs' configs (not shipped); they still load, so each run can be repeated,
# except those of runs 7, 15 and 16, whose knobs were removed (REMOVED): they are kept as
# recorded and name the removed knob.
EXPERIMENTS_DIR = Path(__file__).resolve().parents[2] / "experiments" / "league"
RECORDED_WITH_REMOVED_KNOBS = {"mixed.toml": "tracks_per_round",
                               "fading.toml": "imitation_rounds",
                               "annealed.toml": "main_kl_rounds"}


@pytest.mark.parametrize("path", sorted(LEAGUE_DIR.glob("*.toml")) + sorted(
    EXPERIMENTS_DIR.glob("*.toml")), ids=lambda p: f"{p.parent.name}/{p.name}")
def test_league_configs_load(path):
    knob = RECORDED_WITH_REMOVED_KNOBS.get(path.name) if path.parent == EXPERIMENTS_DIR else None
    if knob is not None:
        with pytest.raises(ValueError, match=f"{knob} was removed: "):
            LeagueConfig.from_toml(path)
        return
    config = LeagueConfig.from_toml(path)
    assert any(s.role == "main" for s in config.learners)


def test_flat_keys_name_their_table_and_removed_knobs_say_why(tmp_path):
    old = tmp_path / "old.toml"
    old.write_text('name = "x"\neval_races = 2\nmain_restore_margin = 0.1\n')
    with pytest.raises(ValueError) as err:
        LeagueConfig.from_toml(old)
    assert str(err.value) == (f"{old}: eval_races, main_restore_margin moved into tables: "
                              "eval_races is now [races] eval_races; main_restore_margin is "
                              "now [main_restore] margin")
    old.write_text('name = "x"\nmain_kl_rounds = 80\n')
    with pytest.raises(ValueError, match=r"main_kl_rounds was removed: .*\(run 16\)"):
        LeagueConfig.from_toml(old)
    assert set(REMOVED) == {"tracks_per_round", "imitation_rounds", "main_kl_rounds"}
    old.write_text('name = "x"\n[races]\nlap = 2\n')
    with pytest.raises(ValueError, match=r"\[races\] unknown keys \['lap'\]; allowed keys "
                                         r"are \['eval_races', 'eval_recent', 'laps'"):
        LeagueConfig.from_toml(old)
    old.write_text('name = "x"\n[snapshots]\nmin_rounds = 3\nmax_rounds = 2\n')
    with pytest.raises(ValueError, match=rf"^{old}: \[snapshots\] max_rounds must be an "
                                         r"integer >= min_rounds \(3\), got 2$"):
        LeagueConfig.from_toml(old)


def test_config_errors(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\nlearning_rat = 0.1\n')
    with pytest.raises(ValueError, match=r"unknown keys \['learning_rat'\]"):
        LeagueConfig.from_toml(bad)
    bad.write_text('name = "x"\n[[learners]]\nname = "m"\nrole = "boss"\n')
    with pytest.raises(ValueError, match="role must be one of"):
        LeagueConfig.from_toml(bad)
    bad.write_text("name = \n")
    with pytest.raises(ValueError, match="not valid TOML"):
        LeagueConfig.from_toml(bad)
    with pytest.raises(ValueError, match="at least one learner with role 'main'"):
        LeagueConfig(learners=(LearnerSpec(name="x", role="main_exploiter"),))
    with pytest.raises(ValueError, match="rating_anchor"):
        LeagueConfig(anchors=("pure_pursuit",))
    with pytest.raises(ValueError, match="clash with anchors"):
        LeagueConfig(learners=(LearnerSpec(name="racing_line"),))


def test_anchors_take_driver_settings(tmp_path):
    # Kept as each anchor's player is named (its spec written back), the rating anchor too.
    config = LeagueConfig(anchors=("racing_line:grip_factor=0.70", "blocker:lane=outer"),
                          rating_anchor="racing_line:grip_factor=.7")
    assert config.anchors == ("racing_line:grip_factor=0.7", "blocker:lane=outer")
    assert config.rating_anchor == "racing_line:grip_factor=0.7"
    good = tmp_path / "paced.toml"
    good.write_text('anchors = ["racing_line:grip_factor=0.8", "pure_pursuit"]\n'
                    'rating_anchor = "pure_pursuit"\n')
    assert LeagueConfig.from_toml(good).anchors[0] == "racing_line:grip_factor=0.8"
    for anchors, message in [
            (("racing_line:grip_factor=1.5",), r"LeagueConfig.anchors: racing_line: grip_factor "
                                               r"must be a number in \(0, 1\], got '1.5'"),
            (("racing_line:grp=0.7",), "LeagueConfig.anchors: racing_line: unknown setting 'grp'"),
            (("league_racer:grip_factor=0.7",), "league_racer: a trained policy takes no settings"),
            (("nobody",), "LeagueConfig.anchors: unknown driver 'nobody'")]:
        with pytest.raises(ValueError, match=message):
            LeagueConfig(anchors=anchors)


def test_pool_opponent_drives_each_copy_with_its_driver():
    core = race_core("oval", num_cars=2, num_envs=4)
    specs = ("racing_line", "pure_pursuit", "pure_pursuit", "racing_line")
    pool = PoolOpponent(specs)
    pool.reset(core)
    actions = pool.act(core, 1)
    for name in set(specs):
        driver = make_driver(name)
        driver.reset(core)
        rows = np.array([s == name for s in specs])
        np.testing.assert_array_equal(actions[rows], np.asarray(driver.act(core, 1))[rows])
    with pytest.raises(ValueError, match="3 opponent assignments for 4 env copies"):
        PoolOpponent(specs[:3]).reset(core)


def test_smoke_league_snapshots_rates_and_resumes(tmp_path, capsys):
    config = LeagueConfig.from_toml(LEAGUE_DIR / "smoke.toml")
    one_round = dataclasses.replace(config, max_rounds=1)
    out = io.StringIO()
    league = League(one_round, tmp_path, out=out)
    league.run()
    # [snapshots] max_rounds = 1: both learners are frozen after round 1.
    assert [s.name for s in league.snapshots()] == ["main_v1", "main_exploiter_v1"]
    league.close()
    assert "round 1" in out.getvalue()

    league = League(config, tmp_path, out=out)  # max_rounds = 2: one more round
    league.run()
    store = league.store
    assert store.meta()["round"] == "2"
    snapshots = league.snapshots()
    assert len(snapshots) == 4
    assert all(Path(s.checkpoint).is_file() and s.parent in ("main", "main_exploiter")
               for s in snapshots)
    # Training steps grow: round 2's snapshot of main trained twice as long as round 1's
    # (1 iteration x 8 copies x 8 steps per round).
    steps = {s.name: s.training_steps for s in snapshots}
    assert steps["main_v1"] == 64 and steps["main_v2"] == 128
    # Placement: the 2 anchors against each other (1 pair), and every snapshot against every
    # older frozen player (2 anchors + k - 1 earlier snapshots for the k-th): 1 seed x 2 seat
    # orders each -> 2 (1 + 2 + 3 + 4 + 5) = 30.
    assert store.count_matches(context="league:smoke:placement") == 30
    history = store.rating_history()
    assert history["racing_line"][-1][1] == pytest.approx(1000.0)
    assert set(history) == {"racing_line", "pure_pursuit", *steps}
    # Evaluation races of each round are keyed by round: none is stored twice.
    keys = [m.key for m in store.matches()]
    assert len(keys) == len(set(keys))
    for learner in ("main", "main_exploiter"):
        assert (tmp_path / "learners" / learner / "latest.pt").is_file()
        assert (tmp_path / "learners" / learner / "runner.pt").is_file()
    league.close()

    from h2h_racing.cli.command import main

    capsys.readouterr()
    assert main(["league", "table", "--league", str(tmp_path / "league.sqlite"),
                 "--boot", "10"]) == 0
    # The standings end with the trend of each lineage's snapshot ratings: 2 snapshots each.
    rows = {line.split()[0]: line.split() for line in capsys.readouterr().out.splitlines()[-2:]}
    assert rows["main"][1] == "2" and rows["main"][-1] in ("main_v1", "main_v2")
    assert rows["main_exploiter"][1] == "2"


def test_anchor_share_and_race_rules(tmp_path):
    from h2h_racing.league.pfsp import Payoff

    smoke = LeagueConfig.from_toml(LEAGUE_DIR / "smoke.toml")
    config = dataclasses.replace(smoke, matchmaking=Matchmaking(anchor_share=1.0),
                                 training=dataclasses.replace(smoke.training, rules="race"))
    league = League(config, tmp_path, out=io.StringIO())
    try:
        spec = config.learners[0]
        mains = [s.name for s in config.learners if s.role == "main"]
        names = league._opponents(spec, league._pool(), mains, Payoff.from_races([]))
        # anchor_share = 1: every copy races an anchor.
        assert len(names) == config.training.num_envs and set(names) <= set(config.anchors)
    finally:
        league.close()
    train_config = config.train_config(seed=0)
    rules = train_config.env_config().rules
    # Race rules (penalties, not retirement) with the training episode's lap and time cap.
    assert rules.mode == "race" and rules.laps == 1
    assert rules.off_track_penalty > 0
    with pytest.raises(ValueError, match=r"\[matchmaking\] anchor_share must be a number in"):
        Matchmaking(anchor_share=1.5)
    with pytest.raises(ValueError, match=r"\[training\] rules must be"):
        LearnerTraining(rules="fast")


def test_max_std_reaches_the_learners(tmp_path):
    config = LeagueConfig.from_toml(EXPERIMENTS_DIR / "bounded.toml")
    assert config.training.max_std == 0.5 and config.train_config(seed=0).max_std == 0.5
    # The run configs recorded before the bound existed keep their unbounded std.
    anchored = LeagueConfig.from_toml(EXPERIMENTS_DIR / "anchored.toml")
    assert anchored.training.max_std == float("inf")
    with pytest.raises(ValueError, match="max_std must be a number > 0"):
        LearnerTraining(max_std=0.0)
    # No entropy bonus is allowed (experiments/league/low_noise.toml); a negative one is
    # refused here, before any learner starts.
    assert LeagueConfig.from_toml(EXPERIMENTS_DIR / "low_noise.toml").train_config(
        seed=0).ppo.entropy_coef == 0.0
    with pytest.raises(ValueError, match="entropy_coef must be a number >= 0"):
        LearnerTraining(entropy_coef=-0.1)
    with pytest.raises(ValueError, match="learning_rate must be a number > 0"):
        LearnerTraining(learning_rate=0)


def test_the_ppo_update_size_reaches_the_learners():
    config = LeagueConfig.from_toml(EXPERIMENTS_DIR / "racecraft.toml")
    ppo = config.train_config(seed=0).ppo
    assert (ppo.num_learning_epochs, ppo.num_mini_batches) == (2, 2)
    algorithm = config.train_config(seed=0).rsl_rl_dict()["algorithm"]
    assert (algorithm["num_learning_epochs"], algorithm["num_mini_batches"]) == (2, 2)
    # The earlier runs keep rsl-rl's 4 x 4.
    ppo = LeagueConfig.from_toml(EXPERIMENTS_DIR / "finishing.toml").train_config(seed=0).ppo
    assert (ppo.num_learning_epochs, ppo.num_mini_batches) == (4, 4)
    for name in ("num_learning_epochs", "num_mini_batches"):
        with pytest.raises(ValueError, match=rf"\[training\] {name} must be an integer >= 1"):
            LearnerTraining(**{name: 0})


def test_imitation_term_reaches_the_learners():
    from h2h_racing.league.learners import make_env
    from h2h_racing.training.vec_env import PoolOpponent

    config = LeagueConfig.from_toml(EXPERIMENTS_DIR / "guided.toml")
    train_config = config.train_config(seed=0)
    assert (train_config.imitation.driver, train_config.imitation.coef) == ("racing_line", 2.0)
    assert train_config.rsl_rl_dict()["algorithm"]["class_name"].endswith(":ImitationPPO")
    # The learners' envs give the racing line's actions as the expert group.
    small = dataclasses.replace(train_config, num_envs=2, track="oval")
    env = make_env(small, PoolOpponent(("blocker", "pure_pursuit")))
    assert env.get_observations()["expert"].shape == (2, 2)
    with pytest.raises(ValueError, match=r"\[imitation\] coef keeps PPO's actor near a "
                                         r"scripted driver: name it in driver"):
        dataclasses.replace(config.imitation, driver=None)
    with pytest.raises(ValueError, match=r"\[imitation\] driver must be one of"):
        dataclasses.replace(config.imitation, driver="random")
    with pytest.raises(ValueError, match=r"\[imitation\] coef must be a number >= 0"):
        dataclasses.replace(config.imitation, coef=-2.0)
    # The learners train with PPO: a distillation teacher has no place in a league.
    with pytest.raises(ValueError, match=r"\[imitation\] teacher 'racing_line': a league's "
                                         r"learners train with PPO"):
        dataclasses.replace(config, imitation=dataclasses.replace(
            config.imitation, coef=0.0, driver=None, teacher="racing_line"))


def test_anchor_weighting_favours_the_anchor_the_learner_loses_to(tmp_path):
    from h2h_racing.league.pfsp import Payoff

    smoke = LeagueConfig.from_toml(LEAGUE_DIR / "smoke.toml")
    config = dataclasses.replace(smoke, anchors=("racing_line", "pure_pursuit", "blocker"),
                                 matchmaking=Matchmaking(anchor_share=1.0,
                                                         anchor_weighting="linear"),
                                 training=dataclasses.replace(smoke.training, num_envs=300))
    payoff = Payoff()
    payoff.update("main", "racing_line", 1.0)
    payoff.update("main", "blocker", 0.0)
    league = League(config, tmp_path, out=io.StringIO())
    try:
        spec = next(s for s in config.learners if s.role == "main")
        names = league._opponents(spec, league._pool(), [spec.name], payoff)
    finally:
        league.close()
    # Win rates 1 (racing_line), 1/2 (pure_pursuit, never met), 0 (blocker); linear weights
    # 1 - x = 0, 1/2, 1 -> probabilities 0, 1/3, 2/3. Blocker copies ~ Binomial(300, 2/3):
    # mean 200, sd sqrt(300 * 2/3 * 1/3) = 8.2; 170-230 is beyond 3.5 sd either side.
    assert names.count("racing_line") == 0
    assert 170 < names.count("blocker") < 230
    assert names.count("pure_pursuit") == 300 - names.count("blocker")
    with pytest.raises(ValueError, match="anchor_weighting must be 'uniform' or one of"):
        Matchmaking(anchor_weighting="hardest")


def test_training_under_race_rules_runs():
    from h2h_racing.training.config import TrainConfig
    from h2h_racing.training.train import train

    config = TrainConfig(track="oval", num_cars=2, learners=1, opponent="pure_pursuit",
                         num_envs=4, num_steps_per_env=8, rules="race", eval_every=0)
    runner = train(config, iterations=1)
    assert runner.env.core.config.rules.mode == "race"
    with pytest.raises(ValueError, match="rules must be 'training' or 'race'"):
        TrainConfig(rules="slow")


def test_a_round_trains_on_its_track(tmp_path):
    from h2h_racing.league import learners
    from h2h_racing.league.learners import TrainJob, train_round

    smoke = LeagueConfig.from_toml(LEAGUE_DIR / "smoke.toml")
    config = dataclasses.replace(smoke, tracks=("oval", "kidney", "speedway"),
                                 training=dataclasses.replace(smoke.training,
                                                              iterations_per_round=3))
    job = TrainJob(learner="solo", role="main", folder=str(tmp_path / "solo"), config=config,
                   round=1, track="speedway",
                   opponents=("pure_pursuit",) * config.training.num_envs, reset=False, seed=0)
    stats = train_round(job)
    runner = learners._RUNNERS.pop("solo")[1]
    # The learner's env starts on the first track of the rotation and moves to the round's.
    assert runner.env.track.name == "speedway"
    assert runner.current_learning_iteration == 3
    assert stats["steps"] == 3 * config.training.num_envs * config.training.num_steps_per_env


def _eval_race(round_index, n, main_place, anchor, anchor_place, player="main", behind=True,
               crashes=0):
    """An evaluation race of ``player`` against ``anchor``; ``behind``: ``player`` started on
    the slot behind (its key's ``slots=`` digits say the same)."""
    from h2h_racing.league.store import CarResult, MatchRecord

    context = "league:smoke:eval"
    mine, theirs = (1, 0) if behind else (0, 1)
    cars = (CarResult(seat=0, player=player, position=main_place, finished=True, laps=1,
                      crashes=crashes, grid_slot=mine),
            CarResult(seat=1, player=anchor, position=anchor_place, finished=True, laps=1,
                      grid_slot=theirs))
    return MatchRecord(key=f"{context}:round={round_index}:oval:{player},{anchor}:n={n}"
                           f":slots={mine}{theirs}",
                       track="oval", race_type="head_to_head", laps=1, seed=n, cars=cars,
                       context=context)


def test_the_record_is_the_worst_clean_win_rate_from_behind(tmp_path):
    config = dataclasses.replace(LeagueConfig.from_toml(LEAGUE_DIR / "smoke.toml"),
                                 main_restore=MainRestore(margin=0.2, window=2))
    league = League(config, tmp_path, out=io.StringIO())
    anchors = list(config.anchors)
    assert len(anchors) >= 2
    first, second = anchors[0], anchors[1]
    rest = anchors[2:]
    try:
        results = [
            (first, 1, 2, True, 0),    # won from behind, clean: counts 1 of 1
            (first, 1, 2, True, 1),    # won from behind by causing a crash: 0 of 1
            (first, 2, 1, True, 0),    # lost from behind: 0 of 1
            (first, 1, 2, False, 0),   # won from the front: not in the record
            (second, 1, 2, True, 0),   # 1 of 1
            (second, 2, 1, False, 0),  # lost from the front: not in the record
        ] + [(a, 1, 2, True, 0) for a in rest]
        for n, (anchor, mine, theirs, behind, crashes) in enumerate(results):
            league.store.record_match(_eval_race(1, n, mine, anchor, theirs, behind=behind,
                                                 crashes=crashes))
        # first: 1 clean win of 3 races from behind; second: 1 of 1; record = min = 1/3.
        assert league.record("main", 1) == pytest.approx(1 / 3)
        # Round 3's window (rounds 2-3) holds no race from behind: no record.
        league.store.record_match(_eval_race(3, 0, 1, first, 2, behind=False))
        assert league.record("main", 3) is None
    finally:
        league.close()


def test_main_state_is_kept_at_its_best_and_put_back_when_its_record_falls(tmp_path):
    config = dataclasses.replace(LeagueConfig.from_toml(LEAGUE_DIR / "smoke.toml"),
                                 main_restore=MainRestore(margin=0.2, window=2),
                                 anchors=("racing_line", "pure_pursuit"))
    out = io.StringIO()
    league = League(config, tmp_path, out=out)
    folder = tmp_path / "learners" / "main"
    meta = league.store.meta

    def state(tag):
        for file in ("latest.pt", "runner.pt"):
            (folder / file).write_text(f"{tag} {file}")

    def races(round_index, results):
        for n, (anchor, main_place, anchor_place, *crashes) in enumerate(results):
            league.store.record_match(_eval_race(round_index, n, main_place, anchor,
                                                 anchor_place, crashes=sum(crashes)))

    try:
        state("A")
        races(0, [("racing_line", 1, 2), ("pure_pursuit", 1, 2)])
        # An exploiter's race is not the main's record.
        league.store.record_match(_eval_race(0, 9, 2, "pure_pursuit", 1, "main_exploiter"))
        league._keep_best("main", 0)  # a window of 2 rounds needs round 1
        assert "main.best_record" not in meta() and not (folder / "best").exists()
        races(1, [("racing_line", 1, 2), ("racing_line", 1, 2), ("pure_pursuit", 1, 2),
                  ("pure_pursuit", 1, 2, 1)])
        # Rounds 0-1, every race from behind: racing_line 3 clean wins of 3 = 1;
        # pure_pursuit 2 of 3 (one win caused a crash) -> record 2/3, the first: saved.
        assert league.record("main", 1) == pytest.approx(2 / 3)
        league._keep_best("main", 1)
        assert float(meta()["main.best_record"]) == pytest.approx(2 / 3)
        assert (folder / "best" / "latest.pt").read_text() == "A latest.pt"
        state("B")
        races(2, [("racing_line", 2, 1), ("racing_line", 2, 1), ("pure_pursuit", 2, 1),
                  ("pure_pursuit", 2, 1)])
        # Rounds 1-2: racing_line 2 of 4 = 0.5; pure_pursuit 1 of 4 = 0.25 < 2/3 - 0.2:
        # state A is put back, the learner is rebuilt from it, the next record is judged on
        # rounds 3-4.
        league._keep_best("main", 2)
        assert (folder / "latest.pt").read_text() == "A latest.pt"
        assert (folder / "runner.pt").read_text() == "A runner.pt"
        assert meta()["main.reload"] == "1" and meta()["main.restores"] == "1"
        assert meta()["main.judge_from"] == "4"
        assert "restored its state after round 2" in out.getvalue()
        state("C")
        races(3, [("racing_line", 2, 1), ("pure_pursuit", 2, 1)])
        league._keep_best("main", 3)  # rounds 2-3 mix the old state's races: not judged
        assert (folder / "latest.pt").read_text() == "C latest.pt"
        races(4, [("racing_line", 1, 2), ("racing_line", 1, 2), ("pure_pursuit", 1, 2),
                  ("pure_pursuit", 1, 2), ("pure_pursuit", 2, 1)])
        # Rounds 3-4: racing_line 2 of 3, pure_pursuit 2 of 4 = 0.5: between the best (0.667)
        # and the best minus the margin (0.467), nothing happens.
        league._keep_best("main", 4)
        assert (folder / "best" / "latest.pt").read_text() == "A latest.pt"
        assert meta()["main.restores"] == "1"
        races(5, [("racing_line", 1, 2), ("racing_line", 1, 2), ("racing_line", 1, 2),
                  ("pure_pursuit", 1, 2)])
        # Rounds 4-5: racing_line 5 of 5, pure_pursuit 3 of 4 = 0.75 > 2/3: state C is best.
        league._keep_best("main", 5)
        assert (folder / "best" / "runner.pt").read_text() == "C runner.pt"
        assert meta()["main.best_round"] == "5"
    finally:
        league.close()
    with pytest.raises(ValueError, match=r"\[main_restore\] margin must be a win-rate margin"):
        MainRestore(margin=1.5)
    with pytest.raises(ValueError, match=r"\[main_restore\] window must be an integer >= 1"):
        MainRestore(margin=0.2, window=0)


def test_a_run_finishing_on_best_hands_out_the_mains_best_record_state(tmp_path):
    config = dataclasses.replace(LeagueConfig.from_toml(LEAGUE_DIR / "smoke.toml"),
                                 main_restore=MainRestore(margin=0.2, window=2,
                                                          finish_on_best=True))
    out = io.StringIO()
    league = League(config, tmp_path, out=out)
    folder = tmp_path / "learners" / "main"
    (folder / "best").mkdir(parents=True)
    for file in ("latest.pt", "runner.pt"):
        (folder / "best" / file).write_text(f"A {file}")
        (folder / file).write_text(f"C {file}")
    try:
        # Five rounds done (0-4), more than smoke.toml's max_rounds = 2: run() plays none and
        # only finishes.
        league.store.set_metas({"round": "5", "main.best_round": "4",
                                "main.best_record": "0.8"})
        league.run()  # the last round's state is the best: kept
        assert (folder / "latest.pt").read_text() == "C latest.pt"
        # It only says that nothing is left to train (no "finished main on its best" line).
        assert out.getvalue() == (f"[league smoke] all 2 rounds (max_rounds) of {tmp_path} are "
                                  f"played: nothing to train\n")
        league.store.set_meta("main.best_round", "3")
        league.run()
        assert (folder / "latest.pt").read_text() == "A latest.pt"
        assert (folder / "runner.pt").read_text() == "A runner.pt"
        meta = league.store.meta()
        # A continued run rebuilds the main from A; its next record covers rounds 5 and 6
        # (window 2 after round 4: 4 + 2 = 6).
        assert meta["main.reload"] == "1" and meta["main.judge_from"] == "6"
        assert "main" in out.getvalue() and "after round 4, not round 5" in out.getvalue()
        assert "main_exploiter" not in out.getvalue()
    finally:
        league.close()
    with pytest.raises(ValueError, match="finish_on_best needs margin"):
        MainRestore(margin=None, finish_on_best=True)
    with pytest.raises(ValueError, match="finish_on_best must be true or false"):
        MainRestore(margin=0.2, finish_on_best="yes")


def test_a_reload_rebuilds_the_learner_from_its_saved_state(tmp_path):
    import shutil

    from h2h_racing.league import learners
    from h2h_racing.league.learners import TrainJob, train_round

    smoke = LeagueConfig.from_toml(LEAGUE_DIR / "smoke.toml")
    config = dataclasses.replace(smoke, training=dataclasses.replace(smoke.training,
                                                                     iterations_per_round=2))
    folder = tmp_path / "kept"
    job = TrainJob(learner="kept", role="main", folder=str(folder), config=config, round=0,
                   track="oval", opponents=("pure_pursuit",) * config.training.num_envs,
                   reset=False, seed=0)
    try:
        train_round(job)
        learners.install_pending(folder, 0)  # as the league does once the round is recorded
        first = learners._RUNNERS["kept"][1]
        shutil.copyfile(folder / "runner.pt", tmp_path / "round0.pt")
        train_round(dataclasses.replace(job, round=1))
        learners.install_pending(folder, 1)
        assert learners._RUNNERS["kept"][1] is first  # continued in memory
        after_two = first.current_learning_iteration
        shutil.copyfile(tmp_path / "round0.pt", folder / "runner.pt")  # as a restore does
        train_round(dataclasses.replace(job, round=2, reload=True))
        runner = learners._RUNNERS["kept"][1]
        # Rebuilt from round 0's state, then one round: the iteration count of two rounds,
        # not three.
        assert runner is not first
        assert runner.current_learning_iteration == after_two
    finally:
        learners._RUNNERS.pop("kept", None)
