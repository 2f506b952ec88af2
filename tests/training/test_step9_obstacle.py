"""Step 9 of obstacle_generalist (`experiments/routes/retrain/step9_obstacle/`): its seed rule
is step 8's, imported (run on the obstacle9_sN files against step 8's step-7 pace file), and its
ship rule is step 8's (object avoidance on more than 39 routes, head to bot on all 40, then the
card's 30 targets), on hand-made `evaluate --json` files."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import pytest

STEP9 = Path(__file__).resolve().parents[2] / "experiments" / "routes" / "retrain" / \
    "step9_obstacle"
SEVEN = ("grand_loop", "hairpin_valley", "kidney", "oval", "speedway", "technical", "varying")


def load(name: str):
    sys.path.insert(0, str(STEP9))
    try:
        spec = importlib.util.spec_from_file_location(name, STEP9 / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(STEP9))
    return module


def shipped(folder: Path, n: int, pace: float, crashes: int) -> None:
    """Seed n on the 7 shipped tracks: every target met, ``crashes`` in each race type."""
    base = {"routes": [{"route": t} for t in SEVEN]}
    (folder / f"obstacle9_s{n}_time_trial_shipped.json").write_text(json.dumps({
        **base, "race_type": "time_trial", "settings": {"episodes": 20},
        "summary": {"mean_vs_baseline_pct": pace}}))
    for race_type in ("object_avoidance", "head_to_bot"):
        (folder / f"obstacle9_s{n}_{race_type}_shipped.json").write_text(json.dumps({
            **base, "race_type": race_type, "settings": {"races": 20},
            "summary": {"routes_meeting_targets": 7, "laps": 420, "crashes": crashes,
                        "resets": 0}}))


def routes(path: Path, on_target: int, races: int = 20) -> None:
    missed = [f"route_{k}" for k in range(40 - on_target)]
    path.write_text(json.dumps({"settings": {"races": races}, "summary": {
        "routes": 40, "routes_meeting_targets": on_target, "routes_missing_targets": missed}}))


@pytest.fixture()
def step9(tmp_path, monkeypatch):
    choose = load("choose_seed")
    ship = load("ship_check")
    monkeypatch.setattr(choose, "HERE", tmp_path)
    monkeypatch.setattr(ship, "HERE", tmp_path)
    step8 = tmp_path / "step8"
    step8.mkdir()
    monkeypatch.setattr(choose, "STEP8", step8)
    # Step 7's pace alone: +0.9 %, so the bar is +2.9 %.
    (step8 / "obstacle7_time_trial_shipped.json").write_text(json.dumps({
        "race_type": "time_trial", "settings": {"episodes": 20},
        "routes": [{"route": t} for t in SEVEN], "summary": {"mean_vs_baseline_pct": 0.9}}))
    return choose, ship, tmp_path


def test_step8s_rule_on_step9s_files(step9, capsys):
    choose, _, folder = step9
    shipped(folder, 0, 3.0, 0)    # no crash, but 0.1 point over the bar: out
    shipped(folder, 1, 2.9, 10)   # at the bar: kept, 20 crashes in 840 laps
    shipped(folder, 2, -1.0, 12)  # kept, 24 crashes
    assert choose.main([]) == "obstacle9_s1"
    assert capsys.readouterr().out.splitlines()[0].startswith(
        "step 7 alone on the shipped tracks: +0.9 %")


def test_step9_refuses_fewer_than_three_seeds(step9):
    choose, _, folder = step9
    shipped(folder, 0, 0.0, 0)
    shipped(folder, 1, 0.0, 0)
    with pytest.raises(SystemExit, match="obstacle9_s2_time_trial_shipped.json"):
        choose.main([])


@pytest.mark.parametrize(("oa", "h2b", "ships"), [(39, 40, False), (40, 39, False),
                                                  (40, 40, None)])
def test_ship_rule_routes(step9, capsys, oa, h2b, ships):
    _, ship, folder = step9
    routes(folder / "obstacle9_s1_object_avoidance.json", oa)
    routes(folder / "obstacle9_s1_head_to_bot.json", h2b)
    assert ship.check("obstacle9_s1") is False  # without the card's protocol, never
    out = capsys.readouterr().out
    if ships is False:
        assert "ships: no (the rule asks for object avoidance on more than 39" in out
    else:
        assert "the card's protocol is not measured yet" in out


@pytest.mark.parametrize(("failed", "ships"), [(0, True), (1, False)])
def test_ship_rule_card(step9, capsys, failed, ships):
    _, ship, folder = step9
    routes(folder / "obstacle9_s1_object_avoidance.json", 40)
    routes(folder / "obstacle9_s1_head_to_bot.json", 40)
    tracks = {f"track_{k}": {kind: {"ok": not (failed and k == 3 and kind == "head_to_bot")}
                             for kind in ("object_avoidance", "head_to_bot", "time_trial")}
              for k in range(10)}
    (folder / "obstacle9_s1_card.json").write_text(json.dumps(
        {"figures": {"runs/obstacle9_s1/policy.pt": tracks}}))
    assert ship.check("obstacle9_s1") is ships
    assert f"card's protocol: {30 - failed} of 30 targets met" in capsys.readouterr().out


def test_ship_rule_refuses_routes_measured_otherwise(step9):
    _, ship, folder = step9
    routes(folder / "obstacle9_s1_object_avoidance.json", 40, races=10)
    with pytest.raises(SystemExit, match="expected 20 races on each of the 40 routes, got 10"):
        ship.check("obstacle9_s1")
