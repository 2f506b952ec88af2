"""Start point of the distilled obstacle recipe: ``ppo_generalist`` made ready to learn to see
boxes and bots.

    python experiments/obstacles/prepare_init.py [--policy ppo_generalist] OUT.pt

``ppo_generalist`` never met a box or another car, so its state vector's opponent and obstacle
slots (features 19-32) were always 0: its observation normaliser holds mean 0 and std 0 for
them (a box in view becomes an input of 1 / 0.01 = 100), and the first layer's weights of
those inputs are still their random initial values (they never got a gradient). Fine-tuned as
it is, the policy's first sight of a box is a kick of random size.

The file written here is the same policy as ``TrainConfig.init_fresh_slots`` loads it
(``h2h_racing.training.policy_file.freshen_slots``), with

- the first layer's weights of the slot features set to 0: it drives exactly as
  ``ppo_generalist`` until training gives them weight;
- the normaliser's sample count cut to ``FRESH_SLOTS_COUNT`` (two rollouts of 512 copies x 32 steps):
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
from h2h_racing.training.policy_file import FRESH_SLOTS_COUNT, freshen_slots


def prepare(policy: str, out: Path) -> dict[str, float]:
    """Write the prepared copy of ``policy`` to ``out``; return what was changed."""
    payload = load_policy_payload(policy)
    actor = payload["actor_state_dict"]
    changed = {"slot_weight_abs_sum": float(actor["mlp.0.weight"][:, BASE_FEATURES:].abs().sum())
               if "mlp.0.weight" in actor else 0.0,
               "count_before": float(actor["obs_normalizer.count"])}
    try:
        freshen_slots(payload, policy)
    except ValueError as error:
        raise SystemExit(str(error)) from None
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
          f" set to 0, normaliser count {changed['count_before']:.0f} -> {FRESH_SLOTS_COUNT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
