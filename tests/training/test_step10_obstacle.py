"""Step 10 of obstacle_generalist (`experiments/routes/retrain/step10_obstacle/`): its seed rule
is head to bot on the narrow route-like tracks against step 7, then step 8's rule (imported)
among the seeds that pass; its ship rule is step 8's (step 9's ``check``, imported), on
hand-made `evaluate --json` files."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

STEP10 = Path(__file__).resolve().parents[2] / "experiments" / "routes" / "retrain" / \
    "step10_obstacle"
SEVEN = ("grand_loop", "hairpin_valley", "kidney", "oval", "speedway", "technical", "varying")


def load(name: str):
    spec = importlib.util.spec_from_file_location(f"step10_{name}", STEP10 / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def shipped(folder: Path, n: int, pace: float, crashes: int) -> None:
    """Seed n on the 7 shipped tracks: every target met, ``crashes`` in each race type."""
    base = {"routes": [{"route": t} for t in SEVEN]}
    (folder / f"obstacle10_s{n}_time_trial_shipped.json").write_text(json.dumps({
        **base, "race_type": "time_trial", "settings": {"episodes": 20},
        "summary": {"mean_vs_baseline_pct": pace}}))
    for race_type in ("object_avoidance", "head_to_bot"):
        (folder / f"obstacle10_s{n}_{race_type}_shipped.json").write_text(json.dumps({
            **base, "race_type": race_type, "settings": {"races": 20},
            "summary": {"routes_meeting_targets": 7, "laps": 420, "crashes": crashes,
                        "resets": 0}}))


def narrow(path: Path, on_target: int, resets: int, races: int = 20) -> None:
    """Head to bot on the 20 narrow tracks: 1200 laps, ``resets`` in all."""
    path.write_text(json.dumps({"race_type": "head_to_bot", "settings": {"races": races},
                                "summary": {"routes": 20, "routes_meeting_targets": on_target,
                                            "laps": 1200, "resets": resets}}))


@pytest.fixture()
def step10(tmp_path, monkeypatch):
    choose = load("choose_seed")
    step8 = tmp_path / "step8"
    step8.mkdir()
    monkeypatch.setattr(choose, "STEP8", step8)
    # Step 7's pace alone: +0.9 %, so the bar is +2.9 %.
    (step8 / "obstacle7_time_trial_shipped.json").write_text(json.dumps({
        "race_type": "time_trial", "settings": {"episodes": 20},
        "routes": [{"route": t} for t in SEVEN], "summary": {"mean_vs_baseline_pct": 0.9}}))
    # Step 7 on the narrow tracks: 18 of 20, 444 resets in 1200 laps = 0.37 a lap; bar 0.47.
    narrow(tmp_path / "obstacle7_routelike_narrow.json", 18, 444)
    return choose, tmp_path


def test_the_narrow_check_comes_first(step10, capsys):
    choose, folder = step10
    shipped(folder, 0, 0.0, 0)    # fewest crashes, but 17 of 20 narrow tracks: out
    shipped(folder, 1, 0.0, 10)   # 18, 564 resets = 0.47 a lap, at the bar: passes
    shipped(folder, 2, 0.0, 12)   # 20, but 565 resets = 0.471 a lap: out
    narrow(folder / "obstacle10_s0_routelike_narrow.json", 17, 0)
    narrow(folder / "obstacle10_s1_routelike_narrow.json", 18, 564)
    narrow(folder / "obstacle10_s2_routelike_narrow.json", 20, 565)
    assert choose.main([], here=folder) == "obstacle10_s1"
    out = capsys.readouterr().out
    assert "a seed needs 18 or more and at most 0.470" in out
    assert "obstacle10_s0: on target on 17 of 20 narrow route-like tracks, 0.000 resets per " \
           "lap: out" in out
    assert "step 8's rule among obstacle10_s1:" in out


def test_step8s_rule_among_those_that_pass(step10):
    choose, folder = step10
    shipped(folder, 0, 3.0, 0)    # 0.1 point over step 8's pace bar (+2.9 %): out
    shipped(folder, 1, 0.0, 12)
    shipped(folder, 2, 0.0, 10)   # fewer crashes than seed 1: chosen
    for n in range(3):
        narrow(folder / f"obstacle10_s{n}_routelike_narrow.json", 19, 400)
    assert choose.main([], here=folder) == "obstacle10_s2"


def test_none_pass_the_narrow_check(step10, capsys):
    choose, folder = step10
    for n in range(3):
        shipped(folder, n, 0.0, 0)
        narrow(folder / f"obstacle10_s{n}_routelike_narrow.json", 15, 900)
    assert choose.main([], here=folder) is None
    assert "chosen: none (no seed passes head to bot" in capsys.readouterr().out


def test_refuses_fewer_than_three_seeds(step10):
    choose, folder = step10
    for n in range(3):
        shipped(folder, n, 0.0, 0)
    narrow(folder / "obstacle10_s0_routelike_narrow.json", 20, 0)
    narrow(folder / "obstacle10_s1_routelike_narrow.json", 20, 0)
    with pytest.raises(SystemExit, match="obstacle10_s2_routelike_narrow.json"):
        choose.main([], here=folder)


def test_refuses_narrow_files_measured_otherwise(step10):
    choose, folder = step10
    for n in range(3):
        shipped(folder, n, 0.0, 0)
        narrow(folder / f"obstacle10_s{n}_routelike_narrow.json", 20, 0, races=10)
    with pytest.raises(SystemExit, match="expected head_to_bot with 20 races on each of the 20"):
        choose.main([], here=folder)


@pytest.mark.parametrize(("oa", "h2b", "verdict"), [(39, 40, "ships: no (the rule asks"),
                                                    (40, 39, "ships: no (the rule asks"),
                                                    (40, 40, "the card's protocol is not")])
def test_ship_rule_is_step8s(tmp_path, capsys, oa, h2b, verdict):
    ship = load("ship_check")
    for race_type, n in (("object_avoidance", oa), ("head_to_bot", h2b)):
        (tmp_path / f"obstacle10_s1_{race_type}.json").write_text(json.dumps({
            "settings": {"races": 20}, "summary": {
                "routes": 40, "routes_meeting_targets": n,
                "routes_missing_targets": [f"r{k}" for k in range(40 - n)]}}))
    assert ship.SHIP.check("obstacle10_s1", here=tmp_path) is False
    out = capsys.readouterr().out
    assert verdict in out
    if oa == h2b == 40:
        assert "runs/obstacle10_s1/policy.pt" in out
