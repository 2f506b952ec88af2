"""Example files, shipped in the wheel as ``h2h_racing.examples``.

``deepracer/``: AWS DeepRacer reward functions and a ``model_metadata.json``, usable unchanged
with ``reward_function=`` / ``load_model_metadata`` and ``h2h-racing train|race
--reward-function --model-metadata``. From an installed wheel::

    from h2h_racing.examples import path
    path("deepracer/follow_centre_line.py")          # the file's location in the install
    shutil.copytree(path("deepracer"), "my_model")   # a copy to edit

The other ``*.py`` files are scripts that train with other libraries (run them from a clone:
``python examples/<name>.py``).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def path(name: str) -> Path:
    """The shipped example file or folder ``name`` (e.g. ``"deepracer/model_metadata.json"``)."""
    root = Path(str(resources.files(__name__)))
    found = root / name
    if not found.exists():
        shipped = sorted(p.relative_to(root).as_posix() for p in root.rglob("*")
                         if p.is_file() and p.suffix in (".py", ".json")
                         and p.name != "__init__.py" and "__pycache__" not in p.parts)
        raise FileNotFoundError(f"no example {name!r} in {root}; shipped: {', '.join(shipped)}")
    return found
