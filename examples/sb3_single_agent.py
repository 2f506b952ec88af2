"""Train one car with Stable-Baselines3 PPO on the single-agent Gymnasium view.

    python examples/sb3_single_agent.py                       # alone on the oval, 4096 steps
    python examples/sb3_single_agent.py --opponents pure_pursuit --timesteps 200000 \
        --out runs/sb3_oval

The env is ``gymnasium.make("h2h_racing/Race-v0", ...)`` (registered by ``import h2h_racing``)
under training rules: one lap, and an infraction (off track, crash at fault, reversed,
immobilised) ends the episode. Opponents are driven inside the env. The default run is short
(a smoke test of the whole stack, not a trained driver): a car that laps the oval reliably
takes about 10^5-10^6 steps. After training the script drives one evaluation episode with
``model.predict(deterministic=True)`` and prints its progress and return.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

import gymnasium
from stable_baselines3 import PPO

import h2h_racing  # noqa: F401  (registers h2h_racing/Race-v0)


def make_env(track: str, opponents: Sequence[str], sensors: Sequence[str]) -> gymnasium.Env:
    """The training env: one learner against ``opponents`` under training rules."""
    return gymnasium.make("h2h_racing/Race-v0", track=track, opponents=list(opponents),
                          sensors=list(sensors), rules="training")


def train(track: str = "oval", opponents: Sequence[str] = (), sensors: Sequence[str] = ("state",),
          timesteps: int = 4096, seed: int = 0, out: str | None = None,
          verbose: int = 0) -> dict[str, Any]:
    """Train PPO for ``timesteps`` env steps, then drive one deterministic episode.

    Returns:
        ``{"model": the PPO model, "steps": steps of the evaluation episode, "return": its
        return, "progress": the learner's lap progress in % at its end, "terminated": bool,
        "truncated": bool}``.
    """
    env = make_env(track, opponents, sensors)
    policy = "MlpPolicy" if isinstance(env.observation_space, gymnasium.spaces.Box) \
        else "MultiInputPolicy"
    # A short rollout keeps the default run quick; PPO's default is 2048 steps.
    n_steps = max(64, min(1024, timesteps))
    model = PPO(policy, env, n_steps=n_steps, batch_size=64, seed=seed, verbose=verbose)
    model.learn(total_timesteps=timesteps)
    if out is not None:
        model.save(out)
    obs, info = env.reset(seed=seed + 1)
    total, steps, terminated, truncated = 0.0, 0, False, False
    while not (terminated or truncated):
        action, _ = model.predict(obs, deterministic=True)
        obs, reward, terminated, truncated, info = env.step(action)
        total += float(reward)
        steps += 1
    env.close()
    return {"model": model, "steps": steps, "return": total, "progress": info["progress"],
            "terminated": terminated, "truncated": truncated}


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--track", default="oval", help="catalogue name or track file")
    parser.add_argument("--opponents", default="",
                        help="comma-separated drivers, e.g. racing_line,pure_pursuit (default: "
                             "alone)")
    parser.add_argument("--sensors", default="state",
                        help="comma-separated sensors: state, camera, lidar")
    parser.add_argument("--timesteps", type=int, default=4096, help="PPO training steps")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=None, help="save the model here (SB3 .zip)")
    args = parser.parse_args(argv)
    if args.timesteps < 1:
        parser.error(f"--timesteps must be >= 1, got {args.timesteps}")
    opponents = [d.strip() for d in args.opponents.split(",") if d.strip()]
    sensors = [s.strip() for s in args.sensors.split(",") if s.strip()]
    result = train(args.track, opponents, sensors, timesteps=args.timesteps, seed=args.seed,
                   out=args.out, verbose=1)
    end = "finished or retired" if result["terminated"] else "time limit"
    print(f"evaluation episode: {result['steps']} steps, return {result['return']:.2f}, "
          f"progress {result['progress']:.1f} % of the lap ({end})")
    if args.out:
        print(f"model -> {args.out}.zip (PPO.load to use it)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
