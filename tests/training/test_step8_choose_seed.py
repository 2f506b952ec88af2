"""Step 8's seed rules (`experiments/routes/retrain/step8/choose_seed_{ppo,obstacle}.py`) on
hand-made `evaluate --json` files: ppo_generalist's is step 6's rule on the ppo8_sN files;
obstacle_generalist's is step 7's (race targets on every shipped track, pace alone within 2
points of step 7's, then the fewest crashes a lap); both refuse to choose from fewer than 3
seeds."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

STEP8 = Path(__file__).resolve().parents[2] / "experiments" / "routes" / "retrain" / "step8"
SHIPPED = ("oval", "technical")  # two shipped tracks in the ppo tests, racing_line 10 s
ROUTELIKE = ("routelike_00", "routelike_01")  # racing_line 20 s
SEVEN = ("grand_loop", "hairpin_valley", "kidney", "oval", "speedway", "technical", "varying")


def load(name: str):
    spec = importlib.util.spec_from_file_location(name, STEP8 / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def time_trial(path: Path, rows: dict[str, tuple[float, float]], episodes: int = 20) -> None:
    path.write_text(json.dumps({
        "race_type": "time_trial", "settings": {"episodes": episodes},
        "routes": [{"route": t, "laps": laps, "mean_lap_s": lap}
                   for t, (laps, lap) in rows.items()]}))


# ---- ppo_generalist: step 6's rule on the ppo8 files ----

@pytest.fixture()
def ppo(tmp_path, monkeypatch):
    module = load("choose_seed_ppo")
    step6, step8 = tmp_path / "ppo_step6", tmp_path / "step8"
    step6.mkdir()
    step8.mkdir()
    monkeypatch.setattr(module, "HERE", step8)
    monkeypatch.setattr(module.rule, "HERE", step6)
    monkeypatch.setattr(module.rule, "ROUTELIKE_TRACKS", len(ROUTELIKE))
    time_trial(tmp_path / "racing_line_shipped.json", {t: (1.0, 10.0) for t in SHIPPED})
    time_trial(step6 / "racing_line_routelike.json", {t: (1.0, 20.0) for t in ROUTELIKE})
    return module, step8


def ppo_seed(step8: Path, n: int, shipped: dict, routelike: dict) -> None:
    time_trial(step8 / f"ppo8_s{n}_shipped.json", shipped)
    time_trial(step8 / f"ppo8_s{n}_routelike.json", routelike)


def test_ppo_rule_is_step6s_on_ppo8_files(ppo, capsys):
    module, step8 = ppo
    full = {t: (1.0, 10.0) for t in SHIPPED}
    # Seed 0: the fastest (-10 %) but 95 % of one shipped track: out at step 1.
    ppo_seed(step8, 0, {"oval": (0.95, 9.0), "technical": (1.0, 9.0)},
             {t: (1.0, 18.0) for t in ROUTELIKE})
    # Seed 1: +5 % on the shipped tracks, -5 % on the route-like ones: mean 0 %.
    ppo_seed(step8, 1, {t: (1.0, 10.5) for t in SHIPPED}, {t: (1.0, 19.0) for t in ROUTELIKE})
    # Seed 2: racing_line's pace everywhere except -2 % on one route-like track: mean -0.5 %.
    ppo_seed(step8, 2, full, {"routelike_00": (1.0, 19.6), "routelike_01": (1.0, 20.0)})
    module.main([])
    assert capsys.readouterr().out.splitlines()[-1] == "chosen: ppo8_s2"


def test_ppo_rule_refuses_fewer_than_three_seeds(ppo):
    module, step8 = ppo
    for n in (0, 1):
        ppo_seed(step8, n, {t: (1.0, 10.0) for t in SHIPPED},
                 {t: (1.0, 20.0) for t in ROUTELIKE})
    with pytest.raises(SystemExit, match="ppo8_s2_shipped.json, ppo8_s2_routelike.json"):
        module.main([])


# ---- obstacle_generalist: step 7's rule ----

def races(path: Path, race_type: str, on_target: int, crashes: int, resets: int,
          laps: int = 420) -> None:
    path.write_text(json.dumps({
        "race_type": race_type, "settings": {"races": 20, "laps": 3},
        "routes": [{"route": t} for t in SEVEN],
        "summary": {"routes_meeting_targets": on_target, "laps": laps, "crashes": crashes,
                    "resets": resets}}))


def alone(path: Path, pace: float, episodes: int = 20) -> None:
    path.write_text(json.dumps({
        "race_type": "time_trial", "settings": {"episodes": episodes},
        "routes": [{"route": t} for t in SEVEN], "summary": {"mean_vs_baseline_pct": pace}}))


@pytest.fixture()
def obstacle(tmp_path, monkeypatch):
    module = load("choose_seed_obstacle")
    monkeypatch.setattr(module, "HERE", tmp_path)
    alone(tmp_path / "obstacle7_time_trial_shipped.json", -0.6)  # the bar: +1.4 %
    return module, tmp_path


def obstacle_seed(folder: Path, n: int, pace: float, oa=(7, 0, 0), h2b=(7, 0, 0)) -> None:
    alone(folder / f"obstacle8_s{n}_time_trial_shipped.json", pace)
    races(folder / f"obstacle8_s{n}_object_avoidance_shipped.json", "object_avoidance", *oa)
    races(folder / f"obstacle8_s{n}_head_to_bot_shipped.json", "head_to_bot", *h2b)


def chosen(module, capsys) -> str:
    module.main([])
    return capsys.readouterr().out.splitlines()[-1]


def test_obstacle_targets_and_pace_before_crashes(obstacle, capsys):
    module, folder = obstacle
    obstacle_seed(folder, 0, -1.0, oa=(6, 0, 0))             # no crash, misses one track: out
    obstacle_seed(folder, 1, 1.5, h2b=(7, 1, 0))             # 1 crash, 0.1 over the bar: out
    obstacle_seed(folder, 2, 1.4, oa=(7, 20, 0), h2b=(7, 22, 0))  # at the bar exactly: kept
    assert chosen(module, capsys) == "chosen: obstacle8_s2"


def test_obstacle_fewest_crashes_then_resets(obstacle, capsys):
    module, folder = obstacle
    obstacle_seed(folder, 0, -2.0, oa=(7, 5, 0), h2b=(7, 5, 0))   # 10 crashes in 840 laps
    obstacle_seed(folder, 1, 1.0, oa=(7, 2, 9), h2b=(7, 2, 0))    # 4 crashes, 9 resets
    obstacle_seed(folder, 2, 0.0, oa=(7, 0, 0), h2b=(7, 4, 3))    # 4 crashes, 3 resets
    assert chosen(module, capsys) == "chosen: obstacle8_s2"


def test_obstacle_none_ships_when_none_passes(obstacle, capsys):
    module, folder = obstacle
    for n in range(3):
        obstacle_seed(folder, n, 3.0)  # all too slow alone
    assert chosen(module, capsys).startswith("chosen: none")


def test_obstacle_refuses_fewer_than_three_seeds_or_wrong_files(obstacle, capsys):
    module, folder = obstacle
    obstacle_seed(folder, 0, 0.0)
    obstacle_seed(folder, 1, 0.0)
    with pytest.raises(SystemExit, match="obstacle8_s2_time_trial_shipped.json"):
        module.main([])
    obstacle_seed(folder, 2, 0.0)
    alone(folder / "obstacle8_s2_time_trial_shipped.json", 0.0, episodes=10)
    with pytest.raises(SystemExit, match="20 attempts or races.*got 'time_trial', 10"):
        module.main([])
