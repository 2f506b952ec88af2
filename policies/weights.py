"""Read the torch files the project loads, weights-only, with errors that name the file.

Every ``.pt`` file h2h-racing reads goes through ``load_weights``: policy files (drivers,
``--init``, teachers, opponents, tournament entrants, league snapshots and best states) and a
league learner's rsl-rl runner state (``runner.pt``). It calls
``torch.load(weights_only=True)``, which unpickles only tensors and plain Python values, so a
file that holds anything else (a pickle whose ``__reduce__`` would run a command) is refused
before any of it runs.

Every failure is a ``WeightsFileError`` (a ``ValueError``) naming the file, what is wrong and
what was expected. torch's own message is never passed on: it advises retrying with
``weights_only=False``, which would run the file's code.
"""

from __future__ import annotations

import os
import pickle
import warnings
from collections.abc import Mapping
from pathlib import Path
from types import ModuleType
from typing import Any

from h2h_racing.common.extras import missing_extra


_UNSAFE_OBJECT = ("GLOBAL", "allowlisted", "Can only")
"""Words of torch's weights-only errors for a file that holds code or foreign objects."""


class WeightsFileError(ValueError):
    """A file that should hold weights is unreadable, unsafe or not what was expected."""


def import_torch(purpose: str = "trained drivers") -> ModuleType:
    """Import torch, or raise the ``ImportError`` that names the ``train`` extra."""
    os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")  # rsl-rl imports GitPython
    try:
        import torch
    except ImportError as error:
        raise missing_extra("train", purpose, error) from None
    return torch


def load_weights(path: str | Path, expected: str) -> Any:
    """Load ``path`` with ``torch.load(weights_only=True)`` onto the CPU.

    Args:
        path: The file.
        expected: What the file should be, for messages ("an h2h-racing policy file").

    Raises:
        FileNotFoundError: ``path`` is not a file.
        WeightsFileError: The file is empty, truncated or corrupt, or holds objects other than
            tensors and plain values (refused unread).
        ImportError: torch is not installed (the message names the extra to install).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file; expected {expected}")
    torch = import_torch()
    if path.stat().st_size == 0:
        raise WeightsFileError(f"{path}: the file is empty (0 bytes); expected {expected}")
    try:
        with warnings.catch_warnings():
            # torch warns about the pickle protocol of files it did not write; the error
            # below says all that matters.
            warnings.simplefilter("ignore")
            return torch.load(path, weights_only=True, map_location="cpu")
    except MemoryError:
        raise
    except pickle.UnpicklingError as error:
        # torch's weights-only unpickler names the global or class it would not build; other
        # unpickling errors (unknown opcodes) mean the bytes are no torch file at all.
        if any(word in str(error) for word in _UNSAFE_OBJECT):
            raise WeightsFileError(
                f"{path}: refused: the file holds Python objects other than tensors and plain "
                f"values, and reading them could run code; expected {expected}. h2h-racing "
                f"loads weights only: use a file written by h2h-racing, or one saved with "
                f"torch.save of tensors and plain values") from None
        raise _corrupt(path, error, expected) from None
    except Exception as error:  # torch raises RuntimeError, EOFError, OSError, KeyError, ...
        raise _corrupt(path, error, expected) from None


def _corrupt(path: Path, error: Exception, expected: str) -> WeightsFileError:
    return WeightsFileError(f"{path}: cannot be read as a torch file ({type(error).__name__}): "
                            f"it is truncated, corrupt or another kind of file; expected "
                            f"{expected}")


def check_keys(payload: Any, keys: Mapping[str, type | tuple[type, ...]], source: str,
               expected: str) -> dict[str, Any]:
    """``payload`` if it is a dict holding each of ``keys`` with a value of its type.

    Raises:
        WeightsFileError: Naming ``source``, the first key missing or of the wrong type, and
            ``expected``.
    """
    if not isinstance(payload, dict):
        raise WeightsFileError(f"{source}: holds a {type(payload).__name__}; expected "
                               f"{expected} (a dict)")
    missing = [key for key in keys if key not in payload]
    if missing:
        raise WeightsFileError(f"{source}: missing key(s) {missing}; expected {expected}, a "
                               f"dict with keys {list(keys)}")
    for key, kind in keys.items():
        if not isinstance(payload[key], kind) or (isinstance(payload[key], bool)
                                                  and kind is int):
            names = " or ".join(t.__name__ for t in (kind if isinstance(kind, tuple)
                                                     else (kind,)))
            raise WeightsFileError(f"{source}: key {key!r} holds a "
                                   f"{type(payload[key]).__name__}, expected a {names} "
                                   f"({expected})")
    return payload
