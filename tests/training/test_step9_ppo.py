"""Step 9 of ppo_generalist (`experiments/routes/retrain/step9`): its seed rule is step 8's
(step 6's) run by import on the ppo9_sN files, and its ship rule is step 8's: more routes on
target than step 6's 39, every route at >= 95 % laps, every shipped track at 100 %, read only
once choose_seed.txt names the seed. Hand-made `evaluate --json` files."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

STEP9 = Path(__file__).resolve().parents[2] / "experiments" / "routes" / "retrain" / "step9"
SHIPPED = ("oval", "technical")  # racing_line 10 s
ROUTELIKE = ("routelike_00", "routelike_01")  # racing_line 20 s


def load(name: str):
    spec = importlib.util.spec_from_file_location(f"step9_{name}", STEP9 / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def time_trial(path: Path, rows: dict[str, tuple[float, float]], **extra) -> None:
    path.write_text(json.dumps({
        "race_type": "time_trial", "settings": {"episodes": 20}, **extra,
        "routes": [{"route": t, "laps": laps, "mean_lap_s": lap}
                   for t, (laps, lap) in rows.items()]}))


def test_seed_rule_is_step8s_on_ppo9_files(tmp_path, monkeypatch, capsys):
    module = load("choose_seed")
    step6, step9 = tmp_path / "ppo_step6", tmp_path / "step9"
    step6.mkdir()
    step9.mkdir()
    monkeypatch.setattr(module, "HERE", step9)
    monkeypatch.setattr(module.step8.rule, "HERE", step6)
    monkeypatch.setattr(module.step8.rule, "ROUTELIKE_TRACKS", len(ROUTELIKE))
    time_trial(tmp_path / "racing_line_shipped.json", {t: (1.0, 10.0) for t in SHIPPED})
    time_trial(step6 / "racing_line_routelike.json", {t: (1.0, 20.0) for t in ROUTELIKE})
    seeds = {  # (shipped, route-like)
        # The fastest, but 95 % on one shipped track: out at the rule's step 1.
        0: ({"oval": (0.95, 9.0), "technical": (1.0, 9.0)}, {t: (1.0, 18.0) for t in ROUTELIKE}),
        # All at 100 %, but one route-like track at 90 %: out at step 2.
        1: ({t: (1.0, 9.5) for t in SHIPPED}, {"routelike_00": (0.9, 19.0),
                                                "routelike_01": (1.0, 19.0)}),
        # racing_line's pace: the one left.
        2: ({t: (1.0, 10.0) for t in SHIPPED}, {t: (1.0, 20.0) for t in ROUTELIKE}),
    }
    for n in (0, 1):
        time_trial(step9 / f"ppo9_s{n}_shipped.json", seeds[n][0])
        time_trial(step9 / f"ppo9_s{n}_routelike.json", seeds[n][1])
    with pytest.raises(SystemExit, match="ppo9_s2_shipped.json, ppo9_s2_routelike.json"):
        module.main([])
    time_trial(step9 / "ppo9_s2_shipped.json", seeds[2][0])
    time_trial(step9 / "ppo9_s2_routelike.json", seeds[2][1])
    module.main([])
    assert capsys.readouterr().out.splitlines()[-1] == "chosen: ppo9_s2"


@pytest.fixture()
def ship(tmp_path, monkeypatch):
    module = load("ship_rule")
    step9 = tmp_path / "step9"
    step9.mkdir()
    monkeypatch.setattr(module, "HERE", step9)
    routes = [f"route_{k:02d}" for k in range(40)]
    # racing_line 10 s on every route; the shipped ppo_generalist 10.2 s: the bar is 10.5 s.
    time_trial(tmp_path / "racing_line.json", {r: (1.0, 10.0) for r in routes},
               policy="racing_line")
    monkeypatch.setattr(module.summarise, "SHIPPED_PPO", {"routes": [
        {"route": r, "laps": 1.0, "mean_lap_s": 10.2} for r in routes]})
    return module, step9, routes


def verdict(module, capsys) -> str:
    module.main()
    return capsys.readouterr().out.splitlines()[-1]


def test_ship_rule_waits_for_the_chosen_seed(ship):
    module, step9, _ = ship
    with pytest.raises(SystemExit, match="choose_seed.txt: no such file"):
        module.main()
    (step9 / "choose_seed.txt").write_text("ppo9_s0: ...\nno choice\n")
    with pytest.raises(SystemExit, match="expected one line 'chosen: ppo9_sN', found 0"):
        module.main()


def test_ship_rule_is_step8s(ship, capsys):
    module, step9, routes = ship
    (step9 / "choose_seed.txt").write_text("ppo9_s1: figures\nchosen: ppo9_s1\n")
    time_trial(step9 / "ppo9_s1_shipped.json", {t: (1.0, 10.0) for t in SHIPPED})
    # 40 of 40 on target (10.5 s is on the bar, not over it): ships.
    time_trial(step9 / "ppo9_s1.json", {r: (1.0, 10.5) for r in routes})
    assert verdict(module, capsys) == "ships: yes"
    # One route 5.1 % over racing_line (10.51 s): 39 on target, not more than step 6's 39.
    time_trial(step9 / "ppo9_s1.json", {r: (1.0, 10.51 if r == "route_07" else 10.0)
                                        for r in routes})
    assert verdict(module, capsys) == "ships: no"
    # One route at 90 % laps: below 95 %, no.
    time_trial(step9 / "ppo9_s1.json", {r: (0.9 if r == "route_03" else 1.0, 10.0)
                                        for r in routes})
    assert verdict(module, capsys) == "ships: no"
    # Every route on target but a shipped track at 95 %: no.
    time_trial(step9 / "ppo9_s1.json", {r: (1.0, 10.0) for r in routes})
    time_trial(step9 / "ppo9_s1_shipped.json", {"oval": (0.95, 10.0), "technical": (1.0, 10.0)})
    assert verdict(module, capsys) == "ships: no"
