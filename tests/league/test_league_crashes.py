"""A league killed in its crash windows resumes without training a round twice or freezing a
snapshot twice (issue 38, items 5 and 6).

Each test runs ``h2h-racing league train`` in a fresh process with an ``os._exit`` injected
at the exact point (the store call that would record the round or the snapshot), then runs
the same command again and checks what the resumed league holds.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

torch = pytest.importorskip("torch")

REPO = Path(__file__).resolve().parents[2]

CONFIG = """\
name = "tiny"
tracks = ["oval"]
init = "racing_line_student"
anchors = ["racing_line"]
max_rounds = 1
seed = 0

[training]
iterations_per_round = 1
num_envs = 2
num_steps_per_env = 4

[snapshots]
min_rounds = 1
max_rounds = 1

[races]
eval_races = 1
placement_races = 1
laps = 1

[[learners]]
name = "main"
role = "main"
"""

# The round's state is saved by the worker; the os._exit comes before the store records it.
CRASH_BEFORE_ROUND_IS_RECORDED = """
from h2h_racing.league.store import LeagueStore
_set = LeagueStore.set_metas
def _crash(self, values):
    if any(key.endswith(".trained_round") for key in values):
        os._exit(9)
    return _set(self, values)
LeagueStore.set_metas = _crash
"""

# The snapshot player is stored; the os._exit comes before anything else is written.
CRASH_AFTER_SNAPSHOT_PLAYER = """
from h2h_racing.league.store import LeagueStore
_add = LeagueStore.add_player
def _crash(self, player, *args, **kwargs):
    added = _add(self, player, *args, **kwargs)
    if player.kind == "snapshot":
        os._exit(9)
    return added
LeagueStore.add_player = _crash
"""


def _league_train(tmp_path: Path, patch: str = "") -> subprocess.CompletedProcess[str]:
    config = tmp_path / "tiny.toml"
    config.write_text(CONFIG)
    argv = ["league", "train", "--config", str(config), "--out", str(tmp_path / "league"),
            "--backend", "inprocess", "--no-progress"]
    code = (f"import os, sys\n{textwrap.dedent(patch)}\nfrom h2h_racing.cli.command import main\n"
            f"sys.exit(main({argv!r}))\n")
    path = os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])
    env = dict(os.environ, PYTHONPATH=path, GIT_PYTHON_REFRESH="quiet")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600,
                          env=env, cwd=tmp_path, check=False)


def test_kill_before_the_round_is_recorded_trains_it_once(tmp_path):
    """Before: the resumed league trained the learner's saved state again, two PPO rounds
    recorded as one."""
    crashed = _league_train(tmp_path, CRASH_BEFORE_ROUND_IS_RECORDED)
    assert crashed.returncode == 9, crashed.stderr
    resumed = _league_train(tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    from h2h_racing.league.store import LeagueStore

    folder = tmp_path / "league"
    state = torch.load(folder / "learners" / "main" / "runner.pt", weights_only=False)
    assert state["iter"] == 1  # one round of iterations_per_round = 1, not two
    with LeagueStore(folder / "league.sqlite") as store:
        assert store.meta()["main.steps"] == str(1 * 2 * 4)  # iterations x copies x steps
        assert store.meta()["main.trained_round"] == "0"
    assert not list((folder / "learners" / "main").glob("pending/*"))  # settled


def test_kill_between_the_snapshot_writes_freezes_it_once(tmp_path):
    """Before: the snapshot's player was stored, its learner's counter not; the resumed round
    froze the same weights again as main_v2."""
    crashed = _league_train(tmp_path, CRASH_AFTER_SNAPSHOT_PLAYER)
    assert crashed.returncode == 9, crashed.stderr
    resumed = _league_train(tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    from h2h_racing.league.store import LeagueStore

    with LeagueStore(tmp_path / "league" / "league.sqlite") as store:
        snapshots = store.players(kind="snapshot")
    assert [s.name for s in snapshots] == ["main_v1"]
    assert len({s.checkpoint_sha256 for s in snapshots}) == len(snapshots)
