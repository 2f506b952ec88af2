"""League players: the record, and the player a driver named on the command line becomes."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

PLAYER_KINDS = ("scripted", "policy", "snapshot", "learner")
"""Allowed ``Player.kind`` values."""


@dataclass(frozen=True)
class Player:
    """A league player (see the module docstring for the fields)."""

    name: str
    kind: str
    role: str | None = None
    checkpoint: str | None = None
    checkpoint_sha256: str | None = None
    parent: str | None = None
    created: float = 0.0
    training_steps: int = 0


def file_sha256(path: str | Path) -> str:
    """SHA-256 of a file's bytes (hex)."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def player_for(name: str) -> Player:
    """A ``Player`` for a driver given as on the command line: a scripted driver with any
    settings (``racing_line:grip_factor=0.7``; the player is named by its spec written back,
    ``canonical_spec``, so two spellings of one setting are one player), a shipped driver name,
    or a ``policy.pt`` path (hashed, so a changed file is caught).

    Raises:
        ValueError: For an unknown player, or a scripted driver's bad setting
            (``parse_driver_spec``'s one line).
    """
    from h2h_racing.policies import DRIVERS
    from h2h_racing.policies.registry import SEPARATOR, parse_driver_spec
    from h2h_racing.policies.trained import shipped_policies

    if name.split(SEPARATOR, 1)[0].strip() in DRIVERS:
        spec = parse_driver_spec(name).text
        return Player(name=spec, kind="scripted", role="anchor", checkpoint=spec)
    shipped = shipped_policies()
    if name in shipped:
        return Player(name=name, kind="policy", checkpoint=str(shipped[name]),
                      checkpoint_sha256=file_sha256(shipped[name]))
    path = Path(name)
    if path.suffix == ".pt" and path.is_file():
        return Player(name=_policy_name(path), kind="policy", checkpoint=str(path),
                      checkpoint_sha256=file_sha256(path))
    if SEPARATOR in name and not name.endswith(".pt"):
        parse_driver_spec(name)  # settings on a trained policy: its own one line
    raise ValueError(f"unknown player {name!r}: give a driver name ({', '.join(sorted(DRIVERS))}"
                     f", with any settings: racing_line:grip_factor=0.7), a shipped policy "
                     f"({', '.join(sorted(shipped))}) or a policy.pt file")


def _policy_name(path: Path) -> str:
    """``runs/abc/policy.pt`` -> ``abc``; ``x/best.pt`` -> ``best``."""
    return path.parent.name if path.stem == "policy" and path.parent.name else path.stem

