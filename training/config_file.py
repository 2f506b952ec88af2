"""Reading a training config file: TOML, optionally ``extends`` another config.

A recipe's later steps differ from its first in a few keys (a learning rate, a share of
tracks), so a step's file can name the file it builds on and give only what changes::

    extends = "tight.toml"          # beside this file, or a shipped name ("ppo_generalist/imitate")
    [procedural]
    circuit_share = 0.4

The base is read first (itself perhaps extending another), then this file's keys replace its
keys: top-level keys whole, tables (``[procedural]``, ``[distill]`` ...) key by key, so that
a table given here keeps the base's other keys. A value that is itself a table inside a table
(``[imitation] options = {...}``) replaces the base's whole.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from h2h_racing.training.toml_types import read_toml

MAX_DEPTH = 8
"""Most files in one chain of ``extends``."""


def read_train_toml(path: str | Path) -> dict[str, Any]:
    """The data of the training config at ``path`` with its ``extends`` chain merged in;
    ``ValueError`` naming the file on invalid TOML, a base that cannot be found, a cycle or a
    chain longer than ``MAX_DEPTH``."""
    chain: list[Path] = []
    return _read(Path(path), chain)


def _read(path: Path, chain: list[Path]) -> dict[str, Any]:
    resolved = path.resolve()
    if resolved in chain:
        names = " -> ".join(str(p) for p in [*chain, resolved])
        raise ValueError(f"{path}: extends goes round in a circle ({names}); remove one extends")
    if len(chain) >= MAX_DEPTH:
        raise ValueError(f"{path}: more than {MAX_DEPTH} files extend one another; merge some")
    chain.append(resolved)
    data = read_toml(path)
    base = data.pop("extends", None)
    if base is None:
        return data
    if not isinstance(base, str) or not base:
        raise ValueError(f"{path}: extends must be the path of a TOML file (relative to this "
                         f"file's folder) or a shipped config's name, got {base!r}")
    merged = _read(_base_path(path, base), chain)
    for key, value in data.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = {**merged[key], **value}
        else:
            merged[key] = value
    return merged


def _base_path(path: Path, base: str) -> Path:
    """``base`` beside ``path``, else the shipped training config of that name."""
    from h2h_racing.config.shipped import shipped_configs

    beside = path.parent / base
    if beside.is_file():
        return beside
    shipped = shipped_configs("train")
    name = base.removesuffix(".toml")
    if name in shipped:
        return shipped[name]
    raise ValueError(f"{path}: extends = {base!r}: no file {beside}, and no shipped training "
                     f"config of that name; shipped: {', '.join(sorted(shipped))} (or give a "
                     f"path relative to this file's folder)")
