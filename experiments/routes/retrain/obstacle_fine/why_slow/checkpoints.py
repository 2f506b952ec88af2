"""Step 7's rsl-rl checkpoints (``runs/routes_obstacle_s0/model_N.pt``) as policy files that
``h2h-racing evaluate`` drives: the final ``policy.pt`` with the checkpoint's student weights.

    python experiments/routes/retrain/obstacle_fine/why_slow/checkpoints.py RUN OUT N [N ...]
"""

from __future__ import annotations

import sys
from pathlib import Path

import torch


def main(run: Path, out: Path, iterations: list[int]) -> None:
    out.mkdir(parents=True, exist_ok=True)
    final = torch.load(run / "policy.pt", weights_only=True)
    for n in iterations:
        student = torch.load(run / f"model_{n}.pt", weights_only=False)["student_state_dict"]
        payload = dict(final)
        payload["actor_state_dict"] = {key: student[key] for key in final["actor_state_dict"]}
        torch.save(payload, out / f"model_{n}.pt")


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]), [int(n) for n in sys.argv[3:]])
