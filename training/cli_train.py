"""The ``train`` subcommand of ``h2h-racing``, and what training means for the other commands.

``add_train_command`` adds ``train`` to the parser: its ``TrainConfig`` from ``--config`` and
the flags (``_train_config``), the run (``h2h_racing.training.train``), and the lines a stopped
run prints (what was kept, the command that resumes). ``warn_trained_alone`` is the warning
``race`` and ``evaluate`` print when a policy trained alone races another car. The command
needs the ``train`` extra only when it runs.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from h2h_racing.cli.help import SEED_HELP, SPEC_HELP, command_line
from h2h_racing.config.rules import RACE_TYPES
from h2h_racing.common.progress import Progress, add_progress_flag, progress_mode


def _cmd_train(args: argparse.Namespace) -> int:
    from h2h_racing.training.interrupt import (EXIT_INTERRUPTED, StopRequest,
                                               TrainingInterrupted)
    from h2h_racing.training.train import train

    out = Path(args.out)
    config = _train_config(args)
    stop = StopRequest(hard_stop=lambda: _stopped_line(args, "stopped at once (a second "
                                                             "Ctrl-C)"))
    try:
        runner = train(config, iterations=args.iterations, out=out, minutes=args.minutes,
                       progress=progress_mode(args), verbose=args.verbose,
                       resume=args.resume, overwrite=args.overwrite, stop=stop)
    except TrainingInterrupted as stopped:
        print(f"interrupted after iteration {stopped.done}: kept {stopped.checkpoint} and "
              f"{stopped.policy} (the actor at that iteration) and the curves; resume with: "
              f"{_resume_command(args, out)}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except KeyboardInterrupt:  # a Ctrl-C before training started (setup, compiling)
        print(_stopped_line(args, "interrupted"), file=sys.stderr)
        return EXIT_INTERRUPTED
    print(f"trained {runner.current_learning_iteration} iterations -> {out / 'policy.pt'} "
          f"(rsl-rl logs and checkpoints in {out}; curves: tensorboard --logdir {out})")
    if args.simtrace:
        print(f"DeepRacer simtrace + metrics -> {out / 'simtrace'} (deepracer-utils: "
              f"DeepRacerLog('{out / 'simtrace' / 'car_0'}').load_training_trace())")
    if args.onnx and stop.requested:  # a Ctrl-C while training's last files were saved
        print(f"interrupted after training: {out / 'policy.pt'} is complete; export it with: "
              f"h2h-racing export {out / 'policy.pt'} --format onnx", file=sys.stderr)
        return EXIT_INTERRUPTED
    if args.onnx:
        from h2h_racing.training.export import export_policy

        # The exported actor is policy.pt's, checked against it: its own phase on the line.
        bar = Progress("export", mode=progress_mode(args))
        bar.update(0.0, "policy.pt -> policy.onnx, checking it against policy.pt", force=True)
        try:
            result = export_policy(out / "policy.pt", out, formats="onnx")
        except KeyboardInterrupt:
            bar.clear()
            print(f"interrupted during the ONNX export: training is complete, {out} holds "
                  f"policy.pt; export it with: h2h-racing export {out / 'policy.pt'} "
                  "--format onnx", file=sys.stderr)
            return EXIT_INTERRUPTED
        bar.update(1.0, "policy.onnx written and checked", force=True)
        bar.close()
        print(result.summary())
    return 0


def _stopped_line(args: argparse.Namespace, what: str) -> str:
    """One line for a run stopped without ``TrainingInterrupted``: what ``--out`` keeps, and
    the command that goes on (``--resume`` from its latest checkpoint, or a fresh start)."""
    from h2h_racing.training.run_folder import latest_checkpoint

    out = Path(args.out)
    latest = latest_checkpoint(out) if out.is_dir() else None
    if latest is not None:
        return f"{what}: kept {latest}; resume with: {_resume_command(args, out)}"
    start = _command_line(args, {"resume": False, "overwrite": out.is_dir() and any(
        out.iterdir())})
    return f"{what}: nothing kept (no checkpoint in {out}); start again with: {start}"


def _resume_command(args: argparse.Namespace, out: Path) -> str:
    """The ``h2h-racing train`` command line that resumes the run in ``out``."""
    return _command_line(args, {"resume": True, "overwrite": False})


def _command_line(args: argparse.Namespace, replace: dict[str, object]) -> str:
    """``args``' ``h2h-racing train`` command line, shell-quoted: every option of train's
    parser whose value differs from its default (``replace`` first; ``--progress`` left out)."""
    return command_line(args, args.train_parser, ("train",), replace)


_WARNED_ALONE: set[str] = set()
"""Policies ``warn_trained_alone`` has warned about in this process (once each)."""


def warn_trained_alone(drivers: list[str], others: int) -> None:
    """Warn once on stderr, per policy, when a policy among ``drivers`` that was trained alone
    (its policy file's ``racing`` record, ``policies.trained.trained_alone``) races
    ``others`` (>= 1) other cars: it has never seen a car, and crashes into them. Scripted
    drivers, and files that do not load (the command reports those itself), are passed over."""
    from h2h_racing.policies.registry import parse_driver_spec
    from h2h_racing.policies.trained import shipped_policies

    if others < 1:
        return
    shipped = shipped_policies()
    for text in dict.fromkeys(drivers):
        try:
            name = parse_driver_spec(text).name
        except ValueError:
            continue
        if name in _WARNED_ALONE or not (name in shipped or name.endswith(".pt")):
            continue
        try:
            from h2h_racing.policies.trained import load_policy_payload, trained_alone

            # Read without torch: a race of state-observation policies never imports it.
            alone = trained_alone(load_policy_payload(name, arrays=True))
        except (ImportError, OSError, ValueError):
            continue
        if alone:
            _WARNED_ALONE.add(name)
            print(f"warning: {name} was trained alone (no other car on its track), and races "
                  f"{others} other car{'s' if others > 1 else ''} here: it has never seen one "
                  f"and is likely to crash; for races, train it against a car (h2h-racing "
                  f"train's default: --opponents racing_line)", file=sys.stderr, flush=True)


def _train_config(args: argparse.Namespace) -> object:
    """The ``TrainConfig`` of ``train``: the ``--config`` file's fields (without one,
    ``HEAD_TO_HEAD`` over ``TrainConfig``'s defaults), then every flag given on the command
    line over them."""
    import copy

    from h2h_racing.training.config import HEAD_TO_HEAD, TrainConfig

    # Without a config file, train races against racing_line and contacts cost (HEAD_TO_HEAD),
    # unless another race type (boxes, bots) is asked for.
    data: dict[str, object] = {}
    if args.config is None and getattr(args, "race_type", None) in (None, "head_to_head"):
        data = copy.deepcopy(HEAD_TO_HEAD)
    if args.config is not None:
        from h2h_racing.config.shipped import resolve_config
        from h2h_racing.training.config_file import read_train_toml

        try:
            data = read_train_toml(resolve_config(args.config, "train"))
        except FileNotFoundError as err:
            raise SystemExit(f"error: {err}") from None
        except ValueError as err:
            raise SystemExit(f"error: --config {args.config!r}: {err}") from None
    flags = {"track": "track", "obs": "observations", "rules": "rules", "init": "init",
             "max_std": "max_std", "envs": "num_envs", "seed": "seed",
             "reward_function": "reward_function", "model_metadata": "model_metadata",
             "simtrace": "simtrace_envs", "eval_every": "eval_every", "device": "device"}
    data.update({field: getattr(args, flag) for flag, field in flags.items()
                 if getattr(args, flag) is not None})
    if args.opponents is not None:
        opponent = None if args.opponents == "none" else args.opponents
        data.update(opponent=opponent, num_cars=1 if opponent is None else 2,
                    learners=None if opponent is None else 1)
    # Flags of a table change that key over the file's table.
    race = {"race_type": args.race_type, "boxes": args.boxes, "bots": args.bots,
            "bot_speed": args.bot_speed, "bot_lane_change": args.bot_lane_change}
    tables = {"reward": _reward_terms(args.reward) if args.reward else {},
              "imitation": {} if args.teacher is None else {"teacher": args.teacher},
              "race": {key: value for key, value in race.items() if value is not None}}
    for table, values in tables.items():
        if values:
            given = data.get(table, {})
            data[table] = {**(given if isinstance(given, dict) else {}), **values}
    return TrainConfig.from_dict(data, source=args.config or "train's flags")


def _reward_terms(text: str) -> dict[str, float]:
    """``"progress=1,crash=-10"`` -> ``{"progress": 1.0, "crash": -10.0}`` (checked names)."""
    import dataclasses

    from h2h_racing.config.env import RewardConfig

    names = [f.name for f in dataclasses.fields(RewardConfig)]
    weights = {}
    for item in text.split(","):
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or name not in names:
            raise SystemExit(f"error: --reward takes TERM=WEIGHT,... with TERM one of "
                             f"{', '.join(names)}; got {item!r}")
        try:
            weights[name] = float(value)
        except ValueError:
            raise SystemExit(f"error: --reward {name}={value!r}: the weight must be a "
                             "number") from None
    return weights


def add_train_command(sub: argparse._SubParsersAction) -> None:
    """Add ``train`` to the ``h2h-racing`` subparsers."""
    train = sub.add_parser("train", help="train a policy with rsl-rl PPO (needs h2h-racing[train])")
    train.add_argument("--config", default=None, metavar="TRAIN.toml|NAME",
                       help="TrainConfig fields from a TOML file, or a shipped policy's "
                            "training step by name: ppo_generalist/imitate, "
                            "ppo_generalist/finetune, racing_line_student/imitate, "
                            "camera_racer/imitate, obstacle_generalist/imitate, "
                            "obstacle_generalist/anneal, obstacle_generalist/tight, "
                            "obstacle_generalist/circuits, obstacle_generalist/settle, "
                            "obstacle_generalist/bots; flags given override them")
    train.add_argument("--track", default=None,
                       help="catalogue name, track file, random:<seed>, or 'procedural' (a new "
                            "random track every 10 iterations; a config's [procedural] table "
                            "sets them) (default: speedway)")
    train.add_argument("--obs", default=None,
                       choices=["state", "camera", "camera_only", "camera_lidar"],
                       help="actor input: the state vector; camera + state vector; camera + "
                            "own speed and steering (camera_only, DeepRacer's camera setting); "
                            "or camera + lidar (64 ranges over +-150 deg, up to 1 m, seeing cars "
                            "and boxes) + own speed and steering (camera_lidar, DeepRacer's "
                            "head-to-head sensors) (default: state)")
    train.add_argument("--rules", default=None, choices=["training", "race"],
                       help="training: an infraction ends the episode (DeepRacer's training); "
                            "race: a time penalty and the car goes on (default: training)")
    train.add_argument("--reward", default=None, metavar="TERM=W,...",
                       help="built-in reward weights, e.g. progress=1,crash=-10,overtake=3,"
                            "time=-0.05 (default: RewardConfig's weights for unnamed terms)")
    train.add_argument("--init", default=None, metavar="POLICY",
                       help="start from this policy's actor (shipped name or policy.pt): "
                            "fine-tuning (default: none, random weights)")
    train.add_argument("--max-std", type=float, default=None, metavar="S",
                       help="upper bound of the policy's standard deviation (actions in "
                            "[-1, 1]); unbounded by default")
    train.add_argument("--teacher", default=None, metavar="POLICY",
                       help="imitate instead of PPO (rsl-rl Distillation, the student drives): "
                            "a scripted driver (racing_line, pure_pursuit, blocker, with any "
                            "settings: racing_line:grip_factor=0.7) for any --obs, or a state "
                            "policy (shipped name or policy.pt) for a camera student (default: "
                            "none, PPO)")
    train.add_argument("--opponents", default=None,
                       help="'none' (alone: a time trial), a scripted driver name or a "
                            "policy.pt, or several separated by commas (they share the env "
                            "copies); " + SPEC_HELP + " (default without --config: "
                            "racing_line, with a contact cost of -5 in the reward)")
    train.add_argument("--iterations", type=int, default=1000,
                       help="the run's PPO (or imitation) iterations, each of --envs copies x "
                            "32 steps; a resumed run's earlier ones count (default: 1000)")
    train.add_argument("--minutes", type=float, default=None,
                       help="the run's wall-clock budget, setup and evaluations included (a "
                            "resumed run's earlier time too): it stops after the iteration past "
                            "which the next would end beyond it, or at --iterations if that "
                            "comes first (default: none)")
    train.add_argument("--envs", type=int, default=None,
                       help="env copies stepped together (default: 256)")
    train.add_argument("--device", default=None, choices=["cpu", "cuda"],
                       help="torch device of the learner (policy, critic, teacher, optimizer); "
                            "the env always runs on the CPU and its observations move to the "
                            "device once per step; cuda needs a GPU that torch sees "
                            "(default: cpu, or the --config file's device)")
    train.add_argument("--seed", type=int, default=None, help=SEED_HELP + " (default: 0)")
    train.add_argument("--reward-function", default=None, metavar="REWARD.py",
                       help="train on a DeepRacer reward_function(params) file (default: the "
                            "built-in reward)")
    train.add_argument("--race-type", default=None,
                       choices=RACE_TYPES,
                       help="DeepRacer race type to train for (default: a head_to_head race "
                            "against racing_line without --config; time_trial with --opponents "
                            "none)")
    train.add_argument("--boxes", type=int, default=None, metavar="N",
                       help="boxes on the lanes, re-drawn every episode in every env copy "
                            "(default: 6 with object_avoidance, else 0)")
    train.add_argument("--bots", type=int, default=None, metavar="N",
                       help="bot cars per env copy (default: 3 with head_to_bot, else 0)")
    train.add_argument("--bot-speed", type=float, default=None, metavar="M/S",
                       help="speed of the bot cars along their lane (default: 0.75)")
    train.add_argument("--bot-lane-change", action=argparse.BooleanOptionalAction,
                       default=None,
                       help="bots change lanes every 3-5 s of driving; --no-bot-lane-change "
                            "keeps each in its lane (default: they change lanes)")
    train.add_argument("--model-metadata", default=None, metavar="model_metadata.json",
                       help="use a DeepRacer action space (discrete list or continuous ranges) "
                            "(default: continuous steering and speed)")
    train.add_argument("--simtrace", type=int, default=None, metavar="N",
                       help="write DeepRacer simtrace + metrics of N env copies (<= 10) to "
                            "OUT/simtrace (default: 0, none)")
    train.add_argument("--eval-every", type=int, default=None, metavar="N",
                       help="every N iterations, evaluate the policy (tensorboard Eval/...) and "
                            "record a race to OUT/eval/iter_<n>.rrd; 0 turns it off "
                            "(default: 50)")
    train.add_argument("--onnx", action=argparse.BooleanOptionalAction, default=True,
                       help="also export policy.pt's actor to OUT/policy.onnx, checked "
                            "(h2h-racing export)")
    train.add_argument("--out", required=True,
                       help="output folder, e.g. runs/speedway: checkpoints, tensorboard log, "
                            "curves.csv and curves.png, policy.pt; one that holds anything is "
                            "refused without --resume or --overwrite")
    train.add_argument("--resume", action="store_true",
                       help="continue the run in --out from its latest checkpoint, its curves "
                            "and its time (--iterations and --minutes count the whole run); "
                            "give the run's own settings (default: off)")
    train.add_argument("--overwrite", action="store_true",
                       help="delete the run in --out first (its checkpoints, tensorboard "
                            "files, curves, policy, evaluations), so that curves are not mixed "
                            "(default: off)")
    add_progress_flag(train)
    train.add_argument("--verbose", action="store_true",
                       help="print rsl-rl's block of figures after every iteration (about 40 "
                            "lines each) instead of the progress line")
    train.set_defaults(func=_cmd_train, train_parser=train)
