"""PPO samples/s of training, today's settings against faster candidates; asserts nothing.

    python benchmarks/bench_train.py                  # state rows, about 3-5 minutes
    python benchmarks/bench_train.py --quick          # a smoke run of every row
    python benchmarks/bench_train.py --camera         # also the camera rows (issue 21)

What is timed: rsl-rl PPO iterations exactly as ``h2h-racing train`` runs them
(``training.config.TrainConfig.rsl_rl_dict``: state observations, an MLP actor and critic,
``num_steps_per_env`` = 32 steps of ``--envs`` copies per iteration, then the update), with
the loop of ``OnPolicyRunner.learn`` written out so that its two phases are timed apart:

- *collect*: ``alg.act`` + ``env.step`` + ``alg.process_env_step`` for 32 steps, then
  ``compute_returns`` (the env and the policy's forward passes);
- *update*: ``alg.update()`` (epochs x mini-batches of PPO gradient steps).

Per setting the bench prints the median over ``--rounds`` of samples/s for a whole iteration
(what rsl-rl logs as "Computation") and for the update alone, and each one's ratio to
today's settings. Every setting is built once, warmed up, then the settings take turns one
iteration at a time (the order rotates every round), so all of them see the same machine
load; on a shared machine the absolute figures move with the load, the ratios much less.

Settings (``SETTINGS``): ``today`` is ``TrainConfig``'s defaults (4 epochs x 4 mini-batches,
hidden (128, 128), one torch thread); the others change one or two of: mini-batches per epoch
(bigger mini-batches), epochs, hidden width, torch threads, ``torch.compile`` of actor and
critic (rsl-rl's ``alg.compile``). Fewer epochs or mini-batches are fewer gradient steps per
sample: whether a run still learns as well is a training question, not answered here.

With ``--camera`` also camera rows: PPO with the camera actor (``observations="camera"``) and
distillation of the racing line into a camera-only student (``[imitation] teacher = "racing_line"``), each at
today's 64 x 48 image and CNN and at a 32 x 24 image with a narrower CNN, with
``--camera-envs`` copies.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import os
import platform
import statistics
import time
from typing import Any

os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")

import torch  # noqa: E402

from h2h_racing.training.config import PPOConfig, TrainConfig  # noqa: E402
from h2h_racing.training.imitation import ImitationConfig  # noqa: E402

SETTINGS: dict[str, dict[str, Any]] = {
    "today": {},
    "2 minibatches per epoch": {"num_mini_batches": 2},
    "1 minibatch per epoch": {"num_mini_batches": 1},
    "2 epochs": {"num_learning_epochs": 2},
    "2 epochs x 2 minibatches": {"num_learning_epochs": 2, "num_mini_batches": 2},
    "2 epochs x 1 minibatch": {"num_learning_epochs": 2, "num_mini_batches": 1},
    "hidden 64x64": {"hidden_dims": (64, 64)},
    "hidden 64x64 + 2 epochs x 2 mb": {"hidden_dims": (64, 64), "num_learning_epochs": 2,
                                       "num_mini_batches": 2},
    "torch.compile": {"compile": True},
    "2 torch threads": {"torch_threads": 2},
}
"""Name -> changes from today's settings (PPOConfig fields, ``hidden_dims``,
``torch_threads``, ``compile``)."""
OPT_IN = {"2 torch threads"}
"""Settings run only when named in ``--only``: two threads on a loaded 2-core machine ran
30x slower in a quick run (OpenMP's threads spin for cores they do not get;
``TrainConfig.torch_threads``), which would make the default run take many minutes."""
SMALL_CNN = {"output_channels": [8, 16, 8], "kernel_size": [5, 3, 3], "stride": [2, 2, 2],
             "padding": "zeros"}
"""The narrower CNN of the small camera rows (today's: 16, 32, 16 channels)."""
DISTIL = ImitationConfig(teacher="racing_line")
"""The distillation rows' teacher."""


@dataclasses.dataclass
class Bench:
    """One setting's runner and its measurements."""

    name: str
    runner: Any
    threads: int
    obs: Any = None
    total: list[float] = dataclasses.field(default_factory=list)
    """Samples/s of whole iterations."""
    update: list[float] = dataclasses.field(default_factory=list)
    """Samples/s of the update alone."""
    error: str | None = None


def state_config(changes: dict[str, Any], envs: int, cars: int) -> TrainConfig:
    """``h2h-racing train``'s config for state observations with ``changes``."""
    ppo = {k: v for k, v in changes.items() if k in {f.name for f in
                                                     dataclasses.fields(PPOConfig)}}
    other = {k: v for k, v in changes.items() if k in ("hidden_dims", "torch_threads")}
    opponent = {"opponent": "racing_line", "learners": 1} if cars == 2 else {}
    return TrainConfig(num_envs=envs, num_cars=cars, ppo=PPOConfig(**ppo), eval_every=0,
                       **opponent, **other)


def build(name: str, config: TrainConfig, compile_models: bool = False,
          cnn: dict[str, Any] | None = None) -> Bench:
    """An rsl-rl runner for ``config`` (PPO, or distillation with a ``teacher``)."""
    from rsl_rl.runners import DistillationRunner, OnPolicyRunner

    torch.manual_seed(config.seed)
    torch.set_num_threads(config.torch_threads)
    env = config.make_env()
    cfg = config.rsl_rl_dict()
    if cnn is not None:
        for section in ("actor", "critic", "student"):
            if "cnn_cfg" in cfg.get(section, {}):
                cfg[section]["cnn_cfg"] = dict(cnn)
    with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl prints the models
        if config.imitation.teacher is None:
            runner = OnPolicyRunner(env, cfg, log_dir=None, device="cpu")
        else:
            runner = DistillationRunner(env, cfg, log_dir=None, device="cpu")
        runner.alg.teacher_loaded = True  # a scripted teacher: the env's expert group
    if compile_models:
        runner.alg.compile("default")
    runner.alg.train_mode()
    return Bench(name=name, runner=runner, threads=config.torch_threads,
                 obs=env.get_observations())


def iteration(bench: Bench) -> tuple[float, float]:
    """One training iteration of ``bench``; returns (collect seconds, update seconds)."""
    runner = bench.runner
    torch.set_num_threads(bench.threads)
    steps = runner.cfg["num_steps_per_env"]
    obs = bench.obs
    start = time.perf_counter()
    with torch.inference_mode():
        for _ in range(steps):
            actions = runner.alg.act(obs)
            obs, rewards, dones, extras = runner.env.step(actions)
            runner.alg.process_env_step(obs, rewards, dones, extras)
        if hasattr(runner.alg, "compute_returns"):
            runner.alg.compute_returns(obs)
    middle = time.perf_counter()
    runner.alg.update()
    end = time.perf_counter()
    bench.obs = obs
    return middle - start, end - middle


def run(benches: list[Bench], rounds: int, warmup: int) -> None:
    """Warm every setting up, then take turns one iteration each, rotating the order."""
    for bench in benches:
        try:
            for _ in range(warmup):
                iteration(bench)
        except Exception as error:  # noqa: BLE001 - a setting that fails is reported
            bench.error = f"{type(error).__name__}: {str(error).splitlines()[0][:100]}"
    live = [b for b in benches if b.error is None]
    for r in range(rounds):
        shift = r % max(len(live), 1)
        for bench in live[shift:] + live[:shift]:
            collect, update = iteration(bench)
            samples = bench.runner.env.num_envs * bench.runner.cfg["num_steps_per_env"]
            bench.total.append(samples / (collect + update))
            bench.update.append(samples / update)


def report(title: str, benches: list[Bench]) -> None:
    """Print medians and ratios to the first (today's) row."""
    print(f"\n{title}")
    print(f"{'setting':<32} {'iteration samples/s':>20} {'ratio':>6} {'update samples/s':>17} "
          f"{'ratio':>6}  (median, min-max)")
    base = benches[0]
    base_total = statistics.median(base.total) if base.total else float("nan")
    base_update = statistics.median(base.update) if base.update else float("nan")
    for bench in benches:
        if bench.error is not None:
            print(f"{bench.name:<32} failed: {bench.error}")
            continue
        total, update = statistics.median(bench.total), statistics.median(bench.update)
        print(f"{bench.name:<32} {total:>20,.0f} {total / base_total:>6.2f} {update:>17,.0f} "
              f"{update / base_update:>6.2f}  ({min(bench.total):,.0f}-{max(bench.total):,.0f}; "
              f"{min(bench.update):,.0f}-{max(bench.update):,.0f})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, default=512, help="env copies (default: 512)")
    parser.add_argument("--cars", type=int, default=1, choices=[1, 2],
                        help="cars per copy: 1 (h2h-racing train's default) or 2, the second "
                             "driven by racing_line (the league's layout) (default: 1)")
    parser.add_argument("--rounds", type=int, default=9,
                        help="timed iterations per setting (default: 9)")
    parser.add_argument("--warmup", type=int, default=2,
                        help="untimed iterations per setting first (default: 2)")
    parser.add_argument("--only", default=None,
                        help="comma-separated setting names to run (today's always runs)")
    parser.add_argument("--camera", action="store_true", help="also the camera rows")
    parser.add_argument("--camera-envs", type=int, default=64,
                        help="env copies of the camera rows (default: 64)")
    parser.add_argument("--quick", action="store_true",
                        help="64 copies, 2 rounds, 1 warm-up: a smoke run")
    args = parser.parse_args()
    if args.quick:
        args.envs, args.rounds, args.warmup, args.camera_envs = 64, 2, 1, 16
    print(f"torch {torch.__version__}, {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at the start")
    wanted = (set(SETTINGS) - OPT_IN if args.only is None
              else {"today", *args.only.split(",")})
    unknown = wanted - set(SETTINGS)
    if unknown:
        parser.error(f"unknown settings {sorted(unknown)}; choose from {list(SETTINGS)}")
    benches = []
    for name, changes in SETTINGS.items():
        if name not in wanted:
            continue
        config = state_config({k: v for k, v in changes.items() if k != "compile"},
                              args.envs, args.cars)
        try:
            benches.append(build(name, config, compile_models=changes.get("compile", False)))
        except Exception as error:  # noqa: BLE001 - reported as the setting's result
            benches.append(Bench(name=name, runner=None, threads=1,
                                 error=f"{type(error).__name__}: {error}"))
    run(benches, args.rounds, args.warmup)
    report(f"PPO, state observations, {args.envs} copies x {args.cars} car(s), 32 steps per "
           f"iteration ({args.rounds} rounds, load average {os.getloadavg()[0]:.1f} at the end)",
           benches)
    if args.camera:
        small = {"camera_size": (32, 24)}
        rows = [
            ("camera PPO 64x48", TrainConfig(num_envs=args.camera_envs, observations="camera",
                                             eval_every=0), None),
            ("camera PPO 32x24, small CNN", TrainConfig(num_envs=args.camera_envs,
                                                        observations="camera", eval_every=0,
                                                        **small), SMALL_CNN),
            ("distill 64x48", TrainConfig(num_envs=args.camera_envs,
                                          observations="camera_only", imitation=DISTIL,
                                          eval_every=0), None),
            ("distill 32x24, small CNN", TrainConfig(num_envs=args.camera_envs,
                                                     observations="camera_only",
                                                     imitation=DISTIL, eval_every=0,
                                                     **small), SMALL_CNN),
        ]
        cameras = [build(name, config, cnn=cnn) for name, config, cnn in rows]
        run(cameras, max(2, args.rounds // 3), args.warmup)
        report(f"camera rows, {args.camera_envs} copies (ratios to camera PPO 64x48)",
               cameras)


if __name__ == "__main__":
    main()
