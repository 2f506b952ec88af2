"""Self-play league training: AlphaStar's league, scaled down to one small machine.

Learners (``main``, ``main_exploiter``, ``league_exploiter``) are rsl-rl PPO runners, each on
its own batched ``RacingVecEnv`` with one learner car and one opponent car per env copy. A
*round* is:

1. **Matchmaking**: for each learner, the opponent of each env copy is drawn by its role's rule
   (``league.pfsp.choose_opponents``: prioritised fictitious self-play over the decayed payoff
   table, pure self-play against the learner's own frozen copy of the round's start, the
   current main). Scripted drivers stay in the pool as fixed anchors.
2. **Training**: every learner runs ``iterations_per_round`` PPO iterations (in parallel on
   the backend's workers) and saves ``learners/<name>/latest.pt`` and its runner state.
3. **Evaluation**: each learner races every pool member (and the other learners) in 2-car races
   under race rules, both seat orders on the same seeds; every race is a stored match, and
   each pair of seat orders (legs) updates the payoff table as one result that the grid does
   not decide (``league.racecraft``: a player that won both legs wins, a split goes to the
   lower aggregate time). With ``main_restore_margin`` set, a main agent whose record
   against the anchors falls that far below its best gets its best state back (the exploit
   step of population-based training, the main's own past as the population); with
   ``main_finish_on_best`` the run also ends with each main at its best-record state.
4. **Snapshots**: a learner whose worst decayed win rate against the pool exceeds the
   threshold after ``snapshot_min_rounds`` rounds (forced after ``snapshot_max_rounds``) is
   frozen into a new player; the main exploiter then restarts from the initial weights, a
   league exploiter does so with probability 0.25 (AlphaStar's rules).
5. **Ratings**: each new snapshot plays placement races against every frozen player (anchors
   and earlier snapshots); a Bradley-Terry fit over all placement races (scored as pairs of
   legs, as the payoff table), anchored to
   ``racing_line`` at 1000, is appended to the rating history at the league's step count.

Everything lives in the league folder: ``league.sqlite`` (players, matches, ratings), the
learners' state and the snapshots. Killing the run at any moment and starting it again
continues from the last finished round: matches are keyed by round, so none is counted twice.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import os
import re
import shutil
import sys
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from h2h_racing.league.store import LeagueStore, Player, file_sha256, player_for
from h2h_racing.training.toml_types import check_fields
from h2h_racing.league.tournament import PAIR_ORDERS, Job, make_job, run_job

ROLES = ("main", "main_exploiter", "league_exploiter")
"""Learner roles (AlphaStar's)."""
KL_FLOOR = 0.05
"""Share of the target KL left to a main agent after ``LeagueConfig.main_kl_rounds``."""


@dataclass(frozen=True, kw_only=True)
class LearnerSpec:
    """One learner of the league."""

    name: str
    role: str = "main"
    """One of ``ROLES``."""

    def __post_init__(self) -> None:
        if self.role not in ROLES:
            raise ValueError(f"learner {self.name!r}: role must be one of {ROLES}, got "
                             f"{self.role!r}")
        _check_name("learner name", self.name)


PLAIN_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_-]*")
"""League and learner names: each names a folder (``runs/leagues/<name>``,
``learners/<name>``), so no path separators, dots or ``..``."""


def _check_name(what: str, name: Any) -> None:
    if not isinstance(name, str) or not PLAIN_NAME.fullmatch(name):
        raise ValueError(f"{what} must be a plain name (letters, digits, '_' and '-', not "
                         f"starting with '-'; it names a folder), got {name!r}")


@dataclass(frozen=True, kw_only=True)
class LeagueConfig:
    """A league run (``league/*.toml`` files hold these fields; unknown keys are refused)."""

    name: str = "league"
    """League name (match keys, the store's meta and the default folder
    ``runs/leagues/<name>``): a plain name (``PLAIN_NAME``)."""
    tracks: tuple[str, ...] = ("speedway",)
    """Tracks the league trains and evaluates on, in turn by round."""
    learners: tuple[LearnerSpec, ...] = (
        LearnerSpec(name="main", role="main"),
        LearnerSpec(name="main_exploiter", role="main_exploiter"),
        LearnerSpec(name="league_exploiter", role="league_exploiter"))
    """The learners; at least one ``main``."""
    anchors: tuple[str, ...] = ("racing_line", "pure_pursuit", "blocker")
    """Scripted drivers (or shipped policies) that stay in the pool as fixed anchors."""
    rating_anchor: str = "racing_line"
    """Player held at 1000 in the ratings (must be one of ``anchors``)."""
    init: str | None = "racing_line_student"
    """Policy every learner starts from and exploiters reset to (a shipped policy name or a
    policy.pt; AlphaStar starts from supervised weights); None trains from scratch."""
    minutes: float = 30.0
    """Wall-clock budget; the round that crosses it is the last."""
    max_rounds: int = 1000
    """Round cap."""
    iterations_per_round: int = 20
    """PPO iterations of each learner per round."""
    tracks_per_round: int = 1
    """Tracks each learner trains on per round: the round's iterations are split into this
    many near-equal chunks, each on the next track of ``tracks`` from the round's own (1: the
    whole round on the round's track); evaluation races stay on the round's track. Meant to
    keep a learner from being fitted to the last track it saw (in run 7 of
    experiments/league/README.md it did not stop the main agent's decline)."""
    num_envs: int = 128
    """Env copies per learner."""
    num_steps_per_env: int = 32
    """Rollout length per PPO iteration [steps]."""
    reward: dict[str, float] = field(default_factory=lambda: {
        "progress": 1.0, "off_track": -5.0, "crash": -5.0, "overtake": 1.0})
    """Reward weights (``RewardConfig`` fields): progress, at-fault crashes penalised,
    overtakes rewarded."""
    learning_rate: float = 3e-4
    """PPO learning rate (lower than from-scratch training: learners start from a policy)."""
    entropy_coef: float = 0.003
    """PPO entropy bonus (0 turns it off)."""
    init_std: float = 0.3
    """Policy standard deviation at the start (and after an exploiter reset)."""
    max_std: float | None = 0.5
    """Upper bound of the learners' policy standard deviation (``TrainConfig.max_std``); None
    leaves it unbounded, as in runs 1-7 of experiments/league/README.md, whose main agents'
    std grew from 0.3 to 2-4."""
    eval_races: int = 2
    """Seeds per (learner, opponent) evaluation pairing per round, each in both seat orders."""
    eval_recent: int = 6
    """Snapshots each learner is evaluated against per round: the most recent ones (anchors
    and the other learners always). Older snapshots keep their decayed payoff entries; this
    bounds a round's cost as the pool grows."""
    placement_tracks: tuple[str, ...] = ()
    """Tracks of the placement races that rate snapshots; empty means ``tracks``."""
    placement_races: int = 3
    """Seeds per (snapshot, frozen player) placement pairing, each in both seat orders."""
    laps: int = 2
    """Laps of evaluation and placement races."""
    snapshot_threshold: float = 0.7
    """Snapshot when the learner's worst decayed win rate against the pool exceeds this."""
    snapshot_min_rounds: int = 2
    """Rounds since a learner's last snapshot before the win-rate rule applies."""
    snapshot_max_rounds: int = 4
    """Rounds after which a snapshot is taken regardless (AlphaStar's forced checkpoint)."""
    payoff_decay: float = 0.99
    """Decay of the payoff table's counts per update (AlphaStar)."""
    anchor_share: float = 0.0
    """Share of each learner's env copies raced against the scripted anchors (drawn uniformly),
    the rest matched by the role's rule. With a flat payoff table PFSP spreads copies over
    the whole pool, where the anchors are a few of many players."""
    anchor_weighting: str = "uniform"
    """How the ``anchor_share`` copies are spread over the anchors: ``"uniform"``, or a PFSP
    weighting of the learner's decayed win rate x against each anchor (``pfsp.WEIGHTINGS``:
    ``"linear"`` 1 - x gives the anchor it loses to most copies). In run 9 the main beat
    racing_line and pure_pursuit in 73 % and 86 % of races but passed the blocker twice in 70."""
    imitation_driver: str | None = None
    """A scripted driver each learner is kept near (``TrainConfig.imitation_driver``)."""
    imitation_coef: float = 0.0
    """Weight of that behaviour-cloning term (``TrainConfig.imitation_coef``; 0: off). In
    run 12 (league/README.md) the main stopped passing the blocker after 55 rounds, although
    its start, ``racing_line_student``, and its teacher, ``racing_line``, pass it."""
    imitation_rounds: int | None = None
    """Rounds over which that term fades linearly to 0 (``imitation_coef_at``); None: it
    stays at ``imitation_coef``. Runs 13 and 14 held it constant: the mains kept passing the
    blocker but never learnt to pass the racing line they were held near."""
    main_kl_rounds: int | None = None
    """Rounds over which the main agents' PPO steps shrink (``desired_kl_at``): the target KL
    of the adaptive learning-rate schedule (``PPOConfig.desired_kl``, 0.01) falls linearly
    to ``KL_FLOOR`` (5 %) of itself, then stays there, as the PPO paper anneals its step size
    over training (Schulman et al. 2017, Atari). Exploiters keep full steps (they are reset
    and must learn anew). None: constant. In runs 12 to 15 every main was at its best after
    about 40 rounds and worse at the end (league/README.md)."""
    main_restore_margin: float | None = None
    """Population-based training's exploit step (Jaderberg et al. 2017) with a main agent's
    own past as the population. After each round the main's *record* is its worst undecayed
    win rate against the anchors over the evaluation races of the last ``main_restore_window``
    rounds. A record above the best so far saves the main's state (``learners/<name>/best/``);
    a record more than this margin below the best puts that state back, and the next record
    is judged on a full window of races after it. None: off. In runs 12 to 16
    (league/README.md) every main was at its best around round 40 and worse at the end."""
    main_restore_window: int = 7
    """Rounds of evaluation races in one record (7: one round on each shipped track)."""
    main_finish_on_best: bool = False
    """End the run with each main agent at its best record (needs ``main_restore_margin``):
    a main whose last state is not its best-record state gets that state back when the time
    budget or the round cap is spent, so the run's final main is the state its own evaluation
    races rated best (model selection on held-out races, as early stopping picks a
    checkpoint). In run 18 (league/README.md) the last state and the best differed most
    against the racing line: 53 % and no passes against 66 % and 9 passes."""
    training_rules: str = "training"
    """Rules of the learners' episodes (``TrainConfig.rules``): ``"training"`` ends an episode
    at the first infraction; ``"race"`` gives a time penalty and goes on, as the evaluation
    races do."""
    seed: int = 0
    """Seeds matchmaking, training and races."""

    def __post_init__(self) -> None:
        _check_name("LeagueConfig.name", self.name)
        if not (isinstance(self.anchor_share, (int, float)) and 0.0 <= self.anchor_share <= 1.0):
            raise ValueError(f"LeagueConfig.anchor_share must be a number in [0, 1] (share of "
                             f"env copies), got {self.anchor_share!r}")
        if not (isinstance(self.learning_rate, (int, float)) and self.learning_rate > 0):
            raise ValueError(f"LeagueConfig.learning_rate must be a number > 0, got "
                             f"{self.learning_rate!r}")
        if not (isinstance(self.entropy_coef, (int, float)) and self.entropy_coef >= 0):
            raise ValueError(f"LeagueConfig.entropy_coef must be a number >= 0, got "
                             f"{self.entropy_coef!r}")
        if self.max_std is not None and not (isinstance(self.max_std, (int, float))
                                             and self.max_std > 0):
            raise ValueError(f"LeagueConfig.max_std must be a number > 0 (inf: unbounded), got "
                             f"{self.max_std!r}")
        from h2h_racing.league.pfsp import WEIGHTINGS

        if self.anchor_weighting != "uniform" and self.anchor_weighting not in WEIGHTINGS:
            raise ValueError(f"LeagueConfig.anchor_weighting must be 'uniform' or one of "
                             f"{sorted(WEIGHTINGS)}, got {self.anchor_weighting!r}")
        from h2h_racing.policies.scripted import TEACHERS as SCRIPTED_TEACHERS

        if self.imitation_driver is not None and self.imitation_driver not in SCRIPTED_TEACHERS:
            raise ValueError(f"LeagueConfig.imitation_driver must be one of {SCRIPTED_TEACHERS}, "
                             f"got {self.imitation_driver!r}")
        if not (isinstance(self.imitation_coef, (int, float)) and self.imitation_coef >= 0):
            raise ValueError(f"LeagueConfig.imitation_coef must be a number >= 0, got "
                             f"{self.imitation_coef!r}")
        if self.imitation_coef and self.imitation_driver is None:
            raise ValueError("LeagueConfig.imitation_coef needs an imitation_driver (a scripted "
                             f"driver: {', '.join(SCRIPTED_TEACHERS)})")
        for name in ("imitation_rounds", "main_kl_rounds"):
            rounds = getattr(self, name)
            if rounds is not None and not (isinstance(rounds, int)
                                           and not isinstance(rounds, bool) and rounds >= 1):
                raise ValueError(f"LeagueConfig.{name} must be an integer >= 1 (or left out "
                                 f"for no fading), got {rounds!r}")
        if self.main_restore_margin is not None and not (
                isinstance(self.main_restore_margin, (int, float))
                and not isinstance(self.main_restore_margin, bool)
                and 0.0 <= self.main_restore_margin <= 1.0):
            raise ValueError(f"LeagueConfig.main_restore_margin must be a win-rate margin in "
                             f"[0, 1] (or left out: no restores), got "
                             f"{self.main_restore_margin!r}")
        if not (isinstance(self.main_restore_window, int)
                and not isinstance(self.main_restore_window, bool)
                and self.main_restore_window >= 1):
            raise ValueError(f"LeagueConfig.main_restore_window must be an integer >= 1 "
                             f"(rounds), got {self.main_restore_window!r}")
        if not isinstance(self.main_finish_on_best, bool):
            raise ValueError(f"LeagueConfig.main_finish_on_best must be true or false, got "
                             f"{self.main_finish_on_best!r}")
        if self.main_finish_on_best and self.main_restore_margin is None:
            raise ValueError("LeagueConfig.main_finish_on_best needs main_restore_margin: the "
                             "best state is only kept while restores are on; set "
                             "main_restore_margin (1.0 keeps the best without restoring)")
        if self.training_rules not in ("training", "race"):
            raise ValueError(f"LeagueConfig.training_rules must be 'training' or 'race', got "
                             f"{self.training_rules!r}")
        if not self.learners or not any(s.role == "main" for s in self.learners):
            raise ValueError("a league needs at least one learner with role 'main'")
        names = [s.name for s in self.learners]
        if len(set(names)) != len(names):
            raise ValueError(f"learner names must be distinct, got {names}")
        if set(names) & set(self.anchors):
            raise ValueError(f"learner names {sorted(set(names) & set(self.anchors))} clash "
                             f"with anchors")
        if self.rating_anchor not in self.anchors:
            raise ValueError(f"rating_anchor {self.rating_anchor!r} must be one of the anchors "
                             f"{list(self.anchors)}")
        if not self.tracks:
            raise ValueError("give at least one track")
        if self.eval_recent < 0:
            raise ValueError(f"LeagueConfig.eval_recent must be >= 0, got {self.eval_recent}")
        if not 1 <= self.tracks_per_round <= min(len(self.tracks), self.iterations_per_round):
            raise ValueError(f"LeagueConfig.tracks_per_round must be in [1, min(number of "
                             f"tracks, iterations_per_round)], got {self.tracks_per_round}")
        for name in ("iterations_per_round", "num_envs", "num_steps_per_env", "eval_races",
                     "placement_races", "laps", "snapshot_min_rounds", "max_rounds"):
            if getattr(self, name) < 1:
                raise ValueError(f"LeagueConfig.{name} must be >= 1, got {getattr(self, name)}")
        if self.snapshot_max_rounds < self.snapshot_min_rounds:
            raise ValueError("snapshot_max_rounds must be >= snapshot_min_rounds")
        if not 0.0 < self.payoff_decay <= 1.0 or not 0.0 <= self.snapshot_threshold <= 1.0:
            raise ValueError("payoff_decay must be in (0, 1] and snapshot_threshold in [0, 1]")
        if self.minutes <= 0:
            raise ValueError(f"LeagueConfig.minutes must be > 0, got {self.minutes}")

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "league config") -> LeagueConfig:
        """Build from plain data (a parsed TOML file); unknown keys raise ``ValueError``."""
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"{source}: unknown keys {unknown}; allowed keys are {sorted(known)}")
        # Types first, so that a wrong one is named with its key (not "'<' not supported");
        # one string for a list of names is that one name.
        values = check_fields(cls, data, source)
        if "learners" in values:
            learners = []
            for i, entry in enumerate(values["learners"]):
                if isinstance(entry, LearnerSpec):
                    learners.append(entry)
                    continue
                entry = check_fields(LearnerSpec, entry, source, f"learners[{i}].")
                extra = sorted(set(entry) - {"name", "role"})
                if extra:
                    raise ValueError(f"{source}: learners[{i}] has unknown keys {extra}; "
                                     f"allowed: name, role")
                learners.append(LearnerSpec(**entry))
            values["learners"] = tuple(learners)
        try:
            return cls(**values)
        except TypeError as err:
            raise ValueError(f"{source}: {err}") from None

    @classmethod
    def from_toml(cls, path: str | Path) -> LeagueConfig:
        """Read a league config file."""
        with open(path, "rb") as handle:
            try:
                data = tomllib.load(handle)
            except tomllib.TOMLDecodeError as err:
                raise ValueError(f"{path}: not valid TOML: {err}") from None
        return cls.from_dict(data, source=str(path))

    @property
    def rating_tracks(self) -> tuple[str, ...]:
        """Tracks of the placement races."""
        return self.placement_tracks or self.tracks

    def imitation_coef_at(self, round_index: int) -> float:
        """The behaviour-cloning weight in round ``round_index`` (0-based):
        ``imitation_coef * max(0, 1 - round_index / imitation_rounds)``."""
        return float(self.imitation_coef) * _fade(round_index, self.imitation_rounds, 0.0)

    def desired_kl_at(self, round_index: int, role: str) -> float:
        """The target KL of a learner's PPO steps in round ``round_index`` (0-based): for the
        main agents ``desired_kl * max(KL_FLOOR, 1 - round_index / main_kl_rounds)``, else
        ``desired_kl`` (``PPOConfig``'s)."""
        from h2h_racing.training.config import PPOConfig

        rounds = self.main_kl_rounds if role == "main" else None
        return PPOConfig().desired_kl * _fade(round_index, rounds, KL_FLOOR)

    def train_config(self, seed: int) -> Any:
        """The ``TrainConfig`` of every learner: two cars, one learner, race tracks."""
        from h2h_racing.config import RewardConfig
        from h2h_racing.training.config import PPOConfig, TrainConfig

        return TrainConfig(track=self.tracks[0], num_cars=2, learners=1, opponent=None,
                           num_envs=self.num_envs, num_steps_per_env=self.num_steps_per_env,
                           init_std=self.init_std, max_std=self.max_std,
                           reward=RewardConfig(**self.reward), seed=seed,
                           rules=self.training_rules,
                           imitation_driver=self.imitation_driver,
                           imitation_coef=self.imitation_coef,
                           ppo=PPOConfig(learning_rate=self.learning_rate,
                                         entropy_coef=self.entropy_coef))


def _fade(round_index: int, rounds: int | None, floor: float) -> float:
    """A linear fade over ``rounds`` rounds: ``max(floor, 1 - round_index / rounds)``; 1 for
    ever without ``rounds``."""
    return 1.0 if rounds is None else max(floor, 1.0 - round_index / rounds)


# ------------------------------------------------------------------ learner jobs (workers)


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
    """The round's track (evaluation races; the first training chunk)."""
    opponents: tuple[str, ...]
    """Driver of the opponent car of each env copy (``make_driver`` names or policy paths)."""
    reset: bool
    """Start from the initial weights (an exploiter reset) instead of the saved state."""
    seed: int
    reload: bool = False
    """Rebuild the learner from its saved state even if this worker holds it in memory (the
    league has put an earlier state back: ``LeagueConfig.main_restore_margin``)."""


_RUNNERS: dict[str, tuple[int, Any]] = {}
"""Worker-process cache: learner -> (round it last finished, runner). A worker that trained a
learner last round continues with its runner in memory; any other worker rebuilds it from the
learner's ``runner.pt``. Module-level on purpose: it is the state of one worker process."""


def train_round(job: TrainJob) -> dict[str, float]:
    """Run one round of PPO for ``job.learner``; save its state; return round statistics."""
    os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")
    # First: without torch, this import's error names the extra to install.
    from h2h_racing.training.policy_file import load_init, load_runner_state, save_policy

    import torch
    from rsl_rl.runners import OnPolicyRunner

    from h2h_racing.training.vec_env import PoolOpponent
    from h2h_racing.track_io import load_track

    torch.set_num_threads(1)
    folder = Path(job.folder)
    config = job.config.train_config(job.seed)
    config = dataclasses.replace(config, track=job.track)
    cached = _RUNNERS.get(job.learner)
    opponent = PoolOpponent(job.opponents, seed=job.seed)
    if (cached is not None and cached[0] == job.round - 1 and not job.reset
            and not job.reload):
        runner = cached[1]  # the training loop below moves it to the round's tracks
        runner.env.set_opponent(opponent)
    else:
        torch.manual_seed(job.seed)
        env = _make_env(config, opponent)
        with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl prints the model summaries
            runner = OnPolicyRunner(env, config.rsl_rl_dict(), log_dir=None, device="cpu")
        state = folder / "runner.pt"
        if state.is_file() and not job.reset:
            load_runner_state(runner, state)  # weights-only, unlike rsl-rl's runner.load
        elif job.config.init is not None:
            load_init(runner, job.config.init)
    if job.config.imitation_coef:
        runner.alg.imitation_coef = job.config.imitation_coef_at(job.round)
    runner.alg.desired_kl = job.config.desired_kl_at(job.round, job.role)
    start = time.perf_counter()
    tracks = job.config.tracks
    first = tracks.index(job.track)
    chunks = np.array_split(np.arange(job.config.iterations_per_round),
                            job.config.tracks_per_round)
    for k, chunk in enumerate(chunks):
        track = load_track(tracks[(first + k) % len(tracks)])
        if runner.env.track.name != track.name:
            runner.env.set_track(track)
        runner.learn(len(chunk))
        runner.current_learning_iteration += 1  # rsl-rl's learn() reuses the last index (G3)
    seconds = time.perf_counter() - start
    folder.mkdir(parents=True, exist_ok=True)
    _atomic(lambda p: runner.save(str(p)), folder / "runner.pt")
    _atomic(lambda p: save_policy(runner, config, p), folder / "latest.pt")
    _RUNNERS[job.learner] = (job.round, runner)
    steps = job.config.iterations_per_round * config.num_envs * config.num_steps_per_env
    return {"steps": float(steps), "seconds": seconds}


def _make_env(config: Any, opponent: Any) -> Any:
    from h2h_racing.training.vec_env import RacingVecEnv

    return RacingVecEnv(config.env_config(), num_envs=config.num_envs, learners=1,
                        opponent=opponent, observations=config.observations, seed=config.seed,
                        expert=config.expert())


_STATE_FILES = ("latest.pt", "runner.pt")
"""A learner's saved state: its policy checkpoint and its runner (optimiser, std bound)."""


def _copy_state(source: Path, target: Path) -> None:
    """Copy a learner's saved state (``_STATE_FILES``) from folder ``source`` to ``target``,
    each file atomically."""
    target.mkdir(exist_ok=True)
    for file in _STATE_FILES:
        _atomic(lambda p, f=file: shutil.copyfile(source / f, p), target / file)


def _round_of(key: str, context: str) -> int:
    """The round of an evaluation match key ``<context>:round=<r>:...`` (``League._jobs``)."""
    head = f"{context}:round="
    if not key.startswith(head):
        raise ValueError(f"match key {key!r} is not a round's evaluation key ({head}<r>:...)")
    return int(key[len(head):].split(":", 1)[0])


def _atomic(write: Any, path: Path) -> None:
    """Write via a temporary file and rename, so a killed process never leaves half a file."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    write(tmp)
    os.replace(tmp, path)


# ------------------------------------------------------------------ the league (driver)


class League:
    """A league run in ``folder`` (see the module docstring).

    Args:
        config: The league.
        folder: Where the store, learners and snapshots live; an existing league folder of
            the same name is continued.
        backend: Where learner rounds and matches run (``league.backends``); None: in process.
        out: Progress display stream (None: stderr).
    """

    def __init__(self, config: LeagueConfig, folder: str | Path, backend: Any | None = None,
                 out: TextIO | None = None) -> None:
        from h2h_racing.league.backends import InProcessBackend

        self.config = config
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.store = LeagueStore(self.folder / "league.sqlite", name=config.name)
        stored = self.store.meta().get("league_name")
        if stored is not None and stored != config.name:
            raise ValueError(f"{self.folder} holds league {stored!r}, not {config.name!r}; "
                             f"give another folder")
        self.store.set_meta("league_name", config.name)
        self.backend = backend or InProcessBackend()
        self.out = out or sys.stderr
        self.rng = np.random.default_rng(config.seed)
        self.timings: dict[str, float] = {}
        """Seconds spent in each phase of the last round (train, evaluate, place)."""
        for anchor in config.anchors:
            self.store.add_player(player_for(anchor))
        for spec in config.learners:
            self.store.add_player(Player(name=spec.name, kind="learner", role=spec.role,
                                         checkpoint=str(self._latest(spec.name))))
            if config.init is not None and not self._latest(spec.name).exists():
                self._latest(spec.name).parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(player_for(config.init).checkpoint or config.init,
                                self._latest(spec.name))

    # ---- paths and pool

    def _latest(self, learner: str) -> Path:
        return self.folder / "learners" / learner / "latest.pt"

    def snapshots(self) -> list[Player]:
        """Frozen learner snapshots, oldest first."""
        return self.store.players(kind="snapshot")

    def _driver_spec(self, name: str) -> str:
        """What ``make_driver`` builds player ``name`` from."""
        player = self.store.player(name)
        if player is None:
            raise KeyError(name)
        return player.checkpoint or name

    def _opponents(self, spec: LearnerSpec, pool: list[Any], mains: list[str],
                   payoff: Any) -> list[str]:
        """The opponent of each env copy of ``spec``: ``anchor_share`` of the copies against
        an anchor drawn by ``anchor_weighting``, the rest by the role's matchmaking rule, in
        random order."""
        from h2h_racing.league.pfsp import choose_opponents, pfsp_weights

        cfg = self.config
        fixed = int(round(cfg.anchor_share * cfg.num_envs))
        weights = None
        if cfg.anchor_weighting != "uniform":
            weights = pfsp_weights(payoff.win_rates(spec.name, list(cfg.anchors)),
                                   cfg.anchor_weighting)
        names = [str(name) for name in self.rng.choice(list(cfg.anchors), size=fixed,
                                                       p=weights)]
        names += choose_opponents(self.rng, spec.name, spec.role, pool, mains, payoff,
                                  cfg.num_envs - fixed)
        return [names[i] for i in self.rng.permutation(len(names))]

    def _pool(self) -> list[Any]:
        from h2h_racing.league.pfsp import PoolEntry

        pool = [PoolEntry(name=a, role="scripted", parent=None) for a in self.config.anchors]
        pool += [PoolEntry(name=s.name, role=s.role or "main", parent=s.parent)
                 for s in self.snapshots()]
        return pool

    # ---- state kept in the store

    def _round(self) -> int:
        return int(self.store.meta().get("round", "0"))

    def _learner_meta(self, learner: str, key: str, default: float = 0.0) -> float:
        return float(self.store.meta().get(f"{learner}.{key}", str(default)))

    def _payoff(self) -> Any:
        from h2h_racing.league.pfsp import Payoff

        return Payoff.from_races(self._paired("eval"), decay=self.config.payoff_decay)

    def _paired(self, kind: str) -> list[dict[str, float]]:
        """Results of the stored ``kind`` races, both legs of a start point (one from each
        grid slot) scored as one result so the grid does not decide it
        (``league.racecraft``)."""
        from h2h_racing.league.racecraft import paired_races

        return paired_races(self.store.matches(context=self._context(kind))).races

    def _context(self, kind: str) -> str:
        return f"league:{self.config.name}:{kind}"

    # ---- the loop

    def run(self) -> None:
        """Run rounds until the time budget or the round cap is spent."""
        start = time.perf_counter()
        first = self._round()
        for round_index in range(first, self.config.max_rounds):
            self.round(round_index)
            self.store.set_meta("round", str(round_index + 1))
            elapsed = (time.perf_counter() - start) / 60.0
            self._show(round_index, elapsed)
            if elapsed >= self.config.minutes:
                break
        if self.config.main_finish_on_best:
            for spec in self.config.learners:
                if spec.role == "main":
                    self._finish_on_best(spec.name)

    def round(self, round_index: int) -> None:
        """One round: matchmaking, training, evaluation, snapshots, ratings."""
        from h2h_racing.league.pfsp import resets_on_snapshot, should_snapshot

        cfg = self.config
        track = cfg.tracks[round_index % len(cfg.tracks)]
        payoff = self._payoff()
        pool = self._pool()
        mains = [s.name for s in cfg.learners if s.role == "main"]
        jobs = []
        for k, spec in enumerate(cfg.learners):
            if self._learner_meta(spec.name, "trained_round", -1) >= round_index:
                continue  # trained before a restart
            names = self._opponents(spec, pool, mains, payoff)
            specs = tuple(self._opponent_spec(name) for name in names)
            reset = bool(self._learner_meta(spec.name, "reset", 0.0))
            jobs.append(TrainJob(learner=spec.name, role=spec.role,
                                 folder=str(self._latest(spec.name).parent), config=cfg,
                                 round=round_index, track=track, opponents=specs, reset=reset,
                                 seed=cfg.seed + 1000 * round_index + k,
                                 reload=bool(self._learner_meta(spec.name, "reload", 0.0))))
        clock = time.perf_counter()
        for job, stats in self.backend.map(train_round, jobs):
            name = job.learner
            self.store.set_metas({
                f"{name}.steps": str(int(self._learner_meta(name, "steps") + stats["steps"])),
                f"{name}.reset": "0",
                f"{name}.reload": "0",
                f"{name}.trained_round": str(round_index),
                f"{name}.rounds_since_snapshot":
                    str(int(self._learner_meta(name, "rounds_since_snapshot")) + 1)})
        self.timings["train"] = time.perf_counter() - clock
        clock = time.perf_counter()
        self._evaluate(round_index, track)
        self.timings["evaluate"] = time.perf_counter() - clock
        if cfg.main_restore_margin is not None:
            for name in mains:
                self._keep_best(name, round_index)
        clock = time.perf_counter()
        payoff = self._payoff()
        for spec in cfg.learners:
            # AlphaStar judges a main exploiter against the mains, the others against the
            # whole pool.
            judged = mains if spec.role == "main_exploiter" else [p.name for p in pool]
            since = int(self._learner_meta(spec.name, "rounds_since_snapshot"))
            if should_snapshot(since >= cfg.snapshot_min_rounds,
                               since >= cfg.snapshot_max_rounds,
                               payoff.win_rates(spec.name, judged), cfg.snapshot_threshold):
                self._snapshot(spec, reset=resets_on_snapshot(self.rng, spec.role))
        self._place()
        self.timings["place"] = time.perf_counter() - clock

    def _opponent_spec(self, name: str) -> str:
        """Driver spec of a matchmaking choice (a learner's name means its latest weights)."""
        if any(s.name == name for s in self.config.learners):
            latest = self._latest(name)
            if latest.exists():
                return str(latest)
            return self.config.rating_anchor
        return self._driver_spec(name)

    def _jobs(self, kind: str, round_index: int | None, pairs: list[tuple[str, str]],
              track: str, races: int) -> list[Job]:
        """2-car jobs of ``pairs`` (both seat orders) not yet stored (for this round)."""
        context = self._context(kind)
        prefix = context if round_index is None else f"{context}:round={round_index}"
        done = self.store.done_keys(prefix + ":")
        # Evaluation races start at new points every round; placement races at fixed ones.
        seed = self.config.seed + (0 if round_index is None else 7919 * (round_index + 1))
        jobs = [make_job(track, (a, b), {a: self._opponent_spec(a), b: self._opponent_spec(b)},
                         PAIR_ORDERS, range(races), prefix, done, laps=self.config.laps,
                         seed=seed, context=context) for a, b in pairs]
        return [job for job in jobs if job is not None]

    def _evaluate(self, round_index: int, track: str) -> None:
        """Each learner against the anchors, the most recent snapshots and the other
        learners."""
        cfg = self.config
        snapshots = [s.name for s in self.snapshots()]
        opponents = list(cfg.anchors) + (snapshots[-cfg.eval_recent:] if cfg.eval_recent else [])
        learners = [s.name for s in cfg.learners]
        pairs = [(learner, other) for learner in learners for other in opponents]
        pairs += [(a, b) for i, a in enumerate(learners) for b in learners[i + 1:]]
        self._play(self._jobs("eval", round_index, pairs, track, cfg.eval_races))

    def record(self, learner: str, round_index: int) -> float | None:
        """``learner``'s worst win rate against the anchors in the evaluation races of rounds
        ``round_index - main_restore_window + 1`` to ``round_index`` (each race counted once,
        a tie as half a win); None if it did not race every anchor in them."""
        from h2h_racing.league.pfsp import Payoff

        first = round_index - self.config.main_restore_window + 1
        context = self._context("eval")
        races = [m.places for m in self.store.matches(context=context)
                 if learner in m.places and first <= _round_of(m.key, context) <= round_index]
        payoff = Payoff.from_races(races, decay=1.0)
        anchors = list(self.config.anchors)
        if min(payoff.games(learner, a) for a in anchors) == 0:
            return None
        return float(payoff.win_rates(learner, anchors).min())

    def _keep_best(self, learner: str, round_index: int) -> None:
        """Save ``learner``'s state when its record is the best so far; put the best state
        back when its record is more than ``main_restore_margin`` below the best
        (``LeagueConfig.main_restore_margin``). Files first, then the store: a run killed in
        between repeats the same copies when it resumes the round."""
        cfg = self.config
        window = cfg.main_restore_window
        if round_index < self._learner_meta(learner, "judge_from", window - 1):
            return
        record = self.record(learner, round_index)
        if record is None:
            return
        folder = self._latest(learner).parent
        best = self._learner_meta(learner, "best_record", -1.0)
        if record > best:
            _copy_state(folder, folder / "best")
            self.store.set_metas({f"{learner}.best_record": repr(record),
                                  f"{learner}.best_round": str(round_index)})
        elif record < best - cfg.main_restore_margin:
            restores = int(self._learner_meta(learner, "restores")) + 1
            self._put_back_best(learner, round_index, {f"{learner}.restores": str(restores)})
            best_round = int(self._learner_meta(learner, "best_round"))
            print(f"[league {cfg.name}] round {round_index + 1}: {learner}'s record against "
                  f"the anchors {record:.2f} < best {best:.2f} - {cfg.main_restore_margin}: "
                  f"restored its state after round {best_round + 1}",
                  file=self.out, flush=True)

    def _put_back_best(self, learner: str, round_index: int,
                       metas: dict[str, str] | None = None) -> None:
        """Copy ``learner``'s best state over its latest after round ``round_index`` and
        store ``metas`` with the reload: the next round rebuilds the learner from there, and
        its next record is judged on a full window of races after it."""
        folder = self._latest(learner).parent
        _copy_state(folder / "best", folder)
        self.store.set_metas({
            **(metas or {}), f"{learner}.reload": "1",
            f"{learner}.judge_from": str(round_index + self.config.main_restore_window)})

    def _finish_on_best(self, learner: str) -> None:
        """Leave ``learner`` at its best-record state at the end of a run
        (``LeagueConfig.main_finish_on_best``); nothing if it is there already or no record
        was ever made."""
        meta = self.store.meta()
        last = self._round() - 1
        if f"{learner}.best_round" not in meta or int(meta[f"{learner}.best_round"]) == last:
            return
        self._put_back_best(learner, last)
        best_round = int(meta[f"{learner}.best_round"])
        print(f"[league {self.config.name}] finished {learner} on its best record "
              f"({float(meta[f'{learner}.best_record']):.2f}): its state after round "
              f"{best_round + 1}, not round {last + 1}", file=self.out, flush=True)

    def _play(self, jobs: list[Job]) -> None:
        for _job_done, records in self.backend.map(run_job, jobs):
            for record in records:
                self.store.record_match(record)

    def _snapshot(self, spec: LearnerSpec, reset: bool) -> None:
        """Freeze ``spec``'s latest weights into a new player (placed by ``_place``)."""
        count = sum(1 for s in self.snapshots() if s.parent == spec.name)
        name = f"{spec.name}_v{count + 1}"
        path = self.folder / "snapshots" / f"{name}.pt"
        path.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(self._latest(spec.name), path)
        steps = int(self._learner_meta(spec.name, "steps"))
        self.store.add_player(Player(name=name, kind="snapshot", role=spec.role,
                                     parent=spec.name, checkpoint=str(path),
                                     checkpoint_sha256=file_sha256(path),
                                     training_steps=steps))
        self.store.set_metas({f"{spec.name}.rounds_since_snapshot": "0",
                              f"{spec.name}.reset": "1" if reset else "0"})

    def _place(self) -> None:
        """Placement races that are not stored yet: the anchors against each other, and every
        snapshot against every older frozen player (anchors and earlier snapshots); then refit
        the ratings."""
        anchors = list(self.config.anchors)
        pairs = [(a, b) for i, a in enumerate(anchors) for b in anchors[i + 1:]]
        older = list(anchors)
        for snapshot in self.snapshots():
            pairs += [(snapshot.name, other) for other in older]
            older.append(snapshot.name)
        jobs = [job for track in self.config.rating_tracks
                for job in self._jobs("placement", None, pairs, track,
                                      self.config.placement_races)]
        if jobs:
            self._play(jobs)
            self._rate()

    def league_steps(self) -> int:
        """Agent steps trained by all learners together."""
        return int(sum(self._learner_meta(s.name, "steps") for s in self.config.learners))

    def _rate(self) -> None:
        from h2h_racing.league.ratings import standings

        races = self._paired("placement")
        if not races:
            return
        rows = standings(races, anchor=self.config.rating_anchor, n_boot=100,
                         rng=np.random.default_rng(self.config.seed))
        self.store.record_ratings("bradley_terry", {r.player: r.rating for r in rows},
                                  {r.player: (r.low, r.high) for r in rows},
                                  training_steps=self.league_steps(), matches=len(races))

    def standings(self) -> list[Any]:
        """Current standings of the frozen players (placement races)."""
        from h2h_racing.league.ratings import standings

        races = self._paired("placement")
        return standings(races, anchor=self.config.rating_anchor, n_boot=100,
                         rng=np.random.default_rng(self.config.seed)) if races else []

    def _show(self, round_index: int, minutes: float) -> None:
        rows = self.standings()[:3]
        top = ", ".join(f"{r.player} {r.rating:.0f}" for r in rows) or "-"
        print(f"[league {self.config.name}] round {round_index + 1}  {minutes:5.1f} min  "
              f"{self.league_steps() / 1e6:6.2f} M steps  snapshots {len(self.snapshots())}  "
              f"top: {top}  (train {self.timings.get('train', 0):.0f} s, evaluate "
              f"{self.timings.get('evaluate', 0):.0f} s, place {self.timings.get('place', 0):.0f} s)",
              file=self.out, flush=True)
        self._show_racecraft(round_index)

    def _show_racecraft(self, round_index: int) -> None:
        """Each learner's record against the anchors in the round's evaluation races, by
        grid slot (``league.racecraft``)."""
        from h2h_racing.league.racecraft import racecraft_records

        context = self._context("eval")
        matches = [m for m in self.store.matches(context=context)
                   if _round_of(m.key, context) == round_index]
        for spec in self.config.learners:
            record = racecraft_records(matches, spec.name, self.config.anchors).get("all")
            if record is not None:
                record = dataclasses.replace(record, opponent="the anchors")
                print(f"  {record.line()}", file=self.out, flush=True)

    def close(self) -> None:
        """Release the store and the backend."""
        self.store.close()
        self.backend.close()
