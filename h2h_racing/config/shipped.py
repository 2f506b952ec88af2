"""Config files shipped in the wheel, found by name from any directory.

``h2h-racing league train --config recommended`` and ``h2h-racing train --config
ppo_generalist/imitate`` work from an installed wheel as from a clone: an argument that is not
an existing file is looked up among the shipped configs of its kind.

- league configs: ``league/<name>.toml`` (package ``h2h_racing.league``), named ``<name>``;
- training configs: the files that trained a shipped policy,
  ``policies/trained/<policy>/<step>.toml`` (package ``h2h_racing.policies``), named
  ``<policy>/<step>``.

The recorded experiments' configs (``experiments/``) are not shipped; give their path.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Literal

ConfigKind = Literal["league", "train"]
KINDS: tuple[ConfigKind, ...] = ("league", "train")
_WHAT = {"league": "league config", "train": "training config"}


def shipped_configs(kind: ConfigKind) -> dict[str, Path]:
    """The shipped configs of ``kind``, name -> file."""
    if kind == "league":
        root = resources.files("h2h_racing.league")
        return {entry.name.removesuffix(".toml"): Path(str(entry))
                for entry in root.iterdir() if entry.name.endswith(".toml")}
    if kind == "train":
        trained = resources.files("h2h_racing.policies") / "trained"
        return {f"{policy.name}/{entry.name.removesuffix('.toml')}": Path(str(entry))
                for policy in trained.iterdir() if policy.is_dir()
                for entry in policy.iterdir() if entry.name.endswith(".toml")}
    raise ValueError(f"config kind must be one of {KINDS}, got {kind!r}")


def resolve_config(arg: str | Path, kind: ConfigKind) -> Path:
    """The file ``arg`` names: an existing path as given, else the shipped config of that name
    (``.toml`` optional). Raises ``FileNotFoundError`` listing the shipped names otherwise."""
    path = Path(arg)
    if path.is_file():
        return path
    shipped = shipped_configs(kind)
    name = str(arg).removesuffix(".toml")
    if name in shipped:
        return shipped[name]
    raise FileNotFoundError(
        f"--config {str(arg)!r}: no such file, and no shipped {_WHAT[kind]} of that name; "
        f"shipped: {', '.join(sorted(shipped))} (or give the path of a TOML file)")
