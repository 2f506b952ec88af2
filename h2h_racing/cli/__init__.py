"""The ``h2h-racing`` command (``command.main``) and its help pages; the training commands are in
``h2h_racing.training.cli``, the league's in ``h2h_racing.league.cli``.

The names of the old ``h2h_racing.cli`` module are here too (from ``command``, imported
when first used).
"""

from __future__ import annotations

from h2h_racing.common.faces import lazy_face

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

__getattr__, __dir__ = lazy_face(__name__, "h2h_racing.cli.command", __all__, globals())
