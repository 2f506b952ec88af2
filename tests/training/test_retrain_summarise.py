"""Issue 36's bars as `experiments/routes/retrain/summarise.py` reads them: which lap each route
is held to (steps 1-2's ppo_generalist, racing_line: the one given or the one each run recorded),
on hand-made JSON files of one route."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "routes" / "retrain" / "summarise.py"


@pytest.fixture()
def summarise(monkeypatch):
    spec = importlib.util.spec_from_file_location("retrain_summarise", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    # Steps 1-2's ppo_generalist: 10.0 s on the one route.
    monkeypatch.setattr(module, "SHIPPED_PPO", run_json("ppo_generalist.pt", 10.0, None))
    return module


def run_json(policy: str, lap: float | None, baseline: float | None, laps: float = 1.0) -> dict:
    """An `evaluate --json` time trial over one route, ``baseline`` the racing_line it recorded."""
    pct = 100 * (lap / baseline - 1) if lap and baseline else None  # as evaluate writes it
    return {"policy": policy, "race_type": "time_trial",
            "summary": {"mean_vs_baseline_pct": pct},
            "routes": [{"route": "loop", "laps": laps, "mean_lap_s": lap,
                        "baseline_mean_lap_s": baseline}]}


def write(folder: Path, name: str, data: dict) -> None:
    (folder / f"{name}.json").write_text(json.dumps(data))


def test_ppo_bar_is_the_faster_of_the_policy_before_and_racing_line(summarise):
    route = {"route": "loop"}
    line = {"loop": 9.0}
    assert summarise.pace_bar(route, summarise.SHIPPED_PPO, True, line) == (9.0, "racing_line")
    assert summarise.pace_bar(route, summarise.SHIPPED_PPO, True, {"loop": 11.0}) == (
        10.0, "policy before")
    assert summarise.pace_bar(route, summarise.SHIPPED_PPO, False, line) == (10.0, "policy before")
    # The policy before never lapped the route: racing_line alone sets the bar.
    never = run_json("old", None, None)
    assert summarise.pace_bar(route, never, True, line) == (9.0, "racing_line")


def test_camera_bar_leaves_racing_line_out_even_against_the_policy_before(summarise, tmp_path):
    # 10.5 s is within 10 % of the policy before's 10.0 s, not of racing_line's 9.0 s (9.9 s):
    # the camera bar is ppo_generalist's laps only. The old code put racing_line in whenever
    # the reference was steps 1-2's file (summarise.py run without PPO_SEED).
    write(tmp_path, "camera_s0", run_json("camera.pt", 10.5, 9.0))
    row = summarise.time_trial("camera_s0", summarise.SHIPPED_PPO, 0.10, tmp_path)
    assert row.split(" | ")[3] == "1 of 1"


def test_today_racing_line_replaces_the_one_each_run_recorded(summarise, tmp_path, monkeypatch):
    # The run recorded racing_line at 9.0 s; today's laps 12.0 s. Bar: min(10.0, 12.0) = 10.0,
    # and 10.4 <= 1.05 * 10.0; against the recorded line the bar was 9.0 (10.4 > 9.45, +15.6 %).
    write(tmp_path, "ppo_s0", run_json("ppo.pt", 10.4, 9.0))
    monkeypatch.setattr(summarise, "RACING_LINE", run_json("racing_line", 12.0, 12.0))
    cells = summarise.time_trial("ppo_s0", summarise.SHIPPED_PPO, 0.05, tmp_path,
                                 with_racing_line=True).split(" | ")
    assert cells[3:6] == ["1 of 1", "-", f"{100 * (10.4 / 12.0 - 1):+.1f} % |"]
    monkeypatch.setattr(summarise, "RACING_LINE", None)  # --stored-baseline
    cells = summarise.time_trial("ppo_s0", summarise.SHIPPED_PPO, 0.05, tmp_path,
                                 with_racing_line=True).split(" | ")
    assert cells[3:6] == ["0 of 1", "loop +15.6 %", "+15.6 % |"]


def test_a_racing_line_file_of_another_policy_is_refused(tmp_path):
    path = tmp_path / "not_racing_line.json"
    path.write_text(json.dumps(run_json("runs/ppo/policy.pt", 10.0, 9.0)))
    result = subprocess.run([sys.executable, str(SCRIPT), "--racing-line", str(path)],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode != 0
    assert "expected racing_line's time trial" in result.stderr
    assert "runs/ppo/policy.pt" in result.stderr


def test_a_folders_shipped_tracks_json_gets_no_routes_row(summarise, tmp_path, monkeypatch,
                                                          capsys):
    # ppo_more/ keeps each seed's run on the shipped tracks (`--track all`) beside its routes
    # JSON: only the routes one is a row of the routes table (the old code printed both).
    line = run_json("racing_line", 10.0, 10.0)
    write(tmp_path, "racing_line", line)
    write(tmp_path, "racing_line_shipped", line)
    (tmp_path / "ppo_more").mkdir()
    write(tmp_path / "ppo_more", "ppo5_s0", run_json("ppo5.pt", 10.2, 10.0))
    write(tmp_path / "ppo_more", "ppo5_s0_shipped", run_json("ppo5.pt", 10.2, 10.0))
    monkeypatch.setattr(summarise, "HERE", tmp_path)
    monkeypatch.setattr(sys, "argv", ["summarise.py"])
    summarise.main()
    out = capsys.readouterr().out
    assert "| ppo_more/ppo5_s0 | 1 of 1 | - | 1 of 1 | - | +2.0 % |" in out
    assert "ppo5_s0_shipped" not in out


def test_a_folders_routelike_json_gets_no_routes_row(summarise, tmp_path, monkeypatch, capsys):
    # ppo_step6/ keeps each seed's run on the 30 route-like procedural tracks, and
    # racing_line's, beside its routes JSON: neither is a row of the routes table (the old code
    # printed them as routes rows).
    line = run_json("racing_line", 10.0, 10.0)
    write(tmp_path, "racing_line", line)
    write(tmp_path, "racing_line_shipped", line)
    (tmp_path / "ppo_step6").mkdir()
    write(tmp_path / "ppo_step6", "ppo6_s0", run_json("ppo6.pt", 10.3, 10.0))
    write(tmp_path / "ppo_step6", "ppo6_s0_routelike", run_json("ppo6.pt", 10.2, 10.0))
    write(tmp_path / "ppo_step6", "racing_line_routelike", line)
    monkeypatch.setattr(summarise, "HERE", tmp_path)
    monkeypatch.setattr(sys, "argv", ["summarise.py"])
    summarise.main()
    out = capsys.readouterr().out
    assert "| ppo_step6/ppo6_s0 | 1 of 1 | - | 1 of 1 | - | +3.0 % |" in out
    assert "_routelike" not in out
