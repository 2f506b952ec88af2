"""``h2h-racing evaluate`` over many routes (issue 36): a folder or several files, one row per
route, a summary, ``--json``, race types, worker processes, Ctrl-C.

The routes are generated in ``tmp_path`` from the catalogue's 20 m oval (1.07 m wide): the oval
itself, the oval at 0.6 of its width (0.642 m) and a broken file. ``pure_pursuit:offset=0.45``
follows a line 0.45 m left of the centre line: on the narrow oval (0.321 m half-width) even
its inner wheels (0.45 - 0.08 m wheel half-track = 0.37 m) are off the track, so every attempt
ends off track; on the oval every wheel stays inside (0.53 m < 0.535 m), so it laps.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from h2h_racing.cli.command import main
from h2h_racing.training.evaluate import Evaluation, RaceEvaluation, evaluate_races
from h2h_racing.training.evaluate_routes import (RouteFailure, RouteLaps, RouteRaces,
                                                 RouteTask, route_sources,
                                                 run_routes)
from h2h_racing.training.evaluate_routes_report import (laps_summary, missed_targets,
                                                        races_summary)

ROUTES = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "deepracer_tracks"
OFFSET = "pure_pursuit:offset=0.45"


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """oval.json, narrow.json (0.6 of the oval's width), broken.npy, notes.txt, .hidden.json."""
    from h2h_racing.track.io import load_track, save_track

    out = tmp_path_factory.mktemp("routes")
    save_track(load_track("oval"), out / "oval.json")
    save_track(load_track("oval", scale=(1.0, 0.6)), out / "narrow.json")
    (out / "broken.npy").write_bytes(b"not a numpy file")
    (out / "notes.txt").write_text("not a track\n")
    (out / ".hidden.json").write_text("{}")
    return out


def _laps(route: str, laps: float, mean: float, base: float | None,
          reference: float = 5.0) -> RouteLaps:
    """A hand-made time-trial result: ``laps`` of 10 attempts lapped in ``mean`` s."""
    def ev(lapped: float, lap: float) -> Evaluation:
        return Evaluation("p", route, 10, lapped, lap, lap, 0, 0)

    return RouteLaps(route, f"{route}.npy", ev(laps, mean),
                     None if base is None else ev(1.0, base), reference, 20.0)


def _races(route: str, finished: int, laps_done: int, crashes: int, resets: int) -> RouteRaces:
    """A hand-made race result of 10 races of 3 laps."""
    return RouteRaces(route, f"{route}.npy", RaceEvaluation(
        "p", route, "object_avoidance", 10, 3, finished, laps_done, crashes, resets, 0,
        60.0), 20.0)


class TestRouteSources:
    """What ``--track`` names."""

    def test_a_folder_is_its_track_files_sorted(self, folder: Path) -> None:
        sources = route_sources([str(folder)])
        assert [s.route for s in sources.routes] == ["broken", "narrow", "oval"]
        assert sources.routes[1].source == str(folder / "narrow.json")
        # notes.txt is left out and said so; hidden files are not looked at.
        assert [Path(p).name for p in sources.ignored] == ["notes.txt"]

    def test_comma_lists_names_files_and_all(self, folder: Path) -> None:
        from h2h_racing.track.io import list_tracks

        sources = route_sources([f"oval,{folder / 'narrow.json'}", "random:3"])
        assert [(s.route, s.source) for s in sources.routes] == [
            ("oval", "oval"), ("narrow", str(folder / "narrow.json")),
            ("random:3", "random:3")]
        assert [s.route for s in route_sources(["all"]).routes] == list_tracks()

    def test_a_typo_is_refused_before_anything_runs(self, tmp_path: Path) -> None:
        with pytest.raises(ValueError, match="'ovall' is neither a folder, a track file nor"):
            route_sources(["oval,ovall"])
        with pytest.raises(ValueError, match="holds no track file"):
            route_sources([str(tmp_path)])


class TestSummaries:
    """The summary's counts and worst routes, on hand-made figures."""

    def test_time_trial_counts_routes_at_95_percent(self) -> None:
        results = [_laps("a", 1.0, 10.0, 10.0), _laps("b", 0.95, 11.0, 10.0),
                   _laps("c", 0.9, 10.0, 10.0), _laps("d", 0.0, float("inf"), 10.0)]
        failures = [RouteFailure("e", "e.npy", "bad")]
        lines, figures = laps_summary(results, failures, "racing_line")
        # 95 % counts (b); 90 % (c) and 0 % (d) do not.
        assert lines[0] == ("summary: 2 of 4 routes at >= 95 % laps; 1 file not evaluated "
                            "(e.npy)")
        assert figures["routes_at_target"] == 2 and figures["files_not_evaluated"] == 1
        assert figures["routes_below_target"] == ["c", "d"]
        # Worst first: d (0 %), c (90 %), then b (95 %, 10 % slower) before a (100 %).
        assert figures["worst_routes"] == ["d", "c", "b"]
        assert lines[1] == ("worst routes: d 0 %; c 90 % (+0.0 % vs racing_line); b 95 % "
                            "(+10.0 % vs racing_line)")
        # Mean over a, b, c (d has no lap): (0 + 10 + 0) / 3; vs the 5 s reference: a and c
        # +100 %, b +120 %.
        assert figures["mean_vs_baseline_pct"] == pytest.approx(10.0 / 3)
        assert figures["mean_vs_reference_pct"] == pytest.approx(320.0 / 3)
        assert "over the 3 routes both lapped" in lines[2]

    def test_every_route_below_target_is_named(self) -> None:
        results = [_laps(name, 0.5, 10.0, None) for name in "abcde"]
        lines, figures = laps_summary(results, [], None)
        assert figures["worst_routes"] == list("abcde")
        assert not any("vs racing_line" in line for line in lines)

    def test_race_targets(self) -> None:
        results = [_races("ok", 9, 27, 13, 27),       # 90 % finished, 0.48 crashes, 1 reset
                   _races("few", 8, 24, 0, 0),        # 80 % finished
                   _races("crashy", 10, 30, 16, 16),  # 0.53 crashes per lap
                   _races("stuck", 0, 0, 0, 0)]       # no lap: per-lap figures miss
        assert [missed_targets(r) for r in results] == [
            [], ["finished"], ["crashes"], ["finished", "crashes", "resets"]]
        lines, figures = races_summary(results, [RouteFailure("x", "x.csv", "bad")])
        assert lines[0].startswith("summary: 1 of 4 routes meet the targets (>= 90 % of races "
                                   "finished, <= 0.5 crashes and <= 1 reset per lap)")
        assert lines[0].endswith("1 file not evaluated (x.csv)")
        assert figures["routes_by_target"] == {"finished": 2, "crashes_per_lap": 2,
                                               "resets_per_lap": 3}
        assert figures["worst_routes"] == ["stuck", "few", "crashy"]
        # 27 of 40 races finished; 29 crashes and 43 resets over 81 laps.
        assert lines[2] == ("all routes: 27 of 40 races finished, 81 laps, 0.36 crashes and "
                            "0.53 resets per lap")


class TestFolderCommand:
    """``evaluate --track FOLDER`` end to end, in this process."""

    def test_rows_failures_summary_and_json(self, folder: Path, tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
        out = tmp_path / "routes.json"
        status = main(["evaluate", "--policy", OFFSET, "--track", str(folder), "--episodes",
                       "4", "--jobs", "1", "--json", str(out), "--no-progress"])
        text = capsys.readouterr().out
        assert status == 1, text  # a file could not be evaluated
        lines = text.splitlines()
        rows = {line.split()[0]: line for line in lines if line.split()[0] in ("oval", "narrow")}
        assert "100.0 %" in rows["oval"] and "0.0 %" in rows["narrow"]
        bad = [line for line in lines if line.startswith("broken.npy: not evaluated: ")]
        assert len(bad) == 1 and "numpy" in bad[0]
        assert "notes.txt: left out: not a track file" in text
        assert ("summary: 1 of 2 routes at >= 95 % laps; 1 file not evaluated (broken.npy)"
                in lines)
        data = json.loads(out.read_text())
        assert [r["route"] for r in data["routes"]] == ["narrow", "oval"]
        narrow, oval = data["routes"]
        assert narrow["laps"] == 0.0 and narrow["mean_lap_s"] is None
        assert narrow["off_tracks"] == 4 and narrow["at_target"] is False
        assert oval["laps"] == 1.0 and oval["baseline_laps"] == 1.0
        # Pure pursuit laps the oval in ~8 s, racing_line in ~6 s (policies/README): slower.
        assert oval["vs_baseline_pct"] > 20 and oval["reference_lap_s"] < oval["mean_lap_s"]
        assert data["files_not_evaluated"][0]["file"] == str(folder / "broken.npy")
        assert data["summary"]["routes"] == 2 and data["summary"]["routes_at_target"] == 1
        assert data["summary"]["worst_routes"][0] == "narrow"
        assert data["settings"] == {"episodes": 4, "baseline": "racing_line", "seed": 0,
                                    "jobs": 1}

    def test_race_type_over_files(self, folder: Path, tmp_path: Path,
                                  capsys: pytest.CaptureFixture[str]) -> None:
        out = tmp_path / "races.json"
        status = main(["evaluate", "--policy", OFFSET, "--track",
                       str(folder / "oval.json"), str(folder / "narrow.json"), "--race-type",
                       "head_to_bot", "--races", "2", "--laps", "1", "--jobs", "1", "--json",
                       str(out), "--no-progress"])
        text = capsys.readouterr().out
        assert status == 0, text
        data = json.loads(out.read_text())
        oval, narrow = data["routes"]
        assert oval["route"] == "oval" and oval["finished"] == 2 and oval["laps"] == 2
        assert narrow["finished"] == 0 and narrow["laps"] == 0
        assert narrow["crashes_per_lap"] is None
        assert narrow["missed_targets"] == ["finished", "crashes", "resets"]
        assert data["summary"]["routes_meeting_targets"] == (0 if oval["missed_targets"] else 1)
        assert "summary: " in text and "worst routes: narrow" in text

    def test_jobs_do_not_change_the_figures(self, folder: Path) -> None:
        sources = route_sources([str(folder)]).routes
        tasks = [RouteTask(source, OFFSET, episodes=3) for source in sources]
        done: list[int] = []
        one = run_routes(tasks, 1)
        two = run_routes(tasks, 2, lambda index, result: done.append(index))
        assert sorted(done) == [0, 1, 2]
        assert two == one
        assert isinstance(one[0], RouteFailure) and isinstance(one[2], RouteLaps)

    def test_one_track_keeps_the_old_table(self, capsys: pytest.CaptureFixture[str]) -> None:
        assert main(["evaluate", "--policy", "pure_pursuit", "--track", "oval", "--episodes",
                     "2"]) == 0
        lines = capsys.readouterr().out.splitlines()
        assert lines[1] == Evaluation.header()
        assert [line.split()[0] for line in lines[2:]] == ["pure_pursuit", "racing_line"]

    @pytest.mark.parametrize("argv, message", [
        (["--json", "/nonexistent-folder/x.json"], "does not exist; create it first"),
        (["--jobs", "0"], "--jobs must be a whole number >= 1"),
        (["--policy", "no_such_driver"], "no_such_driver"),
    ])
    def test_bad_options_fail_before_running(self, folder: Path, argv: list[str], message: str,
                                             capsys: pytest.CaptureFixture[str]) -> None:
        base = ["evaluate", "--policy", "racing_line", "--track", str(folder), "--no-progress"]
        assert main(base + argv) == 2
        captured = capsys.readouterr()
        assert message in captured.err and "route" not in captured.out

    def test_race_type_with_against_is_refused(self, capsys: pytest.CaptureFixture[str]) -> None:
        assert main(["evaluate", "--policy", "racing_line", "--against", "pure_pursuit",
                     "--race-type", "head_to_bot"]) == 2
        assert "--race-type head_to_bot races the policy alone" in capsys.readouterr().err


class TestEvaluateRaces:
    """``evaluate_races``: races alone with boxes or bots in one batched core."""

    def test_racing_line_finishes_with_boxes(self) -> None:
        result = evaluate_races("racing_line", "oval", "object_avoidance", races=2, laps=1)
        assert (result.races, result.finished, result.laps_done) == (2, 2, 2)
        assert result.crashes_per_lap == result.crashes / 2
        assert np.isfinite(result.mean_race_time)

    def test_bad_race_type(self) -> None:
        with pytest.raises(ValueError, match="race_type must be one of object_avoidance"):
            evaluate_races("racing_line", "oval", "time_trial")


def test_ctrl_c_keeps_the_routes_done(folder: Path, tmp_path: Path) -> None:
    """Ctrl-C during a run with workers: the routes done are summed up and written, the
    workers are stopped, and the command ends at once with status 130."""
    from h2h_racing.track.io import load_track, save_track

    (tmp_path / "in").mkdir()
    for k in range(4):
        save_track(load_track("oval", scale=(10.0, 1.0)), tmp_path / "in" / f"r{k}.json")
    out = tmp_path / "partial.json"
    # 5000 attempts on a 200 m lap, then racing_line's: a route takes about a minute on a
    # quiet development machine, so none finishes before Ctrl-C, nor within the 30 s allowed
    # after. The command gets Python's own Ctrl-C whatever this process ignores (a child
    # inherits an ignored SIGINT, and the full run's earlier tests may have left one).
    proc = subprocess.Popen(
        [sys.executable, "-m", "h2h_racing.cli.command", "evaluate", "--policy", "pure_pursuit",
         "--track", str(tmp_path / "in"), "--episodes", "5000", "--jobs", "2", "--json",
         str(out), "--no-progress"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        assert proc.stdout is not None
        assert "4 routes" in proc.stdout.readline()  # the run has started
        time.sleep(3.0)  # the workers are up and in their first routes
        workers = subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True,
                                 text=True).stdout.split()
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, (stdout, stderr)
    assert "interrupted (Ctrl-C) after 0 of 4 routes" in stdout
    data = json.loads(out.read_text())
    assert data["interrupted"] is True and data["routes"] == [] and data["routes_given"] == 4
    assert workers  # the pool's workers (and multiprocessing's resource tracker)
    # They end with the command (terminated, or on their parent's death: lifeline); allow
    # them a moment to go, which a worker that kept its route running would not.
    deadline = time.monotonic() + 10.0
    while _alive(workers) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not _alive(workers)


def _alive(pids: list[str]) -> list[str]:
    """The processes of ``pids`` still running (a zombie awaiting its reaper is not)."""
    alive = []
    for pid in pids:
        try:
            status = Path(f"/proc/{pid}/status").read_text()
        except OSError:
            continue
        if "\nState:\tZ" not in status:
            alive.append(pid)
    return alive


@pytest.mark.skipif(not ROUTES.is_dir(), reason="../shared/data/deepracer_tracks not beside "
                                                "the clone (README's Tests section)")
def test_the_deepracer_routes_folder(tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    """The 40 real routes are read as 40 routes; two of them, evaluated as a folder, lap."""
    sources = route_sources([str(ROUTES)])
    assert len(sources.routes) == 40 and not sources.ignored
    assert {Path(s.source).suffix for s in sources.routes} == {".npy"}
    # racing_line laps every route clean alone (policies/README, experiments/routes).
    folder = tmp_path / "two"
    folder.mkdir()
    for name in ("Oval_track.npy", "reInvent2019_wide.npy"):
        (folder / name).symlink_to((ROUTES / name).resolve())
    assert main(["evaluate", "--policy", "racing_line", "--track", str(folder), "--episodes",
                 "2", "--jobs", "1", "--baseline", "", "--no-progress"]) == 0
    assert "summary: 2 of 2 routes at >= 95 % laps" in capsys.readouterr().out


def test_a_task_is_checked() -> None:
    source = route_sources(["oval"]).routes[0]
    with pytest.raises(ValueError, match="race_type must be one of time_trial, "
                                         "object_avoidance, head_to_bot, got 'head_to_head'"):
        RouteTask(source, "racing_line", race_type="head_to_head")
    with pytest.raises(ValueError, match="episodes must be a whole number >= 1, got 0"):
        RouteTask(source, "racing_line", episodes=0)
