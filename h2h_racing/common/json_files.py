"""Read a JSON file the user gives (a track, ``model_metadata.json``) with every failure a
``ValueError`` that names the file.

``json.loads`` alone lets through a ``UnicodeDecodeError`` for a UTF-16 or binary file, a
``RecursionError`` for deeply nested arrays, and a message without the file for integers of
more than 4,300 digits; a file may also be any size. Here each is refused in one line, and
the data is checked to be nested at most ``MAX_JSON_DEPTH`` deep, so code that walks it or
prints it never recurses far.
"""

from __future__ import annotations

import json
import reprlib
from pathlib import Path
from typing import Any

MAX_JSON_DEPTH = 32
"""Deepest nesting of arrays and objects accepted (DeepRacer's metadata is 3 deep, a track 1)."""
MAX_JSON_BYTES = 32 * 2**20
"""Largest JSON file read [bytes]: a track of 100,000 vertices is about 9 MB."""

_short = reprlib.Repr()
_short.maxstring = 60
_short.maxother = 60
_short.maxlist = _short.maxdict = 6
_short.maxlevel = 3


def short_repr(value: Any) -> str:
    """``repr(value)`` cut to a line (long numbers, lists, dicts and nesting elided with ``...``).

    >>> short_repr(list(range(100)))
    '[0, 1, 2, 3, 4, 5, ...]'
    """
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 200:
        return f"<an integer of about {int(value.bit_length() * 0.30103) + 1} digits>"
    return _short.repr(value)


def read_json_file(path: str | Path, what: str, max_bytes: int = MAX_JSON_BYTES) -> Any:
    """Return the parsed JSON of ``path``, or raise ``ValueError`` naming the file.

    Args:
        path: The file.
        what: What the file should be, for the messages (``"model metadata"``).
        max_bytes: Largest file accepted [bytes].

    Raises:
        ValueError: The file is missing or unreadable, larger than ``max_bytes``, not UTF-8 text,
            not JSON, nested deeper than ``MAX_JSON_DEPTH``, or holds an integer too long to read.
    """
    path = Path(path)
    try:
        size = path.stat().st_size
        if size > max_bytes:
            raise ValueError(f"{path}: the file is {size} bytes; {what} may be at most {max_bytes} "
                             f"bytes")
        raw = path.read_bytes()
    except OSError as exc:
        raise ValueError(f"{path}: cannot read {what} ({exc})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: {what} must be UTF-8 text (JSON), but byte {exc.start} is "
                         f"{raw[exc.start:exc.start + 1]!r}; save the file as UTF-8") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: cannot read {what}: not valid JSON ({exc})") from None
    except RecursionError:
        raise ValueError(f"{path}: {what} is nested deeper than {MAX_JSON_DEPTH} levels of arrays "
                         f"and objects") from None
    except ValueError as exc:  # an integer of more than sys.get_int_max_str_digits() digits
        raise ValueError(f"{path}: {what} holds a number too long to read ({exc})") from None
    check_depth(data, path, what)
    return data


def check_depth(data: Any, path: str | Path, what: str, max_depth: int = MAX_JSON_DEPTH) -> None:
    """Raise ``ValueError`` if ``data`` (parsed JSON or TOML) nests lists and dicts deeper than
    ``max_depth`` (checked iteratively)."""
    stack = [(data, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, (list, dict)):
            if depth > max_depth:
                raise ValueError(f"{path}: {what} is nested deeper than {max_depth} levels of "
                                 f"arrays and objects")
            values = item.values() if isinstance(item, dict) else item
            stack.extend((v, depth + 1) for v in values if isinstance(v, (list, dict)))
