"""PPO samples/s of training, today's settings against faster candidates; asserts nothing.

    python benchmarks/bench_train.py                  # state rows, about 3-5 minutes
    python benchmarks/bench_train.py --quick          # a smoke run of every row
    python benchmarks/bench_train.py --camera         # also the camera rows (issue 21)
    python benchmarks/bench_train.py --cpu-time       # thread CPU time (a shared machine)
    python benchmarks/bench_train.py --camera --device cuda --only today   # GPU rows too

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
``--cpu-time`` times with the thread's CPU time instead of the wall clock, which other
processes on the machine barely move (torch runs one intra-op thread and the env one thread:
the work is this thread's; a setting with more torch threads is refused then).

Settings (``SETTINGS``): ``today`` is ``TrainConfig``'s defaults (4 epochs x 4 mini-batches,
hidden (128, 128), one torch thread); the others change one or two of: mini-batches per epoch
(bigger mini-batches), epochs, hidden width, torch threads, ``torch.compile`` of actor and
critic (rsl-rl's ``alg.compile``). Fewer epochs or mini-batches are fewer gradient steps per
sample: whether a run still learns as well is a training question, not answered here.

With ``--camera`` also camera rows (issue 21), each fast row against its own today's row:

- PPO with the camera actor (``observations="camera"``: camera and state vector, and a CNN
  critic): today's (``TrainConfig``'s 64 x 48 image and (16, 32, 16) CNN, ``--camera-envs``
  copies), then with the camera recipe's image, CNN, channels-last layout and copies
  (``experiments/camera/ppo.toml``);
- distillation into a camera-only student from the scripted ``racing_line`` and from the
  shipped state policy ``ppo_generalist`` (the teacher of the camera recipe): each with
  today's settings (64 x 48, (16, 32, 16), ``--camera-envs`` copies, ``DistillConfig``'s
  defaults), then with the recipe's (``experiments/camera/distill.toml``: 32 x 24, (8, 16, 8),
  channels-last, 512 copies).

The runners are what ``h2h-racing train`` builds (``training.train.make_runner``), so the
recipe rows time the recipe files, not settings of the bench's own. The camera rows also time
``distill_64.toml`` (the 64 x 48 image the camera-only students since use).

With ``--device cuda`` every recipe row (and today's state row) runs a second time with the
learner on the GPU (``TrainConfig.device``; the env stays on the CPU), its ratios to the same
row on the CPU in the same run. The clock waits for the GPU (``torch.cuda.synchronize``)
before it reads the end of each phase.
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
from pathlib import Path
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
RECIPES = Path(__file__).resolve().parents[1] / "experiments" / "camera"
"""The camera recipe (``distill.toml``, then ``ppo.toml``) whose settings the fast camera
rows time."""
TEACHERS = ("racing_line", "ppo_generalist")
"""The distillation rows' teachers: the scripted racing line (labels computed in the env) and
the state policy the camera recipe distils (an MLP forward pass per step)."""


@dataclasses.dataclass
class Bench:
    """One setting's runner and its measurements."""

    name: str
    runner: Any
    threads: int
    obs: Any = None
    base: str | None = None
    """The row whose figures this one's ratios divide by (None: the table's first)."""
    total: list[float] = dataclasses.field(default_factory=list)
    """Samples/s of whole iterations."""
    update: list[float] = dataclasses.field(default_factory=list)
    """Samples/s of the update alone."""
    error: str | None = None


clock = time.perf_counter
"""The timer of every figure (``--cpu-time``: the thread's CPU time)."""


def state_config(changes: dict[str, Any], envs: int, cars: int) -> TrainConfig:
    """``h2h-racing train``'s config for state observations with ``changes``."""
    ppo = {k: v for k, v in changes.items() if k in {f.name for f in
                                                     dataclasses.fields(PPOConfig)}}
    other = {k: v for k, v in changes.items() if k in ("hidden_dims", "torch_threads")}
    opponent = {"opponent": "racing_line", "learners": 1} if cars == 2 else {}
    return TrainConfig(num_envs=envs, num_cars=cars, ppo=PPOConfig(**ppo), eval_every=0,
                       **opponent, **other)


def build(name: str, config: TrainConfig, compile_models: bool = False,
          base: str | None = None) -> Bench:
    """The rsl-rl runner ``h2h-racing train`` builds for ``config`` (PPO, or distillation
    with a ``teacher``)."""
    from h2h_racing.training.train import make_runner

    torch.manual_seed(config.seed)
    torch.set_num_threads(config.torch_threads)
    env = config.make_env()
    with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl prints the models
        runner = make_runner(config, env)
    if compile_models:
        runner.alg.compile("default")
    runner.alg.train_mode()
    return Bench(name=name, runner=runner, threads=config.torch_threads,
                 obs=env.get_observations().to(runner.device), base=base)


def sync(device: str) -> None:
    """Wait for ``device``'s queued work (CUDA runs asynchronously to the clock)."""
    if device.startswith("cuda"):
        torch.cuda.synchronize(device)


def on_device(rows: list[tuple[str, TrainConfig, str]],
              device: str) -> list[tuple[str, TrainConfig, str]]:
    """``rows`` with, after each row that is not its own base (a recipe row), the same row
    with the learner on ``device``, based on the CPU row."""
    out = []
    for name, config, base in rows:
        out.append((name, config, base))
        if device != "cpu" and base != name:
            out.append((f"{name}, {device}", dataclasses.replace(config, device=device), name))
    return out


def iteration(bench: Bench) -> tuple[float, float]:
    """One training iteration of ``bench``; returns (collect seconds, update seconds)."""
    runner = bench.runner
    torch.set_num_threads(bench.threads)
    steps = runner.cfg["num_steps_per_env"]
    obs = bench.obs
    start = clock()
    with torch.inference_mode():
        for _ in range(steps):
            actions = runner.alg.act(obs)
            obs, rewards, dones, extras = runner.env.step(actions.to(runner.env.device))
            # The learner's device, as OnPolicyRunner.learn moves them.
            obs, rewards, dones = (obs.to(runner.device), rewards.to(runner.device),
                                   dones.to(runner.device))
            runner.alg.process_env_step(obs, rewards, dones, extras)
        if hasattr(runner.alg, "compute_returns"):
            runner.alg.compute_returns(obs)
    sync(runner.device)
    middle = clock()
    runner.alg.update()
    sync(runner.device)
    end = clock()
    bench.obs = obs
    return middle - start, end - middle


def run(benches: list[Bench], rounds: int, warmup: int) -> None:
    """Warm every setting up, then take turns one iteration each, rotating the order."""
    for bench in benches:
        if clock is time.thread_time and bench.threads > 1 and bench.error is None:
            bench.error = (f"{bench.threads} torch threads: the thread's CPU time misses the "
                           "other threads' work (run it without --cpu-time)")
            continue
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
    """Print medians and ratios to each row's ``base`` row (by default the first, today's)."""
    print(f"\n{title}")
    width = max(32, *(len(b.name) for b in benches))
    print(f"{'setting':<{width}} {'iteration samples/s':>20} {'ratio':>6} "
          f"{'update samples/s':>17} {'ratio':>6}  (median, min-max)")
    rows = {bench.name: bench for bench in benches}

    def median(values: list[float]) -> float:
        return statistics.median(values) if values else float("nan")

    for bench in benches:
        if bench.error is not None:
            print(f"{bench.name:<{width}} failed: {bench.error}")
            continue
        base = rows.get(bench.base or "", benches[0])
        total, update = median(bench.total), median(bench.update)
        print(f"{bench.name:<{width}} {total:>20,.0f} {total / median(base.total):>6.2f} "
              f"{update:>17,.0f} {update / median(base.update):>6.2f}  "
              f"({min(bench.total):,.0f}-{max(bench.total):,.0f}; "
              f"{min(bench.update):,.0f}-{max(bench.update):,.0f})")


def camera_rows(envs: int,
                recipe_envs: int | None = None) -> list[tuple[str, TrainConfig, str]]:
    """(name, config, base row) of the camera rows: today's settings with ``envs`` copies (each
    its own base), and the camera recipe's (with ``recipe_envs`` copies instead of its own when
    given), each based on the today's row before it."""
    distill = TrainConfig.from_toml(RECIPES / "distill.toml")
    finetune = TrainConfig.from_toml(RECIPES / "ppo.toml")
    camera = {"camera_size": finetune.camera_size, "camera_channels": finetune.camera_channels,
              "channels_last": finetune.channels_last,
              "num_envs": recipe_envs or finetune.num_envs}
    today_ppo = TrainConfig(num_envs=envs, observations="camera", eval_every=0)
    size = "x".join(map(str, distill.camera_size))
    net = "-".join(map(str, distill.camera_channels))
    fast = f"{size}, CNN {net}" + (", channels-last" if distill.channels_last else "")
    rows: list[tuple[str, TrainConfig, str]] = [
        ("camera PPO 64x48", today_ppo, "camera PPO 64x48"),
        (f"camera PPO {fast}, {camera['num_envs']} copies",
         dataclasses.replace(today_ppo, **camera), "camera PPO 64x48")]
    for teacher in TEACHERS:
        imitation = ImitationConfig(teacher=teacher)
        today = f"distill {teacher} 64x48"
        recipe = dataclasses.replace(distill, imitation=imitation, eval_every=0,
                                     num_envs=recipe_envs or distill.num_envs)
        rows += [(today, TrainConfig(num_envs=envs, observations="camera_only",
                                     imitation=imitation, eval_every=0), today),
                 (f"distill {teacher} {fast}, {recipe.num_envs} copies", recipe, today)]
    big = TrainConfig.from_toml(RECIPES / "distill_64.toml")
    big = dataclasses.replace(big, eval_every=0, num_envs=recipe_envs or big.num_envs)
    net = "-".join(map(str, big.camera_channels))
    rows.append((f"distill {big.imitation.teacher} 64x48, CNN {net}"
                 + (", channels-last" if big.channels_last else "")
                 + f", {big.num_envs} copies", big, f"distill {big.imitation.teacher} 64x48"))
    return rows


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
                        help="env copies of today's camera rows; the recipe's rows use the "
                             "recipe's (with --quick, these too) (default: 64)")
    parser.add_argument("--quick", action="store_true",
                        help="64 copies, 2 rounds, 1 warm-up: a smoke run")
    parser.add_argument("--device", default="cpu",
                        help="also time the recipe rows and today's state row with the learner "
                             "on this torch device, e.g. cuda (default: cpu, no extra rows)")
    parser.add_argument("--cpu-time", action="store_true",
                        help="time with this thread's CPU time instead of the wall clock "
                             "(steadier where other processes share the CPU)")
    args = parser.parse_args()
    if args.device != "cpu":
        from h2h_racing.training.device import check_device_available

        if args.cpu_time:
            parser.error("--cpu-time misses the GPU's work; time --device rows on the wall clock")
        try:
            check_device_available(args.device)
        except ValueError as error:
            parser.error(str(error))
    global clock
    clock = time.thread_time if args.cpu_time else time.perf_counter
    if args.quick:
        args.envs, args.rounds, args.warmup, args.camera_envs = 64, 2, 1, 16
    print(f"torch {torch.__version__}, {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at the start, "
          f"{'thread CPU time' if args.cpu_time else 'wall clock'}")
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
        named = [(name, config, None)]
        if name == "today" and args.device != "cpu":
            named.append((f"today, {args.device}",
                          dataclasses.replace(config, device=args.device), "today"))
        for row, row_config, base in named:
            try:
                benches.append(build(row, row_config, base=base,
                                     compile_models=changes.get("compile", False)))
            except Exception as error:  # noqa: BLE001 - reported as the row's result
                benches.append(Bench(name=row, runner=None, threads=1,
                                     error=f"{type(error).__name__}: {error}"))
    run(benches, args.rounds, args.warmup)
    report(f"PPO, state observations, {args.envs} copies x {args.cars} car(s), 32 steps per "
           f"iteration ({args.rounds} rounds, load average {os.getloadavg()[0]:.1f} at the end)",
           benches)
    if args.camera:
        rows = on_device(camera_rows(args.camera_envs,
                                     recipe_envs=args.camera_envs if args.quick else None),
                         args.device)
        cameras = [build(name, config, base=base) for name, config, base in rows]
        run(cameras, max(2, args.rounds // 3), args.warmup)
        device_ratio = (f", a {args.device} row's to the same row on the cpu"
                        if args.device != "cpu" else "")
        report(f"camera rows, today's with {args.camera_envs} copies; ratios: a fast row's to "
               f"the today's row above it{device_ratio} ({max(2, args.rounds // 3)} rounds, load average "
               f"{os.getloadavg()[0]:.1f} at the end)", cameras)


if __name__ == "__main__":
    main()
