"""Tests for h2h_racing.training.config_file: training configs that extend another."""

from __future__ import annotations

from pathlib import Path

import pytest

from h2h_racing.training.config import TrainConfig
from h2h_racing.training.config_file import MAX_DEPTH, read_train_toml

BASE = '''track = "procedural"
num_envs = 64
seed = 3
[procedural]
every = 2
tight_share = 0.3
[imitation]
teacher = "racing_line"
options = { follow_gap = 2.0, closing_speed = 0.3 }
'''


def test_a_file_replaces_keys_and_merges_tables(tmp_path: Path) -> None:
    (tmp_path / "base.toml").write_text(BASE)
    step = tmp_path / "step.toml"
    step.write_text('extends = "base.toml"\nseed = 4\n[procedural]\ncircuit_share = 0.4\n'
                    '[imitation]\noptions = { follow_gap = 1.0 }\n')
    assert read_train_toml(step) == {
        "track": "procedural", "num_envs": 64, "seed": 4,
        # A table keeps the base's other keys ...
        "procedural": {"every": 2, "tight_share": 0.3, "circuit_share": 0.4},
        # ... and a table inside a table is replaced whole (no closing_speed).
        "imitation": {"teacher": "racing_line", "options": {"follow_gap": 1.0}},
    }
    config = TrainConfig.from_toml(step)
    assert (config.seed, config.procedural.every, config.procedural.circuit_share) == (4, 2, 0.4)


def test_extends_a_shipped_config_by_name_through_its_chain(tmp_path: Path) -> None:
    # obstacle_generalist/tight extends anneal.toml beside it: tight's share of tight tracks,
    # anneal's learning rate and teacher.
    step = tmp_path / "step.toml"
    step.write_text('extends = "obstacle_generalist/tight"\nseed = 1\n')
    config = TrainConfig.from_toml(step)
    assert config.seed == 1
    assert config.procedural.tight_share == 0.6
    assert config.distill.learning_rate == 0.00003
    assert config.imitation.teacher == "racing_line"
    assert config.imitation.options["box_clearance"] == 0.2


@pytest.mark.parametrize(("text", "message"), [
    ('extends = "missing.toml"\n', r"extends = 'missing.toml': no file .*missing.toml, and no "
                                   r"shipped training config of that name; shipped: "),
    ("extends = 3\n", r"extends must be the path of a TOML file .* got 3"),
    ('extends = "step.toml"\n', r"extends goes round in a circle"),
])
def test_a_bad_extends_names_the_file_and_what_to_do(tmp_path: Path, text: str,
                                                     message: str) -> None:
    step = tmp_path / "step.toml"
    step.write_text(text)
    with pytest.raises(ValueError, match=message) as err:
        read_train_toml(step)
    assert str(err.value).startswith(str(step))


def test_a_chain_longer_than_the_limit_is_refused(tmp_path: Path) -> None:
    (tmp_path / "c0.toml").write_text("seed = 0\n")
    for i in range(1, MAX_DEPTH + 1):
        (tmp_path / f"c{i}.toml").write_text(f'extends = "c{i - 1}.toml"\nseed = {i}\n')
    assert read_train_toml(tmp_path / f"c{MAX_DEPTH - 1}.toml")["seed"] == MAX_DEPTH - 1
    with pytest.raises(ValueError, match=f"more than {MAX_DEPTH} files extend one another"):
        read_train_toml(tmp_path / f"c{MAX_DEPTH}.toml")


def test_the_train_command_reads_extends(tmp_path: Path) -> None:
    from h2h_racing.training.cli import _train_config

    (tmp_path / "base.toml").write_text(BASE)
    step = tmp_path / "step.toml"
    step.write_text('extends = "base.toml"\n[procedural]\ncircuit_share = 0.4\n')

    class Args:
        config = str(step)

        def __getattr__(self, name: str) -> None:
            return None

    config = _train_config(Args())  # type: ignore[arg-type]
    assert config.procedural.tight_share == 0.3  # type: ignore[attr-defined]
    assert config.procedural.circuit_share == 0.4  # type: ignore[attr-defined]
    (tmp_path / "base.toml").write_text("num_envs = [")
    with pytest.raises(SystemExit, match=r"base.toml: not valid TOML"):
        _train_config(Args())  # type: ignore[arg-type]
