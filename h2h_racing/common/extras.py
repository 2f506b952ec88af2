"""Optional dependencies: one message for a missing one, naming the extra that installs it.

The env itself needs none of them. Training and trained drivers need torch and rsl-rl
(``train``), recordings need rerun-sdk (``viz``), ``--backend ray`` needs Ray (``ray``) and
league figures need matplotlib (``league``); see pyproject.toml's optional dependencies.

>>> install_hint("train")
'pip install "h2h-racing[train]"'
"""

from __future__ import annotations

EXTRAS = {"train": "torch and rsl-rl-lib", "viz": "rerun-sdk", "ray": "ray",
          "league": "matplotlib"}
"""Extra name -> the packages it installs (as pyproject.toml's optional dependencies)."""


def install_hint(extra: str) -> str:
    """The command that installs optional dependency group ``extra``."""
    if extra not in EXTRAS:
        raise ValueError(f"unknown extra {extra!r}; known extras: {sorted(EXTRAS)}")
    return f'pip install "h2h-racing[{extra}]"'


def missing_extra(extra: str, purpose: str, error: ImportError | None = None) -> ImportError:
    """The ``ImportError`` to raise when ``purpose`` (e.g. "training") lacks extra ``extra``.

    Args:
        extra: A key of ``EXTRAS``.
        purpose: What needs it, as the subject of "needs" ("trained drivers").
        error: The ImportError caught; its missing module is named in the message.
    """
    missing = f" ({error.name} is missing)" if error is not None and error.name else ""
    return ImportError(f"{purpose} needs the optional {EXTRAS[extra]} package(s), which are not "
                       f"installed{missing}; install them with: {install_hint(extra)}")
