"""A package that still gives the names of the module it replaced (``h2h_racing.track`` was
``track.py``; its names now live in ``track/shape.py``), imported when first used (PEP 562):
importing one submodule of the package does not import the face module's dependencies."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterable
from typing import Any


def lazy_face(package: str, face: str, names: Iterable[str],
              namespace: dict[str, Any]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of package ``package`` (its ``namespace``, the
    package's ``globals()``) that give ``names`` from module ``face`` (a full module path)."""
    exported = frozenset(names)

    def getattr_(name: str) -> Any:
        if name in exported:
            return getattr(importlib.import_module(face), name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def dir_() -> list[str]:
        return sorted(set(namespace) | exported)

    return getattr_, dir_
