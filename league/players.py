"""League players: the record, and the player a driver named on the command line becomes."""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
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


LEAGUE_FILE = "league.sqlite"
"""The league file of a league folder (``league train --out``)."""


def _policy_name(path: Path) -> str:
    """A readable player name for a policy file.

    A league's files are named by the league folder and what they are, so two leagues'
    learners differ: ``runs/leagues/rec/learners/main/latest.pt`` -> ``rec/main``, its
    ``learners/main/best/latest.pt`` -> ``rec/main/best``, ``snapshots/main_v3.pt`` ->
    ``rec/main_v3`` (a folder holding ``league.sqlite``). Otherwise ``runs/abc/policy.pt`` ->
    ``abc``, any other ``latest.pt`` -> its path relative to the current folder without
    ``.pt`` (``latest`` says nothing), and ``x/best.pt`` -> ``best``.
    """
    league = _league_name(path)
    if league is not None:
        return league
    if path.stem == "policy" and path.parent.name:
        return path.parent.name
    if path.stem == "latest":
        return _relative(path).with_suffix("").as_posix()
    return path.stem


def _league_name(path: Path) -> str | None:
    """``<league>/<learner>[/best]`` or ``<league>/<snapshot>`` for a file of a league folder
    (see ``_policy_name``); None for any other file."""
    absolute = path.resolve()
    parts = absolute.parts
    for depth in (2, 3, 4):  # snapshots/X.pt, learners/L/latest.pt, learners/L/best/latest.pt
        if len(parts) <= depth:
            break
        folder = absolute.parents[depth - 1]
        if not (folder / LEAGUE_FILE).is_file():
            continue
        inside = parts[len(folder.parts):]
        if inside[0] == "snapshots" and len(inside) == 2:
            return f"{folder.name}/{path.stem}"
        if inside[0] == "learners" and inside[-1] == "latest.pt" and len(inside) in (3, 4):
            return "/".join((folder.name, *inside[1:-1]))
    return None


def _relative(path: Path) -> Path:
    """``path`` relative to the current folder when it is inside it, else absolute."""
    absolute = path.resolve()
    try:
        return absolute.relative_to(Path.cwd().resolve())
    except ValueError:
        return absolute


def check_distinct_names(given: Sequence[str], names: Sequence[str]) -> None:
    """Refuse two players given as ``given`` that become one player name (``names``).

    Raises:
        ValueError: Naming each clash: which players, which name, and what to do.
    """
    by_name: dict[str, list[str]] = {}
    for spec, name in zip(given, names):
        by_name.setdefault(name, []).append(spec)
    clashes = {name: specs for name, specs in by_name.items() if len(specs) > 1}
    if clashes:
        told = "; ".join(f"{' and '.join(specs)} are "
                         f"{'both' if len(specs) == 2 else 'all'} named {name!r}"
                         for name, specs in clashes.items())
        raise ValueError(
            f"two players of the tournament would have one name: {told}. A scripted driver "
            f"with the same settings is one player: give it once. Policy files are named by "
            f"their league and learner (runs/leagues/L/learners/main/latest.pt: L/main), "
            f"their folder (runs/x/policy.pt: x) or their file name: copy one of them to a "
            f"file of another name")
