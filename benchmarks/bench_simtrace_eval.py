"""Cost of DeepRacer's evaluation episodes in ``train --simtrace`` (issue 39); asserts nothing.

    python benchmarks/bench_simtrace_eval.py                      # ~3 min
    python benchmarks/bench_simtrace_eval.py --envs 32 --iterations 40

Trains the DeepRacer guide's run (``train --track oval --reward-function
follow_centre_line.py --opponents none --simtrace 2``: a time trial, 20 episodes per simtrace
iteration) twice in one process, with its 5 evaluation episodes per iteration and without
(``simtrace_eval_trials`` 5 and 0), the same seed, after a short warm-up run, in turns
(``--rounds``). Prints per run the wall-clock and process CPU time, the time spent inside the
evaluations (``SimtraceEvaluations.run``), the training episodes of env copy 0, and the
evaluation blocks, episodes and simulated steps.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from h2h_racing.training.config import TrainConfig
from h2h_racing.training.simtrace_eval import SimtraceEvaluations
from h2h_racing.training.train import train

ROOT = Path(__file__).resolve().parents[1]
REWARD = ROOT / "examples" / "deepracer" / "follow_centre_line.py"


def one_run(config: TrainConfig, iterations: int) -> dict[str, float]:
    """Train once; return its figures."""
    spent = {"seconds": 0.0, "blocks": 0}
    original = SimtraceEvaluations.run

    def timed(self: SimtraceEvaluations, *args, **kwargs):  # type: ignore[no-untyped-def]
        start = time.perf_counter()
        try:
            return original(self, *args, **kwargs)
        finally:
            spent["seconds"] += time.perf_counter() - start
            spent["blocks"] += 1

    SimtraceEvaluations.run = timed  # type: ignore[method-assign]
    try:
        with tempfile.TemporaryDirectory() as out:
            wall, cpu = time.perf_counter(), time.process_time()
            train(config, iterations=iterations, out=out)
            wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
            rows = json.loads((Path(out) / "simtrace" / "car_0" / "metrics" /
                               "TrainingMetrics.json").read_text())["metrics"]
    finally:
        SimtraceEvaluations.run = original  # type: ignore[method-assign]
    evaluation = [r for r in rows if r["phase"] == "evaluation"]
    step_ms = 1000.0 * config.env_config().step_dt
    return {"wall": wall, "cpu": cpu, "in_eval": spent["seconds"], "blocks": spent["blocks"],
            "episodes": sum(r["phase"] == "training" for r in rows),
            "eval_episodes": len(evaluation),
            "eval_steps": round(sum(r["elapsed_time_in_milliseconds"] for r in evaluation)
                                / step_ms)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, default=4, help="env copies (default: 4)")
    parser.add_argument("--iterations", type=int, default=130,
                        help="PPO iterations of 32 steps per copy (default: 130)")
    parser.add_argument("--rounds", type=int, default=1,
                        help="runs of each setting, in turns (default: 1)")
    args = parser.parse_args()
    base = TrainConfig(track="oval", num_envs=args.envs, reward_function=str(REWARD),
                       simtrace_envs=2, eval_every=0)
    train(base, iterations=2, out=None)  # warm-up: compiled kernels, imports
    print(f"oval, follow_centre_line, {args.envs} env copies x 32 steps, {args.iterations} "
          f"iterations, simtrace 2 (20 episodes per iteration)")
    print(f"{'evaluations':<12} {'wall s':>8} {'cpu s':>8} {'in eval s':>10} {'blocks':>7} "
          f"{'episodes':>9} {'eval eps':>9} {'eval steps':>11}")
    for _ in range(args.rounds):
        for trials in (5, 0):
            config = TrainConfig(**{**base.__dict__, "simtrace_eval_trials": trials})
            r = one_run(config, args.iterations)
            print(f"{trials:<12} {r['wall']:>8.1f} {r['cpu']:>8.1f} {r['in_eval']:>10.2f} "
                  f"{r['blocks']:>7} {r['episodes']:>9} {r['eval_episodes']:>9} "
                  f"{r['eval_steps']:>11}")


if __name__ == "__main__":
    main()
