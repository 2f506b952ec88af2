"""A league run a user can watch and stop (issue 37), in process: the display's line, a round
that stops after its running iteration, the command line that resumes, player names of league
files, and the one ratings table behind `league table`, `league train` and `league plot`.

The same behaviour through the command line, with real processes and signals, is in
``test_league_cli_runs.py``.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import shutil
import time
from pathlib import Path

import pytest

from h2h_racing.league.config import LeagueConfig
from h2h_racing.league.display import LeagueDisplay

LEAGUE_DIR = Path(__file__).resolve().parents[2] / "league"


# ------------------------------------------------------------------ the display (point 1, 4)


def test_the_line_shows_the_budget_the_phase_and_its_count_never_100_before_the_end(tmp_path):
    """Before: the bar read `round 1/1000` (the default round cap, which never ends a run)
    and reached 100 % with the budget while the round that crossed it went on."""
    out = io.StringIO()
    display = LeagueDisplay("x", tmp_path, budget=60.0, used=59.9, max_rounds=1000,
                            show_cap=False, stream=out)
    done = [3]
    display.phase(0, "train", lambda: (done[0], 90), "iterations")
    display.draw()
    # 59.9 s of a 60 s budget is 99.8 % of it: shown as 99 % while the run goes on.
    assert out.getvalue().splitlines()[-1].startswith("league  99% |")
    assert "round 1, train 3/90 iterations" in out.getvalue()
    assert "1000" not in out.getvalue()
    time.sleep(0.2)  # past the budget: still 99 %, no ETA left to show but 0:00
    done[0] = 4
    display.draw(force=True)
    assert display.fraction() == 0.99 and display.left() == 0.0
    display.close(finished=False, rounds_done=0)
    assert "100%" not in out.getvalue()
    assert out.getvalue().splitlines()[-1].startswith("league  99% |")
    assert "round 1, stopped" in out.getvalue().splitlines()[-1]

    finished = io.StringIO()
    display = LeagueDisplay("x", tmp_path, budget=600.0, used=0.0, max_rounds=4,
                            show_cap=True, stream=finished)
    display.phase(3, "place", lambda: (1, 2), "races", rounds_done=3)
    display.draw(force=True)
    # 3 of 4 rounds done is the nearer limit: 75 %.
    assert "league  75% |" in finished.getvalue() and "round 4 of 4, place 1/2 races" in \
        finished.getvalue()
    display.close(finished=True, rounds_done=4)
    assert finished.getvalue().splitlines()[-1].startswith("league 100% |")
    assert "round 4 of 4, done" in finished.getvalue().splitlines()[-1]


def test_a_league_without_a_round_cap_does_not_show_one(tmp_path):
    from h2h_racing.league.selfplay import League

    config = LeagueConfig.from_toml(LEAGUE_DIR / "recommended.toml")  # sets no max_rounds
    league = League(config, tmp_path, out=io.StringIO())
    try:
        assert league.display.info() == "round 1, starting"
        assert league.display.budget == 60.0 * config.minutes
    finally:
        league.close()
    smoke = LeagueConfig.from_toml(LEAGUE_DIR / "smoke.toml")  # max_rounds = 2
    league = League(smoke, tmp_path / "smoke", out=io.StringIO())
    try:
        assert league.display.info() == "round 1 of 2, starting"
    finally:
        league.close()


def test_the_log_keeps_every_line_said_with_its_time(tmp_path):
    display = LeagueDisplay("x", tmp_path, budget=60.0, used=0.0, max_rounds=1000,
                            show_cap=False, mode="off", stream=io.StringIO())
    display.say("[league x] round 1  first\n  second line")
    lines = (tmp_path / "league.log").read_text().splitlines()
    assert len(lines) == 2
    assert lines[0].endswith("  [league x] round 1  first") and lines[1].endswith("    second line")
    assert lines[0][:4].isdigit() and lines[0][4] == "-"  # 2026-11-27 10:36:52


# ------------------------------------------------------------ a round that stops (point 3, 4)


torch = pytest.importorskip("torch")


def _job(tmp_path, iterations, **kwargs):
    from h2h_racing.league.learners import TrainJob

    smoke = LeagueConfig.from_toml(LEAGUE_DIR / "smoke.toml")
    config = dataclasses.replace(smoke, training=dataclasses.replace(
        smoke.training, iterations_per_round=iterations))
    folder = tmp_path / "solo"
    folder.mkdir(exist_ok=True)
    return TrainJob(learner=f"solo-{tmp_path.name}", role="main", folder=str(folder),
                    config=config, round=0, track="oval",
                    opponents=("pure_pursuit",) * config.training.num_envs, reset=False, seed=0,
                    **kwargs)


def test_a_round_stops_after_the_running_iteration_and_keeps_it(tmp_path, monkeypatch):
    """Before: a round ran all its iterations whatever happened (a Ctrl-C was a
    KeyboardInterrupt anywhere in it; the budget was checked between rounds)."""
    from h2h_racing.league import learners

    stop = tmp_path / "stop-requested"
    job = _job(tmp_path, 50, stop_file=str(stop))
    written = learners.write_progress

    def progress(folder, round_index, done, total):
        written(folder, round_index, done, total)
        if done == 2:
            stop.touch()  # a Ctrl-C during iteration 2 of 50

    monkeypatch.setattr(learners, "write_progress", progress)
    try:
        stats = learners.train_round(job)
        runner = learners._RUNNERS[job.learner][1]
    finally:
        learners._RUNNERS.pop(job.learner, None)
    envs, steps = job.config.training.num_envs, job.config.training.num_steps_per_env
    assert stats["iterations"] == 2 and stats["steps"] == 2 * envs * steps
    assert runner.current_learning_iteration == 2
    pending = learners.pending_folder(Path(job.folder), 0)
    assert torch.load(pending / "runner.pt", weights_only=False)["iter"] == 2
    assert learners.read_progress(Path(job.folder), 0) == 2
    assert learners.read_progress(Path(job.folder), 1) == 0  # another round's count: none


def test_a_round_asked_to_stop_before_it_starts_trains_nothing(tmp_path):
    from h2h_racing.league import learners

    (tmp_path / "stop-requested").touch()
    for job in (_job(tmp_path, 5, stop_file=str(tmp_path / "stop-requested")),
                _job(tmp_path, 5, deadline=time.time() - 1.0)):  # the budget is spent
        assert learners.train_round(job) == {"steps": 0.0, "seconds": 0.0, "iterations": 0.0}
        assert not (Path(job.folder) / "pending").exists()
        assert job.learner not in learners._RUNNERS


def test_one_learn_call_per_iteration_trains_as_one_call_for_all(tmp_path):
    """The league now calls rsl-rl's learn() once per iteration (to stop between them); the
    weights, optimiser and normaliser after 3 iterations are the same, bit for bit."""
    from rsl_rl.runners import OnPolicyRunner

    from h2h_racing.league.learners import make_env
    from h2h_racing.training.policy_file import load_init
    from h2h_racing.training.vec_env import PoolOpponent

    job = _job(tmp_path, 3)
    config = dataclasses.replace(job.config.train_config(0), track="oval")

    def trained(calls):
        torch.manual_seed(0)
        env = make_env(config, PoolOpponent(job.opponents, seed=0))
        with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl prints the model
            runner = OnPolicyRunner(env, config.rsl_rl_dict(), log_dir=None, device="cpu")
        load_init(runner, job.config.init)
        for iterations in calls:
            runner.learn(iterations)
            runner.current_learning_iteration += 1
        return runner.alg.save(), runner.current_learning_iteration

    (one, it_one), (three, it_three) = trained([3]), trained([1, 1, 1])
    assert it_one == it_three == 3

    def same(a, b):
        if isinstance(a, dict):
            assert a.keys() == b.keys()
            for key in a:
                same(a[key], b[key])
        elif isinstance(a, torch.Tensor):
            assert torch.equal(a, b)
        elif isinstance(a, (list, tuple)):
            assert len(a) == len(b)
            for x, y in zip(a, b):
                same(x, y)
        else:
            assert a == b

    same(one, three)


# ---------------------------------------------------------------- the resume command (point 3)


def test_the_first_ctrl_c_asks_for_a_stop_and_raises_nothing(tmp_path):
    """Before: Ctrl-C was a KeyboardInterrupt wherever the command was (a traceback)."""
    import os
    import signal

    from h2h_racing.league.stopping import StopSwitch

    before = signal.getsignal(signal.SIGINT)
    file = tmp_path / "stop-requested"
    file.write_text("left by a killed run")
    switch = StopSwitch(file).install()
    try:
        assert not file.exists()  # a stale request does not stop the new run
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.1)  # the handler runs between two bytecodes of the main thread
        assert switch.requested and switch.presses == 1 and file.exists()
    finally:
        switch.uninstall()
    assert signal.getsignal(signal.SIGINT) is before and not file.exists()



def test_the_resume_command_writes_back_every_option_that_is_not_its_default():
    from h2h_racing.league.stopping import resume_command

    parser = argparse.ArgumentParser()
    parser.add_argument("--players", type=lambda t: tuple(t.split(",")), required=True)
    parser.add_argument("--races", type=int, default=2)
    parser.add_argument("--league", default="runs/league.sqlite")
    parser.add_argument("--this-run", action="store_true")
    parser.add_argument("--progress", action=argparse.BooleanOptionalAction, default=True)
    parser.add_argument("--name", default="default")
    args = parser.parse_args(["--players", "racing_line,my policy.pt", "--races", "4",
                              "--this-run", "--no-progress"])
    assert resume_command(args, parser, ("tournament",)) == (
        "h2h-racing tournament --players 'racing_line,my policy.pt' --races 4 --this-run")
    assert resume_command(args, parser, ("t",), {"this_run": False, "name": "x"}) == (
        "h2h-racing t --players 'racing_line,my policy.pt' --races 4 --name x")


# ------------------------------------------------------------------- player names (point 5)


def _league_folder(root: Path, name: str) -> Path:
    from h2h_racing.league.store import LeagueStore
    from h2h_racing.policies.trained import shipped_policies

    policy = shipped_policies()["racing_line_student"]
    folder = root / "runs" / "leagues" / name
    LeagueStore(folder / "league.sqlite", name=name).close()
    for path in (folder / "learners" / "main" / "latest.pt",
                 folder / "learners" / "main" / "best" / "latest.pt",
                 folder / "snapshots" / "main_v3.pt"):
        path.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(policy, path)
    return folder


def test_a_leagues_files_are_named_by_league_and_learner(tmp_path, monkeypatch):
    """Before: every league's learners/main/latest.pt was the player `latest`, so two
    leagues' mains were refused as one player."""
    from h2h_racing.league.players import player_for

    monkeypatch.chdir(tmp_path)
    a, b = _league_folder(tmp_path, "recommended"), _league_folder(tmp_path, "recommended-seed2")
    assert player_for(str(a / "learners/main/latest.pt")).name == "recommended/main"
    assert player_for("runs/leagues/recommended-seed2/learners/main/latest.pt").name == \
        "recommended-seed2/main"
    assert player_for(str(b / "learners/main/best/latest.pt")).name == \
        "recommended-seed2/main/best"
    assert player_for(str(a / "snapshots/main_v3.pt")).name == "recommended/main_v3"
    # Without a league file beside it, latest.pt is named by its path from here.
    (a / "league.sqlite").unlink()
    assert player_for(str(a / "learners/main/latest.pt")).name == \
        "runs/leagues/recommended/learners/main/latest"
    # Other files keep their names: a run's policy.pt by its folder, any other by its stem.
    run = tmp_path / "runs" / "speedway"
    run.mkdir(parents=True)
    shutil.copyfile(a / "snapshots/main_v3.pt", run / "policy.pt")
    assert player_for(str(run / "policy.pt")).name == "speedway"


def test_a_clash_of_two_players_to_one_name_is_refused_naming_them(tmp_path, monkeypatch):
    from h2h_racing.league.store import LeagueStore
    from h2h_racing.league.tournament import TournamentConfig, run_tournament

    monkeypatch.chdir(tmp_path)
    a, b = _league_folder(tmp_path, "a"), _league_folder(tmp_path, "b")
    for folder in (a, b):
        shutil.copyfile(folder / "snapshots/main_v3.pt", folder / "best.pt")
    clash = TournamentConfig(players=(str(a / "best.pt"), str(b / "best.pt"), "racing_line"),
                             tracks=("oval",), races=1, laps=1)
    with LeagueStore(tmp_path / "t.sqlite") as store:
        with pytest.raises(ValueError) as err:
            run_tournament(clash, store)
        assert store.count_matches() == 0 and store.players() == []
    assert str(err.value).startswith(
        f"two players of the tournament would have one name: {a / 'best.pt'} and "
        f"{b / 'best.pt'} are both named 'best'. ")
    assert "copy one of them to a file of another name" in str(err.value)


# ------------------------------------------------------------ one ratings table (point 2)


def _league_with_learners(tmp_path: Path) -> Path:
    """A league file as a run leaves it: anchors, a learner and its snapshot, and races of
    every kind (placement between frozen players, evaluation of the learner)."""
    from h2h_racing.league.store import CarResult, LeagueStore, MatchRecord, Player

    path = tmp_path / "league.sqlite"
    with LeagueStore(path, name="x") as store:
        store.set_metas({"rating_anchor": "racing_line", "main.steps": "2000"})
        for name in ("racing_line", "pure_pursuit"):
            store.add_player(Player(name=name, kind="scripted", checkpoint=name))
        store.add_player(Player(name="main", kind="learner", role="main"))
        store.add_player(Player(name="main_v1", kind="snapshot", role="main", parent="main",
                                training_steps=1000))
        results = [("placement", "racing_line", "pure_pursuit"), ("placement", "main_v1",
                                                                  "pure_pursuit"),
                   ("placement", "racing_line", "main_v1"), ("eval", "main", "pure_pursuit"),
                   ("eval", "racing_line", "main"), ("eval", "main", "main_v1")]
        for n, (kind, winner, loser) in enumerate(results * 2):
            cars = (CarResult(seat=0, player=winner, position=1, finished=True, laps=1),
                    CarResult(seat=1, player=loser, position=2, finished=True, laps=1))
            store.record_match(MatchRecord(key=f"league:x:{kind}:oval:{winner},{loser}:n={n}",
                                           track="oval", race_type="head_to_head", laps=1,
                                           seed=n, cars=cars, context=f"league:x:{kind}"))
        # The placement-only fit a league records, which left the learner out.
        store.record_ratings("bradley_terry", {"racing_line": 1000.0, "pure_pursuit": 600.0,
                                               "main_v1": 800.0})
    return path


def test_league_plot_draws_every_player_of_the_table(tmp_path, monkeypatch, capsys):
    """Before: ratings.png drew the stored placement ratings: the anchors and snapshots,
    not the learners, rated differently from `league table`."""
    pytest.importorskip("matplotlib")
    from h2h_racing.cli.command import main
    from h2h_racing.league import plots
    from h2h_racing.league.store import LeagueStore
    from h2h_racing.league.table import table_rows

    path = _league_with_learners(tmp_path)
    drawn = {}
    monkeypatch.setattr(plots, "plot_ratings",
                        lambda series, out, **kw: drawn.update(series) or Path(out))
    assert main(["league", "plot", "--league", str(path), "--out", str(tmp_path / "p")]) == 0
    with LeagueStore(path) as store:
        rows = {row.player: row for row in table_rows(store)[0]}
    assert set(rows) == {"racing_line", "pure_pursuit", "main", "main_v1"}
    # One line per lineage: main through its snapshot (1000 steps) to itself now (2000);
    # the anchors flat across; every rating the table's.
    assert set(drawn) == {"main", "racing_line", "pure_pursuit"}
    assert [(x, r) for x, r, _, _ in drawn["main"]] == [
        (1000.0, rows["main_v1"].rating), (2000.0, rows["main"].rating)]
    assert [(x, r) for x, r, _, _ in drawn["pure_pursuit"]] == [
        (0.0, rows["pure_pursuit"].rating), (2000.0, rows["pure_pursuit"].rating)]


def test_league_table_rates_every_player_against_the_leagues_anchor(tmp_path, capsys):
    from h2h_racing.cli.command import main
    from h2h_racing.league.store import LeagueStore

    path = _league_with_learners(tmp_path)
    with LeagueStore(path) as store:
        store.set_meta("rating_anchor", "pure_pursuit")
    assert main(["league", "table", "--league", str(path), "--boot", "5"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("12 races, anchor pure_pursuit = 1000\n")
    players = {line.split()[1] for line in out.splitlines()[3:7]}
    assert players == {"racing_line", "pure_pursuit", "main", "main_v1"}
