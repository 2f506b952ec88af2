"""Type checks of config files (TOML) against a config dataclass's field annotations.

A TOML file can hold a value of any type under any key; the configs' own checks then fail on
comparisons (``'<' not supported between 'str' and 'int'``) that name neither the key nor
what it should hold. ``check_fields`` runs first and refuses a value of the wrong type with a
message naming the key, the type expected and the value received. One string where a list of
strings is expected is taken as a list of that one name (``tracks = "oval"`` means
``tracks = ["oval"]``, not the letters o, v, a, l); lists become tuples.
"""

from __future__ import annotations

import dataclasses
import os
import tomllib
import types
import typing
from pathlib import Path
from typing import Any, Literal

from h2h_racing.common.json_files import MAX_JSON_DEPTH, check_depth

_NAMES = {int: "an integer", float: "a number", str: "a string", bool: "true or false"}
_PLURALS = {int: "integers", float: "numbers", str: "strings", bool: "true/false values"}


def _describe(hint: Any) -> str:
    """What a value of type ``hint`` looks like in a TOML file."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if hint in _NAMES:
        return _NAMES[hint]
    if origin is Literal:
        kinds = sorted({_NAMES.get(type(a), type(a).__name__) for a in args})
        return f"{' or '.join(kinds)} (one of {', '.join(repr(a) for a in args)})"
    if origin in (typing.Union, types.UnionType):
        parts = [_describe(a) for a in args if a is not type(None)]
        text = " or ".join(parts)
        return f"{text} (or left out)" if type(None) in args else text
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            if args[0] is str:
                return "a list of strings (or one string)"
            if args[0] in _PLURALS:
                return f"a list of {_PLURALS[args[0]]}"
            return f"a list, each {_describe(args[0])}"
        return f"a list of {len(args)} values ({', '.join(_describe(a) for a in args)})"
    if origin is dict:
        if args[1] in _PLURALS:
            return f"a table of {_PLURALS[args[1]]}"
        return f"a table, each value {_describe(args[1])}"
    if dataclasses.is_dataclass(hint):
        return f"a table of {hint.__name__} fields"
    return getattr(hint, "__name__", str(hint))


def _convert(value: Any, hint: Any) -> tuple[bool, Any]:
    """``(fits, value)``: whether ``value`` has type ``hint``, and the value to use (lists as
    tuples, one string as a one-name tuple)."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if hint is Any:
        return True, value
    if hint is bool:
        return isinstance(value, bool), value
    if hint is int:
        return isinstance(value, int) and not isinstance(value, bool), value
    if hint is float:
        return isinstance(value, (int, float)) and not isinstance(value, bool), value
    if hint is str:
        return isinstance(value, str), value
    if hint is type(None):
        return value is None, value
    if origin is Literal:
        # Only the type: which values are allowed is the config's own check (its message).
        return any(type(value) is type(a) for a in args), value
    if origin in (typing.Union, types.UnionType):
        for arg in args:
            fits, converted = _convert(value, arg)
            if fits:
                return True, converted
        return False, value
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            if args[0] is str and isinstance(value, str):
                return True, (value,)
            items = [args[0]] * len(value) if isinstance(value, (list, tuple)) else []
        else:
            items = list(args)
        if not isinstance(value, (list, tuple)) or len(value) != len(items):
            return False, value
        converted = []
        for item, hint_item in zip(value, items):
            fits, item = _convert(item, hint_item)
            if not fits:
                return False, value
            converted.append(item)
        return True, tuple(converted)
    if origin is dict:
        if not isinstance(value, dict):
            return False, value
        key_hint, value_hint = args
        return all(_convert(k, key_hint)[0] and _convert(v, value_hint)[0]
                   for k, v in value.items()), value
    if dataclasses.is_dataclass(hint):
        return isinstance(value, (dict, hint)), value
    if isinstance(hint, type):
        return isinstance(value, hint), value
    return True, value


def check_fields(cls: type, values: dict[str, Any], source: str,
                 where: str = "") -> dict[str, Any]:
    """Check every value of ``values`` whose key is a field of the dataclass ``cls`` against
    the field's annotation; return the values with lists as tuples.

    Args:
        cls: The config dataclass.
        values: Parsed values (e.g. a TOML table); unknown keys are left to the caller.
        source: Where the values come from (the file), for the message.
        where: Table prefix for the message, e.g. ``"[ppo] "``.

    Raises:
        ValueError: ``"<source>: <where><key> must be <expected>, got <value> (<type>)"``.
    """
    hints = typing.get_type_hints(cls)
    out = dict(values)
    for key, value in values.items():
        if key not in hints:
            continue
        fits, converted = _convert(value, hints[key])
        if not fits:
            raise ValueError(f"{source}: {where}{key} must be {_describe(hints[key])}, got "
                             f"{value!r} ({type(value).__name__})")
        out[key] = converted
    return out


def build_tables(cls: type, data: dict[str, Any], source: str, tables: dict[str, type],
                 moved: dict[str, str] | None = None,
                 removed: dict[str, str] | None = None) -> dict[str, Any]:
    """The keyword arguments of config dataclass ``cls`` from a parsed TOML file: top-level
    keys are ``cls``'s fields, and each table named in ``tables`` fills its config dataclass.
    Unknown keys, at the top or in a table, are refused with the allowed ones; types are
    checked as ``check_fields`` does.

    Args:
        moved: Top-level keys of an earlier layout -> where they are now (``"[table] key"``).
        removed: Keys that were removed -> why.

    Raises:
        ValueError: ``"<source>: ..."``: a removed or moved key (saying why or where to), an
            unknown key, a value of the wrong type, or a table's own check.
    """
    gone = sorted(key for key in data if key in (removed or {}))
    if gone:
        raise ValueError(f"{source}: {', '.join(gone)} was removed: "
                         + "; ".join(removed[key] for key in gone))  # type: ignore[index]
    elsewhere = sorted(key for key in data if key in (moved or {}))
    if elsewhere:
        raise ValueError(f"{source}: {', '.join(elsewhere)} moved into tables: "
                         + "; ".join(f"{key} is now {moved[key]}"  # type: ignore[index]
                                     for key in elsewhere))
    for key, kind in ((None, cls), *tables.items()):
        table = data if key is None else data.get(key, {})
        if key is not None and not isinstance(table, (dict, kind)):
            raise ValueError(f"{source}: {key!r} must be a table of {kind.__name__} fields, "
                             f"got {table!r}")
        if isinstance(table, kind):
            continue
        known = {f.name for f in dataclasses.fields(kind)}
        unknown = sorted(set(table) - known)
        if unknown:
            where = "" if key is None else f"[{key}] "
            raise ValueError(f"{source}: {where}unknown keys {unknown}; allowed keys are "
                             f"{sorted(known)}")
    values = check_fields(cls, data, source)
    for key, kind in tables.items():
        if isinstance(values.get(key), dict):
            table = check_fields(kind, values[key], source, f"[{key}] ")
            try:
                values[key] = kind(**table)
            except (TypeError, ValueError) as err:
                raise ValueError(f"{source}: {err}") from None
    return values


MAX_TOML_BYTES = 2**20
"""Largest config file read [bytes] (the shipped ones are 1-3 KB)."""


def read_toml(path: str | Path) -> dict[str, Any]:
    """The parsed contents of the TOML file at ``path``; invalid TOML raises ``ValueError``
    naming the file."""
    try:
        size = os.stat(path).st_size
        if size > MAX_TOML_BYTES:
            raise ValueError(f"{path}: the file is {size} bytes; a config file may be at most "
                             f"{MAX_TOML_BYTES} bytes")
        with open(path, "rb") as handle:
            data = tomllib.load(handle)
    except tomllib.TOMLDecodeError as err:
        raise ValueError(f"{path}: not valid TOML: {err}") from None
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: a config file must be UTF-8 text (TOML), but byte {err.start} "
                         f"is {err.object[err.start:err.start + 1]!r}; save it as UTF-8") from None
    except RecursionError:
        raise ValueError(f"{path}: arrays or tables nested too deep to read") from None
    # What the config code walks and prints is nested a few levels at most.
    check_depth(data, path, "the config", MAX_JSON_DEPTH)
    return data
