"""Start point of the distilled obstacle recipe: ``ppo_generalist`` made ready to learn to see
boxes and bots.

    python experiments/obstacles/prepare_init.py [--policy ppo_generalist] OUT.pt

``ppo_generalist`` never met a box or another car, so its state vector's opponent and obstacle
slots (features 19-32) were always 0: its observation normaliser holds mean 0 and std 0 for
them (a box in view becomes an input of 1 / 0.01 = 100), and the first layer's weights of
those inputs are still their random initial values (they never got a gradient). Fine-tuned as
it is, the policy's first sight of a box is a kick of random size.

The file written here is the same policy with

- the first layer's weights of the slot features set to 0: it drives exactly as
  ``ppo_generalist`` until training gives them weight;
- the normaliser's sample count cut to ``COUNT`` (two rollouts of 512 copies x 32 steps):
  its statistics follow the states with boxes and bots within a few iterations, instead of
  being outweighed by the 25.7 M box-free samples it was fitted on.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import torch

from h2h_racing.policies.trained import load_policy_payload
from h2h_racing.sensors.state import BASE_FEATURES

COUNT = 2 * 512 * 32
"""Sample count the normaliser restarts from."""


def prepare(policy: str, out: Path) -> dict[str, float]:
    """Write the prepared copy of ``policy`` to ``out``; return what was changed."""
    payload = load_policy_payload(policy)
    if payload["observations"] != "state":
        raise SystemExit(f"{policy}: a state-observation policy is needed, got "
                         f"{payload['observations']!r}")
    actor = payload["actor_state_dict"]
    weight = actor["mlp.0.weight"]
    slots = slice(BASE_FEATURES, weight.shape[1])
    changed = {"slot_weight_abs_sum": float(weight[:, slots].abs().sum()),
               "count_before": float(actor["obs_normalizer.count"])}
    weight[:, slots] = 0.0
    actor["obs_normalizer.count"] = torch.tensor(COUNT, dtype=actor["obs_normalizer.count"].dtype)
    payload["training"] = {**payload.get("training", {}),
                           "prepared_by": "experiments/obstacles/prepare_init.py",
                           "prepared_from": str(policy)}
    out.parent.mkdir(parents=True, exist_ok=True)
    torch.save(payload, out)
    load_policy_payload(out)  # the copy must load as a policy file
    return changed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--policy", default="ppo_generalist")
    args = parser.parse_args(argv)
    changed = prepare(args.policy, args.out)
    print(f"{args.policy} -> {args.out}: slot weights |sum| {changed['slot_weight_abs_sum']:.2f}"
          f" set to 0, normaliser count {changed['count_before']:.0f} -> {COUNT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
