"""What a self-play league is: ``LeagueConfig`` (frozen, validated) and the tables it is made
of. The run itself is ``h2h_racing.league.selfplay``.

A league file (``league/recommended.toml``) holds the league's own keys at the top (name,
tracks, anchors, the budget) and one table per concern: ``[[learners]]`` (the roles),
``[training]`` (each learner's PPO rounds), ``[reward]``, ``[imitation]``, ``[matchmaking]``,
``[snapshots]``, ``[races]`` (evaluation and placement races) and ``[main_restore]``. Unknown
keys are refused, naming the allowed ones; a key of the earlier flat layout names the table it
moved to, and a removed knob says why it went.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from h2h_racing.config.checks import _is_int as _is_integer
from h2h_racing.config.checks import _is_number
from h2h_racing.training.imitation import ImitationConfig
from h2h_racing.training.limits import MAX_NUM_ENVS, MAX_STEPS_PER_ENV, check_count, check_rollout
from h2h_racing.training.toml_types import build_tables, check_fields, read_toml

ROLES = ("main", "main_exploiter", "league_exploiter")
"""Learner roles (AlphaStar's)."""
PLAIN_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_-]*")
"""League and learner names: each names a folder (``runs/leagues/<name>``,
``learners/<name>``), so no path separators, dots or ``..``."""


def _check_name(what: str, name: Any) -> None:
    if not isinstance(name, str) or not PLAIN_NAME.fullmatch(name):
        raise ValueError(f"{what} must be a plain name (letters, digits, '_' and '-', not "
                         f"starting with '-'; it names a folder), got {name!r}")


def _anchor(name: Any, key: str = "anchors") -> str:
    """An anchor as its player is named: a scripted driver's spec written back
    (``canonical_spec``), else the shipped policy's name or ``policy.pt`` path as given."""
    from h2h_racing.policies.registry import canonical_spec

    try:
        return canonical_spec(name)
    except ValueError as err:
        raise ValueError(f"LeagueConfig.{key}: {err}") from None


def _is_int(value: Any, low: int = 1) -> bool:
    return _is_integer(value) and value >= low


@dataclass(frozen=True, kw_only=True)
class LearnerSpec:
    """One learner of the league (a ``[[learners]]`` entry)."""

    name: str
    role: str = "main"
    """One of ``ROLES``."""

    def __post_init__(self) -> None:
        if self.role not in ROLES:
            raise ValueError(f"learner {self.name!r}: role must be one of {ROLES}, got "
                             f"{self.role!r}")
        _check_name("learner name", self.name)


@dataclass(frozen=True, kw_only=True)
class LearnerTraining:
    """``[training]``: each learner's PPO rounds."""

    iterations_per_round: int = 20
    """PPO iterations of each learner per round, on the round's track."""
    num_envs: int = 128
    """Env copies per learner."""
    num_steps_per_env: int = 32
    """Rollout length per PPO iteration [steps]."""
    learning_rate: float = 3e-4
    """PPO learning rate (lower than from-scratch training: learners start from a policy)."""
    entropy_coef: float = 0.003
    """PPO entropy bonus (0 turns it off)."""
    num_learning_epochs: int = 4
    """PPO passes over each rollout."""
    num_mini_batches: int = 4
    """PPO mini-batches per pass (fewer: bigger ones). 2 epochs x 2 mini-batches make a
    2-car learner's iteration 1.45x as fast as 4 x 4 (``benchmarks/bench_train.py --cars 2
    --envs 128``), more experience per league minute for the same gradient steps per second."""
    init_std: float = 0.3
    """Policy standard deviation at the start (and after an exploiter reset)."""
    max_std: float | None = 0.5
    """Upper bound of the learners' policy standard deviation (``TrainConfig.max_std``); None
    leaves it unbounded, as in runs 1-7 of experiments/league/README.md, whose main agents'
    std grew from 0.3 to 2-4."""
    rules: str = "training"
    """Rules of the learners' episodes (``TrainConfig.rules``): ``"training"`` ends an episode
    at the first infraction; ``"race"`` gives a time penalty and goes on, as the evaluation
    races do."""

    def __post_init__(self) -> None:
        for name in ("iterations_per_round", "num_envs", "num_steps_per_env",
                     "num_learning_epochs", "num_mini_batches"):
            if not _is_int(getattr(self, name)):
                raise ValueError(f"[training] {name} must be an integer >= 1, got "
                                 f"{getattr(self, name)!r}")
        check_count(self.num_envs, "[training]", "num_envs", MAX_NUM_ENVS)
        check_count(self.num_steps_per_env, "[training]", "num_steps_per_env", MAX_STEPS_PER_ENV)
        check_rollout(self.num_envs, self.num_steps_per_env, 0, "[training]")
        if not (_is_number(self.learning_rate) and self.learning_rate > 0):
            raise ValueError(f"[training] learning_rate must be a number > 0, got "
                             f"{self.learning_rate!r}")
        if not (_is_number(self.entropy_coef) and self.entropy_coef >= 0):
            raise ValueError(f"[training] entropy_coef must be a number >= 0, got "
                             f"{self.entropy_coef!r}")
        if not (_is_number(self.init_std) and self.init_std > 0):
            raise ValueError(f"[training] init_std must be a number > 0, got {self.init_std!r}")
        if self.max_std is not None and not (_is_number(self.max_std) and self.max_std > 0):
            raise ValueError(f"[training] max_std must be a number > 0 (inf: unbounded), got "
                             f"{self.max_std!r}")
        if self.rules not in ("training", "race"):
            raise ValueError(f"[training] rules must be 'training' or 'race', got "
                             f"{self.rules!r}")


@dataclass(frozen=True, kw_only=True)
class Matchmaking:
    """``[matchmaking]``: how each learner's env copies get their opponents
    (``league.pfsp``)."""

    anchor_share: float = 0.0
    """Share of each learner's env copies raced against the scripted anchors, the rest matched
    by the role's rule. With a flat payoff table PFSP spreads copies over the whole pool,
    where the anchors are a few of many players."""
    anchor_weighting: str = "uniform"
    """How the ``anchor_share`` copies are spread over the anchors: ``"uniform"``, or a PFSP
    weighting of the learner's decayed win rate x against each anchor (``pfsp.WEIGHTINGS``:
    ``"linear"`` 1 - x gives the anchor it loses to most copies). In run 9 the main beat
    racing_line and pure_pursuit in 73 % and 86 % of races but passed the blocker twice in 70."""
    payoff_decay: float = 0.99
    """Decay of the payoff table's counts per update (AlphaStar)."""

    def __post_init__(self) -> None:
        from h2h_racing.league.pfsp import WEIGHTINGS

        if not (_is_number(self.anchor_share) and 0.0 <= self.anchor_share <= 1.0):
            raise ValueError(f"[matchmaking] anchor_share must be a number in [0, 1] (share "
                             f"of env copies), got {self.anchor_share!r}")
        if self.anchor_weighting != "uniform" and self.anchor_weighting not in WEIGHTINGS:
            raise ValueError(f"[matchmaking] anchor_weighting must be 'uniform' or one of "
                             f"{sorted(WEIGHTINGS)}, got {self.anchor_weighting!r}")
        if not (_is_number(self.payoff_decay) and 0.0 < self.payoff_decay <= 1.0):
            raise ValueError(f"[matchmaking] payoff_decay must be in (0, 1], got "
                             f"{self.payoff_decay!r}")


@dataclass(frozen=True, kw_only=True)
class Snapshots:
    """``[snapshots]``: when a learner is frozen into a new player."""

    threshold: float = 0.7
    """Snapshot when the learner's worst decayed win rate against the pool exceeds this."""
    min_rounds: int = 2
    """Rounds since a learner's last snapshot before the win-rate rule applies."""
    max_rounds: int = 4
    """Rounds after which a snapshot is taken regardless (AlphaStar's forced checkpoint)."""

    def __post_init__(self) -> None:
        if not (_is_number(self.threshold) and 0.0 <= self.threshold <= 1.0):
            raise ValueError(f"[snapshots] threshold must be in [0, 1], got "
                             f"{self.threshold!r}")
        if not _is_int(self.min_rounds):
            raise ValueError(f"[snapshots] min_rounds must be an integer >= 1, got "
                             f"{self.min_rounds!r}")
        if not (_is_int(self.max_rounds) and self.max_rounds >= self.min_rounds):
            raise ValueError(f"[snapshots] max_rounds must be an integer >= min_rounds "
                             f"({self.min_rounds}), got {self.max_rounds!r}")


@dataclass(frozen=True, kw_only=True)
class RaceSchedule:
    """``[races]``: the evaluation races of each round and the placement races that rate
    snapshots."""

    laps: int = 2
    """Laps of evaluation and placement races."""
    eval_races: int = 2
    """Seeds per (learner, opponent) evaluation pairing per round, each in both seat orders."""
    eval_recent: int = 6
    """Snapshots each learner is evaluated against per round: the most recent ones (anchors
    and the other learners always). Older snapshots keep their decayed payoff entries; this
    bounds a round's cost as the pool grows."""
    placement_tracks: tuple[str, ...] = ()
    """Tracks of the placement races; empty means the league's ``tracks``."""
    placement_races: int = 3
    """Seeds per (snapshot, frozen player) placement pairing, each in both seat orders."""

    def __post_init__(self) -> None:
        for name in ("laps", "eval_races", "placement_races"):
            if not _is_int(getattr(self, name)):
                raise ValueError(f"[races] {name} must be an integer >= 1, got "
                                 f"{getattr(self, name)!r}")
        if not _is_int(self.eval_recent, low=0):
            raise ValueError(f"[races] eval_recent must be an integer >= 0, got "
                             f"{self.eval_recent!r}")


@dataclass(frozen=True, kw_only=True)
class MainRestore:
    """``[main_restore]``: population-based training's exploit step (Jaderberg et al. 2017)
    with a main agent's own past as the population.

    After each round the main's *record* is its worst clean win rate from behind against the
    anchors over the evaluation races of the last ``window`` rounds (``League.record``: the
    races it started behind, won without causing a crash). A record above the best so far
    saves the main's state (``learners/<name>/best/``); a record more than ``margin`` below
    the best puts that state back, and the next record is judged on a full window of races
    after it. In runs 12 to 16 (experiments/league/README.md) every main was at its best
    around round 40 and worse at the end.
    """

    margin: float | None = None
    """Win-rate margin below the best record that puts the best state back; None: off."""
    window: int = 7
    """Rounds of evaluation races in one record (7: one round on each shipped track)."""
    finish_on_best: bool = False
    """End the run with each main agent at its best record (needs ``margin``): a main whose
    last state is not its best-record state gets that state back when the time budget or the
    round cap is spent (model selection on held-out races, as early stopping picks a
    checkpoint). In run 18 the last state and the best differed most against the racing
    line: 53 % and no passes against 66 % and 9 passes."""

    def __post_init__(self) -> None:
        if self.margin is not None and not (_is_number(self.margin)
                                            and 0.0 <= self.margin <= 1.0):
            raise ValueError(f"[main_restore] margin must be a win-rate margin in [0, 1] (or "
                             f"left out: no restores), got {self.margin!r}")
        if not _is_int(self.window):
            raise ValueError(f"[main_restore] window must be an integer >= 1 (rounds), got "
                             f"{self.window!r}")
        if not isinstance(self.finish_on_best, bool):
            raise ValueError(f"[main_restore] finish_on_best must be true or false, got "
                             f"{self.finish_on_best!r}")
        if self.finish_on_best and self.margin is None:
            raise ValueError("[main_restore] finish_on_best needs margin: the best state is "
                             "only kept while restores are on; set margin (1.0 keeps the "
                             "best without restoring)")


TABLES: dict[str, type] = {"training": LearnerTraining, "imitation": ImitationConfig,
                           "matchmaking": Matchmaking, "snapshots": Snapshots,
                           "races": RaceSchedule, "main_restore": MainRestore}
"""``LeagueConfig``'s tables and the configs they fill."""
MOVED = {
    **{key: f"[training] {key}" for key in ("iterations_per_round", "num_envs",
                                            "num_steps_per_env", "learning_rate",
                                            "entropy_coef", "init_std", "max_std")},
    "training_rules": "[training] rules", "imitation_driver": "[imitation] driver",
    "imitation_coef": "[imitation] coef", "anchor_share": "[matchmaking] anchor_share",
    "anchor_weighting": "[matchmaking] anchor_weighting",
    "payoff_decay": "[matchmaking] payoff_decay", "snapshot_threshold": "[snapshots] threshold",
    "snapshot_min_rounds": "[snapshots] min_rounds",
    "snapshot_max_rounds": "[snapshots] max_rounds",
    **{key: f"[races] {key}" for key in ("laps", "eval_races", "eval_recent",
                                         "placement_tracks", "placement_races")},
    "main_restore_margin": "[main_restore] margin", "main_restore_window": "[main_restore] window",
    "main_finish_on_best": "[main_restore] finish_on_best"}
"""Top-level keys of the earlier flat layout and where they are now."""
REMOVED = {
    "tracks_per_round": "splitting a round over several tracks did not stop the main's "
                        "decline (run 7)",
    "imitation_rounds": "fading the imitation term out collapsed the main: it passed nobody "
                        "once the term reached 0 (run 15)",
    "main_kl_rounds": "shrinking the main's PPO steps made it steadier but never better: it "
                      "never learnt to pass the racing line (run 16)"}
"""Knobs that were tried and removed, and why (experiments/league/README.md; the configs of
those runs load with the code of their commit)."""


DEFAULT_MAX_ROUNDS = 1000
"""``LeagueConfig.max_rounds`` when a config sets none (the budget ends such a league)."""


@dataclass(frozen=True, kw_only=True)
class LeagueConfig:
    """A league run (``league/*.toml`` files hold these fields and tables)."""

    name: str = "league"
    """League name (match keys, the store's meta and the default folder
    ``runs/leagues/<name>``): a plain name (``PLAIN_NAME``)."""
    tracks: tuple[str, ...] = ("speedway",)
    """Tracks the league trains and evaluates on, in turn by round."""
    learners: tuple[LearnerSpec, ...] = (
        LearnerSpec(name="main", role="main"),
        LearnerSpec(name="main_exploiter", role="main_exploiter"),
        LearnerSpec(name="league_exploiter", role="league_exploiter"))
    """The learners and their roles; at least one ``main``."""
    anchors: tuple[str, ...] = ("racing_line", "pure_pursuit", "blocker")
    """Scripted drivers (with any settings, ``racing_line:grip_factor=0.7``; kept as their
    spec written back, the player's name) or shipped policies that stay in the pool as fixed
    anchors."""
    rating_anchor: str = "racing_line"
    """Player held at 1000 in the ratings (must be one of ``anchors``)."""
    init: str | None = "racing_line_student"
    """Policy every learner starts from and exploiters reset to (a shipped policy name or a
    policy.pt; AlphaStar starts from supervised weights); None trains from scratch."""
    minutes: float = 30.0
    """Time budget [min] of the league over all its runs (``league train --this-run``: of
    one run): a run stops within one training iteration or race job of it, and the next run
    resumes the round it stopped in."""
    max_rounds: int = DEFAULT_MAX_ROUNDS
    """Round cap."""
    seed: int = 0
    """Seeds matchmaking, training and races."""
    reward: dict[str, float] = field(default_factory=lambda: {
        "progress": 1.0, "off_track": -5.0, "crash": -5.0, "overtake": 1.0})
    """``[reward]``: reward weights (``RewardConfig`` fields): progress, at-fault crashes
    penalised, overtakes rewarded."""
    training: LearnerTraining = field(default_factory=LearnerTraining)
    """``[training]``: each learner's PPO rounds."""
    imitation: ImitationConfig = field(default_factory=ImitationConfig)
    """``[imitation]``: a behaviour-cloning term that keeps each learner near a scripted
    ``driver`` with weight ``coef`` (off by default; no ``teacher``: the learners train with
    PPO). In run 12 (experiments/league/README.md) the main stopped passing the blocker after
    55 rounds, although its start, ``racing_line_student``, and its teacher, ``racing_line``,
    pass it."""
    matchmaking: Matchmaking = field(default_factory=Matchmaking)
    """``[matchmaking]``: opponents of the learners' env copies."""
    snapshots: Snapshots = field(default_factory=Snapshots)
    """``[snapshots]``: when learners are frozen into players."""
    races: RaceSchedule = field(default_factory=RaceSchedule)
    """``[races]``: evaluation and placement races."""
    main_restore: MainRestore = field(default_factory=MainRestore)
    """``[main_restore]``: keeping the main agents' best states (off by default)."""

    def __post_init__(self) -> None:
        _check_name("LeagueConfig.name", self.name)
        for key, kind in TABLES.items():
            if not isinstance(getattr(self, key), kind):
                raise ValueError(f"LeagueConfig.{key} must be a {kind.__name__}, got "
                                 f"{getattr(self, key)!r}")
        if self.imitation.teacher is not None:
            raise ValueError(f"[imitation] teacher {self.imitation.teacher!r}: a league's "
                             f"learners train with PPO; keep them near a scripted driver with "
                             f"[imitation] driver and coef instead")
        if not self.learners or not any(s.role == "main" for s in self.learners):
            raise ValueError("a league needs at least one learner with role 'main'")
        names = [s.name for s in self.learners]
        if len(set(names)) != len(names):
            raise ValueError(f"learner names must be distinct, got {names}")
        if isinstance(self.anchors, str) or not all(isinstance(a, str) for a in self.anchors):
            raise ValueError(f"LeagueConfig.anchors must be a list of driver names, got "
                             f"{self.anchors!r}")
        # Each anchor as its player is named (a scripted driver's spec written back).
        object.__setattr__(self, "anchors", tuple(_anchor(a) for a in self.anchors))
        object.__setattr__(self, "rating_anchor", _anchor(self.rating_anchor, "rating_anchor"))
        if set(names) & set(self.anchors):
            raise ValueError(f"learner names {sorted(set(names) & set(self.anchors))} clash "
                             f"with anchors")
        if self.rating_anchor not in self.anchors:
            raise ValueError(f"rating_anchor {self.rating_anchor!r} must be one of the anchors "
                             f"{list(self.anchors)}")
        if not self.tracks:
            raise ValueError("give at least one track")
        if not _is_int(self.max_rounds):
            raise ValueError(f"LeagueConfig.max_rounds must be >= 1, got {self.max_rounds}")
        if not (_is_number(self.minutes) and self.minutes > 0):
            raise ValueError(f"LeagueConfig.minutes must be > 0, got {self.minutes}")

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "league config") -> LeagueConfig:
        """Build from plain data (a parsed TOML file): top-level keys are this class's fields,
        ``[[learners]]`` entries ``LearnerSpec``s, the other tables (``TABLES``) their
        configs; unknown keys raise ``ValueError``."""
        # Types first, so that a wrong one is named with its key (not "'<' not supported");
        # one string for a list of names is that one name.
        values = build_tables(cls, data, source, TABLES, moved=MOVED, removed=REMOVED)
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
        return cls.from_dict(read_toml(path), source=str(path))

    @property
    def rating_tracks(self) -> tuple[str, ...]:
        """Tracks of the placement races."""
        return self.races.placement_tracks or self.tracks

    def train_config(self, seed: int) -> Any:
        """The ``TrainConfig`` of every learner: two cars, one learner, race tracks."""
        from h2h_racing.config.env import RewardConfig
        from h2h_racing.training.config import PPOConfig, TrainConfig

        training = self.training
        return TrainConfig(track=self.tracks[0], num_cars=2, learners=1, opponent=None,
                           num_envs=training.num_envs,
                           num_steps_per_env=training.num_steps_per_env,
                           init_std=training.init_std, max_std=training.max_std,
                           reward=RewardConfig(**self.reward), seed=seed,
                           rules=training.rules, imitation=self.imitation,
                           ppo=PPOConfig(learning_rate=training.learning_rate,
                                         entropy_coef=training.entropy_coef,
                                         num_learning_epochs=training.num_learning_epochs,
                                         num_mini_batches=training.num_mini_batches))
