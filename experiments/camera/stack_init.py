"""Start a frame-stacked camera student from a one-frame one.

    python experiments/camera/stack_init.py POLICY FRAMES OUT.pt

The first convolution of ``POLICY`` (a camera policy trained on one frame) reads one input
channel. The file written here has ``FRAMES`` input channels, oldest frame first: the newest
frame's weights are the old ones and the older frames' are 0, so the new student drives
exactly as ``POLICY`` until training gives the older frames weight. The camera settings say
``frame_stack = FRAMES``; everything else is ``POLICY``'s.
"""

from __future__ import annotations

import sys
from pathlib import Path

import torch

from h2h_racing.policies.trained import load_policy_payload

FIRST_CONV = "cnns.camera.0.weight"
"""The first convolution's weights, (out, in, k, k), in the camera actor's state dict."""


def stack(policy: str, frames: int, out: Path) -> None:
    """Write ``policy`` widened to ``frames`` stacked frames to ``out``."""
    payload = load_policy_payload(policy)
    camera = payload["env_config"]["camera"]
    if camera["frame_stack"] != 1 or camera["stereo"]:
        raise SystemExit(f"{policy}: a one-frame mono camera policy is needed, got "
                         f"frame_stack={camera['frame_stack']}, stereo={camera['stereo']}")
    weights = payload["actor_state_dict"][FIRST_CONV]
    wide = torch.zeros(weights.shape[0], frames, *weights.shape[2:], dtype=weights.dtype)
    wide[:, -1] = weights[:, 0]
    payload["actor_state_dict"][FIRST_CONV] = wide
    camera["frame_stack"] = frames
    payload["train_config"]["camera_frames"] = frames
    torch.save(payload, out)


if __name__ == "__main__":
    if len(sys.argv) != 4:
        raise SystemExit(__doc__)
    stack(sys.argv[1], int(sys.argv[2]), Path(sys.argv[3]))
