"""What a training run is: ``TrainConfig`` (frozen, validated) and its tables (the PPO and
distillation configs are in ``config_algorithms``; this module gives their names too);
``TrainConfig.from_toml`` reads a config file (``h2h-racing train --config``).

``TrainConfig`` builds a fresh rsl-rl config dict for every runner (rsl-rl mutates the dict it
is given), the env config the learners race in and the VecEnv (``make_env``). The loop that
uses it is ``h2h_racing.training.train``.
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal


from h2h_racing.config.env import EnvConfig, RaceRules, RewardConfig
from h2h_racing.config.sensors import HFOV_RANGE_DEG, MAX_FRAME_STACK
from h2h_racing.deepracer.reward import check_time_limit
from h2h_racing.policies.registry import parse_driver_spec
from h2h_racing.track.io import load_track
from h2h_racing.training.camera_network import check_camera, cnn_config
from h2h_racing.training.config_algorithms import DistillConfig, PPOConfig
from h2h_racing.training.config_file import read_train_toml
from h2h_racing.training.device import check_device_name
from h2h_racing.training.imitation import SCRIPTED_TEACHERS, ImitationConfig
from h2h_racing.training.limits import (MAX_NUM_ENVS, MAX_STEPS_PER_ENV, check_count,
                                        check_hidden_dims, check_rollout)
from h2h_racing.training.race_settings import RaceSettings
from h2h_racing.training.teachers import load_teacher
from h2h_racing.training.toml_types import build_tables
from h2h_racing.training.tracks import ProceduralTracks
from h2h_racing.training.vec_env import ACTOR_GROUPS, OBSERVATIONS, PoolOpponent, RacingVecEnv

STD_FLOOR = 1e-6
"""Smallest policy standard deviation (rsl-rl's own floor) when ``TrainConfig.max_std`` is set."""
PROCEDURAL = "procedural"
"""``TrainConfig.track`` value that trains on a new random track every ``track_every``
iterations."""


TABLES: dict[str, type] = {"ppo": PPOConfig, "distill": DistillConfig, "reward": RewardConfig,
                           "procedural": ProceduralTracks, "imitation": ImitationConfig,
                           "race": RaceSettings}
"""``TrainConfig``'s tables and the configs they fill."""
MOVED = {"track_every": "[procedural] every", "teacher": "[imitation] teacher",
         "teacher_options": "[imitation] options", "imitation_driver": "[imitation] driver",
         "imitation_coef": "[imitation] coef",
         **{f"procedural_{name}": f"[procedural] {name}"
            for name in ("varying_share", "length", "min_radius", "reverse_share", "chicanes",
                         "tight_share")}}
"""Top-level keys of the earlier flat layout and where they are now."""
REMOVED = {"validation_tracks": "held-out random tracks did not predict the shipped tracks "
                                "(ppo_generalist's card)"}
"""Options that were tried and removed, and why."""

HEAD_TO_HEAD: dict[str, Any] = {"num_cars": 2, "learners": 1, "opponent": "racing_line",
                                "reward": {"contact": -5.0}}
"""What ``h2h-racing train`` trains without ``--config``: one learner against the scripted
``racing_line`` in every env copy, with every contact costing 5 (at fault or not). A policy
trained alone never meets another car and cannot race one (0 laps and 25 resets against
``racing_line`` in issue 19); the contact cost keeps it from gaining by being run into
(``experiments/policies/ppo_speedway_racer.md``). ``--opponents none`` trains alone."""


@dataclass(frozen=True, kw_only=True)
class TrainConfig:
    """What to train, on what, against whom."""

    track: str = "speedway"
    """Catalogue name, track file, ``random:<seed>``, or ``"procedural"``: a new random track
    (``procedural``'s settings) every ``procedural.every`` iterations."""
    procedural: ProceduralTracks = field(default_factory=ProceduralTracks)
    """``[procedural]``: the random tracks of ``track="procedural"`` runs and how often they
    change."""
    observations: Literal["state", "camera", "camera_only", "camera_lidar"] = "state"
    """Actor input: the state vector; the camera plus the state vector; the camera plus the
    car's own speed and steering angle (``camera_only``: DeepRacer's camera setting, no track
    geometry and no other car's state); or the camera, the lidar (the env config's
    ``LidarConfig``, DeepRacer's by default: 64 ranges over +-150 deg up to 1.0 m, seeing cars
    and boxes) and the car's own speed and steering angle (``camera_lidar``: DeepRacer's
    head-to-head sensor set). The critic always gets the privileged state."""
    num_cars: int = 1
    """Cars per env copy."""
    opponent: str | None = None
    """Driver of the cars that are not learners: a ``h2h_racing.policies`` driver name (with
    any settings: ``racing_line:grip_factor=0.7``) or a ``policy.pt``, or several separated by
    commas, which share the env copies (copy ``e`` races the ``e mod k``-th of the ``k``
    names; ``PoolOpponent``)."""
    learners: int | None = None
    """Learner cars per copy; None means every car (self-play with parameter sharing)."""
    num_envs: int = 256
    """Env copies."""
    num_steps_per_env: int = 32
    """Rollout length per iteration [steps]."""
    hidden_dims: tuple[int, ...] = (128, 128)
    """Hidden layer sizes of the actor and critic MLPs."""
    init_std: float = 0.5
    """Initial standard deviation of the Gaussian policy (actions in [-1, 1])."""
    max_std: float | None = None
    """Upper bound of the policy's standard deviation, held after every PPO update
    (``BoundedStdPPO``); None leaves it unbounded, as the shipped policies were trained. The
    env clips actions to [-1, 1], so once a mean sits past a bound, a wider Gaussian costs the
    return nothing and the entropy bonus widens it for ever: the league mains of runs 5-7 went
    from 0.3 to 2-4 in 30 minutes (league/README.md). A larger ``init_std`` (or
    an ``init`` policy's std) is clamped to it."""
    reward: RewardConfig = field(default_factory=RewardConfig)
    """Reward weights."""
    camera_size: tuple[int, int] = (64, 48)
    """(width, height) of the camera image for camera policies [px]."""
    camera_frames: int = 1
    """Camera frames per observation, oldest first, one step (1/15 s) apart: the camera's
    ``frame_stack`` (a new episode repeats its first frame). More than one gives the CNN the
    recent past, where the track went after it left the view in a tight corner."""
    camera_hfov: float = 64.7
    """Horizontal field of view of the camera [deg]: DeepRacer's simulated camera has 64.7
    deg (the default), the physical car's lens 120 deg. A wider view keeps a tight corner's
    exit in the image."""
    camera_stereo: bool = False
    """DeepRacer's ``STEREO_CAMERAS``: two cameras 6 cm apart, each frame two channels (left,
    right), instead of the one front camera."""
    camera_channels: tuple[int, ...] = (16, 32, 16)
    """Output channels of the camera CNN's convolutions, one per layer (1-4 layers; a 5 x 5
    kernel, then 3 x 3 ones, each with stride 2 and zero padding, flattened at the end: no
    pooling, since where the lines and cars are in the image is what steers). The default
    turns 64 x 48 into 8 x 6 x 16 = 768 features; ``(8, 16, 8)`` on a 32 x 24 image (96
    features) is the fast camera recipe (``experiments/camera``; benchmarks/README.md)."""
    channels_last: bool = False
    """Keep the camera CNN's weights, and so its activations, channels-last (NHWC) on the
    learner's device instead of PyTorch's NCHW: oneDNN's convolutions on a CPU run without
    reordering the tensors (benchmarks/README.md). The saved policy is the same either way."""
    device: str = "cpu"
    """Torch device of the learner: ``"cpu"``, ``"cuda"`` or ``"cuda:<index>"``. The learner
    (the rsl-rl runner: actor, critic, teacher, optimizer, rollout storage) runs there; the
    env always runs on the CPU (numpy and numba), and rsl-rl moves its observations to the
    device once per step and the actions back. Saved policies hold CPU tensors, so they load
    on any machine. ``train`` refuses ``cuda`` before any work where torch sees no GPU."""
    seed: int = 0
    """Seeds torch and the env."""
    torch_threads: int = 1
    """Torch intra-op threads. One is fastest for these small networks on a small machine:
    with more threads than free cores, OpenMP's spinning threads slow the update ~10x."""
    ppo: PPOConfig = field(default_factory=PPOConfig)
    """PPO hyper-parameters."""
    reward_function: str | None = None
    """A DeepRacer reward file (``reward_function(params)``) replacing the built-in reward;
    loaded once per learner car and env copy."""
    reward_time_limit: float | None = None
    """Longest one call of ``reward_function`` may run [s]: past it training stops with an
    error naming the file, car and step instead of hanging on an endless loop. None (the
    default) sets no limit (``h2h_racing.deepracer.reward``: the timer costs about 3
    microseconds a call)."""
    model_metadata: str | None = None
    """A DeepRacer ``model_metadata.json`` whose action space (discrete list or continuous
    ranges) the cars use; its sensors are not used (``observations`` chooses the inputs)."""
    simtrace_envs: int = 0
    """Env copies whose DeepRacer simtrace + metrics logs ``train`` writes to
    ``OUT/simtrace`` (0-10; 0 writes none)."""
    simtrace_episodes: int = 20
    """Training episodes of each logged copy per simtrace iteration (its ``<i>-iteration.csv``
    and, with ``simtrace_eval_trials``, one evaluation block); DeepRacer's
    ``num_episodes_between_training``, 20, as one worker runs them."""
    simtrace_eval_trials: int = 5
    """DeepRacer's evaluation episodes after each simtrace training iteration of the first
    logged copy, written to its metrics with ``phase: "evaluation"``
    (``h2h_racing.training.simtrace_eval``; DeepRacer's ``MIN_EVAL_TRIALS``, 5); 0 runs
    none. Only with ``simtrace_envs``."""
    eval_every: int = 50
    """Iterations between evaluations of the current actor [iterations]; 0 turns them off.
    Evaluations need an output folder (``train(out=...)``)."""
    eval_episodes: int = 8
    """Lap attempts per evaluation, from start points spread evenly round the lap."""
    eval_race_seconds: float = 60.0
    """Cap on the length of the recorded evaluation race [simulated s]."""
    init: str | None = None
    """A policy (shipped name or ``policy.pt``) whose actor weights training starts from
    (fine-tuning; its observations and hidden sizes must be this run's); None starts from
    random weights. The critic always starts fresh."""
    init_fresh_slots: bool = False
    """With ``init`` a state policy that raced alone (``ppo_generalist``), start the first-layer
    weights of its state vector's opponent and obstacle slots at 0 and restart its observation
    normaliser's sample count (``policy_file.load_init``): it meets boxes, bots or cars
    without a kick of random size, and its normaliser follows the new states."""
    imitation: ImitationConfig = field(default_factory=ImitationConfig)
    """``[imitation]``: a teacher to distil instead of PPO, or a scripted driver that PPO's
    actor is kept near (nothing by default)."""
    distill: DistillConfig = field(default_factory=DistillConfig)
    """Distillation hyper-parameters (used with ``imitation.teacher``)."""
    rules: Literal["training", "race"] = "training"
    """``"training"``: DeepRacer's training rules, an infraction ends the car's episode;
    ``"race"``: race rules, an infraction costs a time penalty (the car is frozen, the clock
    runs) and the car goes on, as in the races a policy is judged in. One lap per episode,
    at most 120 s, either way."""

    race: RaceSettings = field(default_factory=RaceSettings)
    """``[race]``: the race type trained for, with its boxes and bots (``RaceSettings``; by
    default a time trial alone, head-to-head with an opponent, no boxes, no bots)."""

    def __post_init__(self) -> None:
        if self.rules not in ("training", "race"):
            raise ValueError(f"TrainConfig.rules must be 'training' or 'race', got "
                             f"{self.rules!r}")
        if self.observations not in OBSERVATIONS:
            raise ValueError(f"TrainConfig.observations must be one of {OBSERVATIONS}, got "
                             f"{self.observations!r}")
        for name in self.opponents():
            try:
                parse_driver_spec(name)
            except ValueError as err:
                raise ValueError(f"TrainConfig.opponent: {err}") from None
        if not isinstance(self.imitation, ImitationConfig):
            raise ValueError(f"TrainConfig.imitation must be an ImitationConfig, got "
                             f"{self.imitation!r}")
        teacher = self.imitation.teacher
        if teacher is not None and self.observations == "state" and not self.scripted_teacher:
            raise ValueError("[imitation] teacher distils a state policy into a camera policy: "
                             "set observations to 'camera_only', 'camera_lidar' or 'camera' (a "
                             "state student of a state teacher would only copy it), or imitate a "
                             f"scripted driver ({', '.join(SCRIPTED_TEACHERS)})")
        if not isinstance(self.race, RaceSettings):
            raise ValueError(f"TrainConfig.race must be a RaceSettings, got {self.race!r}")
        if "head_to_head" in (self.race.race_type, *self.race.race_types) and self.num_cars < 2:
            raise ValueError("[race] race_type 'head_to_head' needs two cars or more per copy: "
                             "give an opponent (--opponents racing_line) or set num_cars, or "
                             "train against bot cars with race_type 'head_to_bot'")
        if self.race.race_types and self.track != PROCEDURAL:
            raise ValueError(f"[race] race_types {list(self.race.race_types)} take turns, one "
                             f"per random track: set track = 'procedural' (got "
                             f"{self.track!r}), or give a single race_type")
        if not isinstance(self.procedural, ProceduralTracks):
            raise ValueError(f"TrainConfig.procedural must be a ProceduralTracks, got "
                             f"{self.procedural!r}")
        check_count(self.num_envs, "TrainConfig", "num_envs", MAX_NUM_ENVS)
        check_count(self.num_steps_per_env, "TrainConfig", "num_steps_per_env", MAX_STEPS_PER_ENV)
        check_hidden_dims(self.hidden_dims, "TrainConfig")
        if self.procedural.tracks > 1 and self.track != PROCEDURAL:
            raise ValueError(f"[procedural] tracks = {self.procedural.tracks} races several "
                             f"random tracks at once: set track = 'procedural' (got "
                             f"{self.track!r}), or leave tracks at 1")
        if self.num_envs % self.procedural.tracks:
            raise ValueError(f"TrainConfig.num_envs ({self.num_envs}) must split evenly into "
                             f"[procedural] tracks ({self.procedural.tracks}) blocks of copies; "
                             f"make num_envs a multiple of tracks")
        if self.max_std is not None and not (isinstance(self.max_std, (int, float))
                                             and self.max_std > STD_FLOOR):
            raise ValueError(f"TrainConfig.max_std must be None or a number > {STD_FLOOR}, got "
                             f"{self.max_std!r}")
        if not isinstance(self.simtrace_envs, int) or not 0 <= self.simtrace_envs <= min(
                10, self.num_envs):
            raise ValueError(f"TrainConfig.simtrace_envs must be an int in [0, "
                             f"{min(10, self.num_envs)}] (at most 10 and num_envs), got "
                             f"{self.simtrace_envs!r}")
        if (not isinstance(self.simtrace_episodes, int) or isinstance(self.simtrace_episodes, bool)
                or self.simtrace_episodes < 1):
            raise ValueError(f"TrainConfig.simtrace_episodes must be an int >= 1 (DeepRacer's "
                             f"default: 20), got {self.simtrace_episodes!r}")
        if (not isinstance(self.simtrace_eval_trials, int)
                or isinstance(self.simtrace_eval_trials, bool)
                or not 0 <= self.simtrace_eval_trials <= 100):
            raise ValueError(f"TrainConfig.simtrace_eval_trials must be an int in [0, 100] "
                             f"(DeepRacer's default: 5), got {self.simtrace_eval_trials!r}")
        if self.track == PROCEDURAL and (self.reward_function or self.simtrace_envs):
            raise ValueError("TrainConfig: a DeepRacer reward function or simtrace logs need "
                             "one track; pick a fixed track instead of 'procedural'")
        for name in ("reward_function", "model_metadata"):
            path = getattr(self, name)
            if path is not None and not Path(path).is_file():
                raise ValueError(f"TrainConfig.{name}: {path!r} is not a file; give the path "
                                 f"of your DeepRacer {name.replace('_', ' ')} file")
        if not (isinstance(self.eval_every, int) and self.eval_every >= 0):
            raise ValueError(f"TrainConfig.eval_every must be an int >= 0 (iterations; 0 turns "
                             f"evaluation off), got {self.eval_every!r}")
        if not (isinstance(self.eval_episodes, int) and self.eval_episodes >= 1):
            raise ValueError(f"TrainConfig.eval_episodes must be an int >= 1, got "
                             f"{self.eval_episodes!r}")
        if not (isinstance(self.eval_race_seconds, (int, float)) and self.eval_race_seconds > 0):
            raise ValueError(f"TrainConfig.eval_race_seconds must be > 0 [s], got "
                             f"{self.eval_race_seconds!r}")
        check_camera(self.camera_size, self.camera_channels)
        if not (isinstance(self.camera_frames, int) and not isinstance(self.camera_frames, bool)
                and 1 <= self.camera_frames <= MAX_FRAME_STACK):
            raise ValueError(f"TrainConfig.camera_frames must be an int in [1, "
                             f"{MAX_FRAME_STACK}] (frames per camera observation), got "
                             f"{self.camera_frames!r}")
        camera_values = 0
        if "camera" in self.observations:
            width, height = self.camera_size
            camera_values = width * height * self.camera_frames * (2 if self.camera_stereo else 1)
        check_rollout(self.num_envs, self.num_steps_per_env, camera_values, "TrainConfig")
        low, high = HFOV_RANGE_DEG
        if (isinstance(self.camera_hfov, bool) or not isinstance(self.camera_hfov, (int, float))
                or not low <= self.camera_hfov <= high):
            raise ValueError(f"TrainConfig.camera_hfov must be a number in [{low:g}, {high:g}] "
                             f"(the camera's horizontal field of view in degrees), got "
                             f"{self.camera_hfov!r}")
        if not isinstance(self.init_fresh_slots, bool) or (self.init_fresh_slots
                                                           and self.init is None):
            raise ValueError(f"TrainConfig.init_fresh_slots must be true or false, and true "
                             f"only with an init policy (init = \"ppo_generalist\"), got "
                             f"{self.init_fresh_slots!r} with init={self.init!r}")
        for name in ("camera_stereo", "channels_last"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"TrainConfig.{name} must be true or false, got "
                                 f"{getattr(self, name)!r}")
        check_device_name(self.device)
        check_time_limit(self.reward_time_limit)

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "train config") -> TrainConfig:
        """Build from plain data (a parsed TOML file): top-level keys are this class's fields,
        the tables ``[ppo]``, ``[distill]``, ``[reward]``, ``[procedural]``, ``[imitation]``
        and ``[race]`` fill ``PPOConfig``, ``DistillConfig``, ``RewardConfig``,
        ``ProceduralTracks``, ``ImitationConfig`` and ``RaceSettings``; unknown
        keys raise ``ValueError`` (a key of the earlier flat layout names its table)."""
        values = build_tables(cls, data, source, TABLES, moved=MOVED, removed=REMOVED)
        try:
            return cls(**values)
        except (TypeError, ValueError) as err:
            raise ValueError(f"{source}: {err}") from None

    @classmethod
    def from_toml(cls, path: str | Path) -> TrainConfig:
        """Read a training config file (see ``from_dict``; e.g.
        ``policies/trained/ppo_generalist/imitate.toml``), with the file it ``extends``
        (``read_train_toml``)."""
        return cls.from_dict(read_train_toml(path), source=str(path))

    def opponents(self) -> list[str]:
        """The drivers named by ``opponent`` (empty without one)."""
        return [] if self.opponent is None else [n.strip() for n in self.opponent.split(",")]

    @property
    def scripted_teacher(self) -> bool:
        """Whether ``imitation.teacher`` names a scripted driver."""
        return self.imitation.scripted_teacher

    def env_config(self) -> EnvConfig:
        """The env the learners race in: ``rules`` (DeepRacer's training rules by default: an
        infraction ends the car's episode), one lap per episode (``track`` names the first
        track; a procedural run starts on ``speedway`` and moves to random tracks), ``race``'s
        race type, boxes and bots, a ``camera_size`` camera (read by every mode but ``state``)
        and DeepRacer's default lidar (``LidarConfig()``, read by ``camera_lidar``; the VecEnv
        builds both sensors from these settings, so ``sensors`` stays the state vector)."""
        race_type = self.race.resolved_type(self.num_cars)
        camera = dataclasses.replace(EnvConfig().camera, width=self.camera_size[0],
                                     height=self.camera_size[1],
                                     frame_stack=self.camera_frames,
                                     hfov_deg=self.camera_hfov,
                                     stereo=self.camera_stereo)
        track = "speedway" if self.track == PROCEDURAL else self.track
        rules_type = self.race.rules_type(self.num_cars)
        rules = RaceRules.preset(rules_type, "training")
        if self.rules == "race":
            rules = dataclasses.replace(RaceRules.preset(rules_type, "race"), laps=rules.laps,
                                        time_limit=rules.time_limit, ranking="total_time",
                                        max_resets_per_lap=None)
        return EnvConfig(track=track, num_cars=self.num_cars, race_type=race_type,
                         rules=rules, reward=self.reward,
                         camera=camera, **self.race.env_fields(), **self.action_space())

    def action_space(self) -> dict[str, Any]:
        """The ``EnvConfig`` action-space overrides of ``model_metadata`` (empty without)."""
        if self.model_metadata is None:
            return {}
        from h2h_racing.deepracer.metadata import load_action_space

        return load_action_space(self.model_metadata)

    def actor_groups(self) -> list[str]:
        """Observation groups the actor reads (see ``h2h_racing.training.vec_env``)."""
        return list(ACTOR_GROUPS[self.observations])

    def actor_dict(self) -> dict[str, Any]:
        """rsl-rl config of the actor (the student when distilling): an MLP on the state, a CNN
        (then an MLP, which also reads the vector groups: lidar, motion) with a camera."""
        camera = self.observations != "state"
        distilling = self.imitation.teacher is not None
        init_std = self.distill.student_std if distilling else self.init_std
        actor: dict[str, Any] = {
            "class_name": "CNNModel" if camera else "MLPModel",
            "hidden_dims": list(self.hidden_dims), "obs_normalization": True,
            "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": init_std}}
        if self.max_std is not None and not distilling:
            actor["distribution_cfg"]["std_range"] = [STD_FLOOR, float(self.max_std)]
            actor["distribution_cfg"]["init_std"] = min(init_std, float(self.max_std))
        if camera:
            actor["cnn_cfg"] = cnn_config(self.camera_channels)
        return actor

    def rsl_rl_dict(self, teacher: dict[str, Any] | None = None) -> dict[str, Any]:
        """Return a fresh rsl-rl runner config (rsl-rl mutates what it is given): PPO's for an
        ``OnPolicyRunner``, or with ``teacher`` Distillation's for a ``DistillationRunner``,
        whose teacher model config comes from the teacher's policy dict (``load_teacher``;
        loaded here unless given)."""
        actor = self.actor_dict()
        if self.imitation.teacher is not None:
            if self.scripted_teacher:
                teacher_groups = ["expert"]
                teacher_model = {"class_name": "h2h_racing.training.teachers:ScriptedTeacher"}
            else:
                teacher = teacher if teacher is not None else load_teacher(self)
                teacher_groups = ["policy"]
                teacher_model = {**copy.deepcopy(teacher["actor_cfg"]),
                                 "class_name": "h2h_racing.training.teachers:ClippedTeacher"}
                if self.imitation.pace != 1.0:
                    _, _, speed_mid, speed_half = self.env_config().action_affine
                    teacher_model.update(pace=self.imitation.pace, speed_mid=speed_mid,
                                         speed_half=speed_half)
            return {
                "num_steps_per_env": self.num_steps_per_env,
                "save_interval": 50,
                "obs_groups": {"student": self.actor_groups(), "teacher": teacher_groups},
                "algorithm": {"class_name": "Distillation", "loss_type": "mse",
                              **{k: v for k, v in dataclasses.asdict(self.distill).items()
                                 if k != "student_std"}},
                "student": actor,
                "teacher": teacher_model,
            }
        # The critic reads the privileged state; with the camera and the state vector it also
        # gets the camera (as first built). A camera-only actor's critic needs no CNN: the
        # privileged state holds what the value depends on, at a fraction of the update cost.
        # So does a camera-and-lidar actor's: the privileged state already places the other
        # cars and the nearest boxes, which is all its lidar sees.
        critic: dict[str, Any] = {"class_name": "MLPModel",
                                  "hidden_dims": list(self.hidden_dims), "obs_normalization": True}
        critic_groups = ["critic"]
        if self.observations == "camera":
            critic = {**critic, "class_name": "CNNModel",
                      "cnn_cfg": copy.deepcopy(actor["cnn_cfg"])}
            critic_groups = ["critic", "camera"]
        algorithm: dict[str, Any] = {"class_name": "PPO", "schedule": "adaptive",
                                     **dataclasses.asdict(self.ppo)}
        if self.imitation.coef:
            algorithm.update(class_name="h2h_racing.training.ppo:ImitationPPO",
                             imitation_coef=float(self.imitation.coef))
        elif self.max_std is not None:
            algorithm["class_name"] = "h2h_racing.training.ppo:BoundedStdPPO"
        return {
            "num_steps_per_env": self.num_steps_per_env,
            "save_interval": 50,
            "obs_groups": {"actor": self.actor_groups(), "critic": critic_groups},
            "algorithm": algorithm,
            "actor": actor,
            "critic": critic,
        }

    def make_env(self, device: str = "cpu",
                 simtrace: str | Path | None = None) -> RacingVecEnv:
        """Build the VecEnv for this config (logging ``simtrace_envs`` copies to ``simtrace``
        when both are given): with ``[procedural] tracks`` K > 1 its copies race K tracks at
        once in one core, K blocks of copies each with a generator and drivers of its own
        (seeds spawned from ``seed``, ``RaceCore.track_seeds``); ``train`` gives them their
        random tracks (``set_tracks``)."""
        log = None if simtrace is None or not self.simtrace_envs else str(simtrace)
        env_config = self.env_config()
        opponent: Any = self.opponent
        if opponent is not None and "," in opponent:
            names = self.opponents()
            opponent = PoolOpponent(tuple(names[e % len(names)] for e in range(self.num_envs)),
                                    seed=self.seed)
        track = load_track(env_config.track)
        return RacingVecEnv(
            env_config, num_envs=self.num_envs, learners=self.learners, opponent=opponent,
            observations=self.observations, seed=self.seed, device=device,
            track=[track] * self.procedural.tracks, reward_function=self.reward_function,
            simtrace=log, reward_time_limit=self.reward_time_limit,
            simtrace_envs=max(self.simtrace_envs, 1), simtrace_episodes=self.simtrace_episodes,
            expert=self.imitation.expert(), race_types=self.race.race_types,
            tight_boxes=self.race.tight_boxes())
