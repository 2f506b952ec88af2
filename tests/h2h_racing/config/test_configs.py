"""Shipped configs by name (``--config recommended``) from any directory."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from h2h_racing.config.shipped import resolve_config, shipped_configs

REPO = Path(__file__).resolve().parents[3]


def test_shipped_league_configs_are_the_product_ones() -> None:
    shipped = shipped_configs("league")
    assert sorted(shipped) == ["recommended", "smoke"]
    assert shipped["smoke"].read_text() == (REPO / "league" / "smoke.toml").read_text()


def test_shipped_training_configs_are_named_by_policy_and_step() -> None:
    shipped = shipped_configs("train")
    assert sorted(shipped) == ["camera_generalist/anneal", "camera_generalist/bspline",
                               "camera_generalist/fullpace",
                               "camera_generalist/hairpins", "camera_generalist/imitate",
                               "camera_generalist/pace", "camera_generalist/routes",
                               "camera_generalist/settle", "camera_generalist/wide",
                               "camera_racer/imitate", "obstacle_generalist/anneal",
                               "obstacle_generalist/bots", "obstacle_generalist/circuits",
                               "obstacle_generalist/imitate", "obstacle_generalist/routes",
                               "obstacle_generalist/settle", "obstacle_generalist/tight",
                               "ppo_generalist/finetune", "ppo_generalist/imitate",
                               "ppo_generalist/routes", "ppo_generalist/routes_imitate",
                               "racing_line_student/imitate"]
    assert shipped["ppo_generalist/imitate"] == (
        REPO / "policies" / "trained" / "ppo_generalist" / "imitate.toml")


def test_a_name_resolves_from_any_directory(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)  # no league/ folder here
    assert resolve_config("recommended", "league") == REPO / "league" / "recommended.toml"
    assert resolve_config("smoke.toml", "league") == REPO / "league" / "smoke.toml"
    assert resolve_config("ppo_generalist/imitate", "train").name == "imitate.toml"


def test_an_existing_path_wins_over_a_name(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "smoke").write_text('name = "mine"\n')
    assert resolve_config("smoke", "league") == Path("smoke")
    mine = tmp_path / "mine.toml"
    mine.write_text('name = "mine"\n')
    assert resolve_config(mine, "league") == mine


def test_unknown_names_list_the_shipped_ones() -> None:
    with pytest.raises(FileNotFoundError, match=r"--config 'finishing': no such file, and no "
                       r"shipped league config of that name; shipped: recommended, smoke"):
        resolve_config("finishing", "league")
    # A training config is not a league config, and the other way round.
    with pytest.raises(FileNotFoundError, match="shipped: camera_generalist/anneal, "
                       "camera_generalist/bspline, camera_generalist/fullpace, "
                       "camera_generalist/hairpins, camera_generalist/imitate, "
                       "camera_generalist/pace, camera_generalist/routes, "
                       "camera_generalist/settle, camera_generalist/wide, "
                       "camera_racer/imitate, obstacle_generalist/anneal, "
                       "obstacle_generalist/bots, "
                       "obstacle_generalist/circuits, obstacle_generalist/imitate, "
                       "obstacle_generalist/routes, obstacle_generalist/settle, "
                       "obstacle_generalist/tight, ppo_generalist/finetune, "
                       "ppo_generalist/imitate, ppo_generalist/routes, "
                       "ppo_generalist/routes_imitate, racing_line_student/imitate"):
        resolve_config("smoke", "train")
    with pytest.raises(ValueError, match="config kind must be one of"):
        shipped_configs("tournament")  # type: ignore[arg-type]


def test_the_cli_names_the_shipped_configs() -> None:
    pytest.importorskip("torch")
    from h2h_racing.cli.command import main

    with pytest.raises(SystemExit, match="shipped: recommended, smoke"):
        main(["league", "train", "--config", "no_such_league"])
    with pytest.raises(SystemExit,
                       match="shipped: camera_generalist/anneal, camera_generalist/bspline"):
        main(["train", "--config", "no_such_step", "--out", "unused"])


def test_league_train_seed_overrides_the_config_and_names_its_own_folder(monkeypatch,
                                                                         tmp_path) -> None:
    pytest.importorskip("torch")
    from h2h_racing.cli.command import main
    from h2h_racing.league import selfplay

    made = []

    class Recorder:
        def __init__(self, config, out, **kwargs):
            made.append((config, out))

        def run(self):
            raise SystemExit("stopped before training")

        def close(self):
            pass

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(selfplay, "League", Recorder)
    for argv in (["--config", "smoke", "--seed", "3"], ["--config", "smoke"]):
        with pytest.raises(SystemExit, match="stopped before training"):
            main(["league", "train", *argv, "--no-progress"])
    (seeded, seeded_out), (plain, plain_out) = made
    assert seeded.seed == 3 and str(seeded_out) == "runs/leagues/smoke-seed3"
    # Without --seed: the config's seed and folder; the seed is the only difference.
    assert plain.seed != 3 and str(plain_out) == "runs/leagues/smoke"
    assert dataclasses.replace(seeded, seed=plain.seed) == plain
