"""What a self-play league is: ``LeagueConfig`` (frozen, validated; ``league/*.toml`` files
hold its fields) and its learners (``LearnerSpec``, ``ROLES``). The run itself is
``h2h_racing.league.selfplay``."""

from __future__ import annotations

import dataclasses
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from h2h_racing.training.toml_types import check_fields

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
