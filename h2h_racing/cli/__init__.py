"""The ``h2h-racing`` command (``command.main``) and its help pages; the training commands are in
``h2h_racing.training.cli``, the league's in ``h2h_racing.league.cli``.

The names of the old ``h2h_racing.cli`` module are here too (from ``command``, imported
when first used).
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "ArgumentParser",
    "DESCRIPTION",
    "DRIVERS_HELP",
    "EPILOG",
    "RACE_TYPES",
    "SEED_HELP",
    "TRACKS_NOTE",
    "add_progress_flag",
    "add_training_commands",
    "build_parser",
    "main",
    "progress_mode",
    "warn_trained_alone",
]


def __getattr__(name: str) -> Any:
    # Lazily, so that importing one submodule does not import the face module's dependencies.
    if name in __all__:
        return getattr(importlib.import_module("h2h_racing.cli.command"), name)
    raise AttributeError(f"module 'h2h_racing.cli' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
