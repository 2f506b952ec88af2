"""A learner's round of PPO, run in a worker process (``train_round``), and its saved state:
``learners/<name>/latest.pt`` (policy file) and ``runner.pt`` (rsl-rl state), written
atomically and copied as a whole (``copy_state``) when the league keeps or puts back a main
agent's best state.

A worker leaves a round's new state in ``learners/<name>/pending/round-<k>/``; the league moves
it in (``install_pending``) only after the store has recorded the round, and on a restart
installs a recorded round's pending state and drops an unrecorded one (``discard_pending``):
a kill at any point trains each recorded round exactly once.

A round stops early, after the iteration that is running, when the league asks it to (its
``stop_file`` exists: a Ctrl-C) or its ``deadline`` has passed (the league's time budget);
the iterations done are kept as the round's training. While it trains, the worker writes its
count of iterations to ``learners/<name>/progress`` for the league's display
(``read_progress``)."""

from __future__ import annotations

import contextlib
import dataclasses
import io
import os
import shutil
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from h2h_racing.league.config import LeagueConfig
from h2h_racing.league.stopping import stop_file_exists


@dataclass(frozen=True)
class TrainJob:
    """One round of PPO for one learner (runs in a worker process)."""

    learner: str
    role: str
    """The learner's role (``ROLES``)."""
    folder: str
    """The learner's folder: ``runner.pt`` (rsl-rl state) and ``latest.pt`` (policy file)."""
    config: LeagueConfig
    round: int
    track: str
    """The round's track (training and evaluation races)."""
    opponents: tuple[str, ...]
    """Driver of the opponent car of each env copy (``make_driver`` names or policy paths)."""
    reset: bool
    """Start from the initial weights (an exploiter reset) instead of the saved state."""
    seed: int
    reload: bool = False
    """Rebuild the learner from its saved state even if this worker holds it in memory (the
    league has put an earlier state back: ``[main_restore] margin``)."""
    stop_file: str | None = None
    """Stop after the running iteration once this file exists (``league.stopping``)."""
    deadline: float | None = None
    """Start no iteration after this time (unix seconds: the league's time budget)."""

    def should_stop(self) -> bool:
        """Whether the round must end before its next iteration."""
        return (self.deadline is not None and time.time() >= self.deadline) or \
            stop_file_exists(self.stop_file)


_RUNNERS: dict[str, tuple[int, Any]] = {}
"""Worker-process cache: learner -> (round it last finished, runner). A worker that trained a
learner last round continues with its runner in memory; any other worker rebuilds it from the
learner's ``runner.pt``. Module-level on purpose: it is the state of one worker process."""


def train_round(job: TrainJob) -> dict[str, float]:
    """Run one round of PPO for ``job.learner`` (fewer iterations when it is asked to stop:
    ``TrainJob.should_stop``); save its state unless no iteration ran; return the round's
    ``steps``, ``seconds`` and ``iterations``."""
    os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")
    # First: without torch, this import's error names the extra to install.
    from h2h_racing.training.policy_file import load_init, load_runner_state, save_policy

    import torch
    from rsl_rl.runners import OnPolicyRunner

    from h2h_racing.training.vec_env import PoolOpponent
    from h2h_racing.track.io import load_track

    torch.set_num_threads(1)
    folder = Path(job.folder)
    iterations = job.config.training.iterations_per_round
    write_progress(folder, job.round, 0, iterations)
    if job.should_stop():
        return {"steps": 0.0, "seconds": 0.0, "iterations": 0.0}
    config = job.config.train_config(job.seed)
    config = dataclasses.replace(config, track=job.track)
    cached = _RUNNERS.get(job.learner)
    opponent = PoolOpponent(job.opponents, seed=job.seed)
    if (cached is not None and cached[0] == job.round - 1 and not job.reset
            and not job.reload):
        runner = cached[1]  # moved to the round's track below
        runner.env.set_opponent(opponent)
    else:
        torch.manual_seed(job.seed)
        env = make_env(config, opponent)
        with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl prints the model summaries
            runner = OnPolicyRunner(env, config.rsl_rl_dict(), log_dir=None, device="cpu")
        state = folder / "runner.pt"
        if state.is_file() and not job.reset:
            load_runner_state(runner, state)  # weights-only, unlike rsl-rl's runner.load
        elif job.config.init is not None:
            load_init(runner, job.config.init)
    start = time.perf_counter()
    track = load_track(job.track)
    if runner.env.track.name != track.name:
        runner.env.set_track(track)
    done = 0
    # One learn() call per iteration, the same updates as learn(iterations) (rsl-rl's loop
    # keeps no state between iterations besides the runner's): a stop request or the budget
    # ends the round after the iteration that is running.
    while done < iterations and not job.should_stop():
        runner.learn(1)
        runner.current_learning_iteration += 1  # rsl-rl's learn() reuses the last index (G3)
        done += 1
        write_progress(folder, job.round, done, iterations)
    seconds = time.perf_counter() - start
    if not done:  # stopped before its first iteration: nothing to keep
        return {"steps": 0.0, "seconds": seconds, "iterations": 0.0}
    # The new state goes to pending/round-<k>/: the league installs it (install_pending) once
    # the store has recorded the round, so a kill in between cannot leave a state trained
    # twice under one recorded round.
    pending = pending_folder(folder, job.round)
    pending.mkdir(parents=True, exist_ok=True)
    atomic(lambda p: runner.save(str(p)), pending / "runner.pt")
    atomic(lambda p: save_policy(runner, config, p), pending / "latest.pt")
    _RUNNERS[job.learner] = (job.round, runner)
    steps = done * config.num_envs * config.num_steps_per_env
    return {"steps": float(steps), "seconds": seconds, "iterations": float(done)}


PROGRESS_FILE = "progress"
"""A learner's iteration count in its running round, in its folder: ``round done total``."""


def write_progress(folder: Path, round_index: int, done: int, total: int) -> None:
    """Write a learner's iteration count (atomically; for the league's display only, so a
    failed write is ignored)."""
    try:
        atomic(lambda p: p.write_text(f"{round_index} {done} {total}\n"),
               folder / PROGRESS_FILE)
    except OSError:
        pass


def read_progress(folder: Path, round_index: int) -> int:
    """Iterations a learner has done in round ``round_index`` (0 when unknown)."""
    try:
        fields = (folder / PROGRESS_FILE).read_text().split()
        return int(fields[1]) if int(fields[0]) == round_index else 0
    except (OSError, ValueError, IndexError):
        return 0


def make_env(config: Any, opponent: Any) -> Any:
    from h2h_racing.training.vec_env import RacingVecEnv

    return RacingVecEnv(config.env_config(), num_envs=config.num_envs, learners=1,
                        opponent=opponent, observations=config.observations, seed=config.seed,
                        expert=config.imitation.expert())


_STATE_FILES = ("latest.pt", "runner.pt")
"""A learner's saved state: its policy checkpoint and its runner (optimiser, std bound)."""


def copy_state(source: Path, target: Path) -> None:
    """Copy a learner's saved state (``_STATE_FILES``) from folder ``source`` to ``target``,
    each file atomically."""
    target.mkdir(exist_ok=True)
    for file in _STATE_FILES:
        atomic(lambda p, f=file: shutil.copyfile(source / f, p), target / file)


def pending_folder(folder: Path, round_index: int) -> Path:
    """Where a worker leaves the state of ``round_index`` until the league records the round."""
    return folder / "pending" / f"round-{round_index}"


def install_pending(folder: Path, round_index: int) -> None:
    """Move the state of ``round_index`` from its pending folder into ``folder`` (each file
    atomically; what a kill leaves behind is moved on the next call) and remove the folder."""
    pending = pending_folder(folder, round_index)
    for file in _STATE_FILES:
        if (pending / file).is_file():
            os.replace(pending / file, folder / file)
    shutil.rmtree(pending, ignore_errors=True)


def discard_pending(folder: Path, recorded_round: int) -> None:
    """Settle the pending states a killed league left in ``folder``: a round the store recorded
    (``<= recorded_round``) is installed, a later one was never recorded and is dropped (the
    round is trained again from the recorded state)."""
    root = folder / "pending"
    if not root.is_dir():
        return
    for pending in sorted(root.glob("round-*"), key=lambda p: int(p.name.removeprefix("round-"))):
        round_index = int(pending.name.removeprefix("round-"))
        if round_index <= recorded_round:
            install_pending(folder, round_index)
        else:
            shutil.rmtree(pending, ignore_errors=True)


def atomic(write: Any, path: Path) -> None:
    """Write via a temporary file and rename, so a killed process never leaves half a file."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    write(tmp)
    os.replace(tmp, path)
