"""Move the flat modules of ``h2h_racing/`` into the subpackages of its parts (issue 40).

Run from the repository root, on a clean checkout of the branch to restructure::

    python tools/restructure.py            # moves, rewrites, writes shims; then review and commit
    python tools/restructure.py --dry-run  # prints what it would move and the files it would edit

It is the record of the move and can be re-applied to a branch made before it (a branch merged
later): one table (``MOVES``) says where every module goes. What it does, in order:

1. refuses if the move was made already (a package folder of ``PACKAGES`` exists), or if
   ``h2h_racing/`` holds a module the table does not know (it prints them: add each to
   ``MOVES`` or ``STAY``; ``--leave-unknown`` leaves them where they are instead);
2. ``git mv``s every module of ``MOVES`` that exists (absent ones are skipped, so the table may
   name modules of branches not merged yet);
3. rewrites every reference in the tracked text files (code, docs, README, pyproject; not
   CHANGELOG.md, which records what was): ``from h2h_racing import spawn``, ``import
   h2h_racing.track_io``, ``h2h_racing.track_io.load_track`` in strings and prose (monkeypatch
   and mock paths, entry points) and file paths ``h2h_racing/track_io.py``;
4. writes each package's ``__init__.py``; the four old modules whose names are now packages
   (``track``, ``config``, ``viz``, ``cli``) keep their public names there, lazily;
5. writes a shim at every other old module path: importing ``h2h_racing.track_io`` warns
   (``DeprecationWarning``) and gives the new module itself, so old imports, monkeypatches
   and pickles keep working for one release;
6. breaks the import circle ``track`` <-> ``track_projection`` (a protocol instead of the type
   import) and the track package's import of the root package (``catalogue_dir``);
7. adds the packages to pyproject's explicit package list.

It stages its moves with git; the rewritten files are left for review (``git diff``).
"""

from __future__ import annotations

import argparse
import ast
import re
import subprocess
import sys
from pathlib import Path

# Old module (in h2h_racing/) -> new module, relative to h2h_racing ("training.cli" is the
# top-level training/ folder, installed as h2h_racing.training).
MOVES: dict[str, str] = {
    # sim/: the batched core and what it is made of
    "core": "sim.core",
    "core_state": "sim.state",
    "core_spawn": "sim.starts",
    "core_penalties": "sim.penalties",
    "core_events": "sim.events",
    "core_tracks": "sim.tracks",          # multitrack branch
    "core_view": "sim.view",              # multitrack branch
    "race": "sim.race",
    "physics": "sim.physics",
    "dynamics": "sim.dynamics",
    "bots": "sim.bots",
    "replacement": "sim.replacement",
    "spawn": "sim.layouts",
    "rewards": "sim.rewards",
    # track/: geometry, projection, lookup tables, file formats, generators, metrics
    "track": "track.shape",
    "track_geometry": "track.geometry",
    "track_projection": "track.projection",
    "track_lookup": "track.lookup",
    "track_tables": "track.tables",       # multitrack branch
    "track_io": "track.io",
    "track_gen": "track.generator",
    "track_gen_circuit": "track.circuits",
    "track_metrics": "track.metrics",
    # envs/: the PettingZoo env, the Gymnasium view, actions, rewards, infos, results
    "env": "envs.parallel",
    "env_actions": "envs.actions",
    "env_rewards": "envs.rewards",
    "infos": "envs.infos",
    "results": "envs.results",
    "single_agent": "envs.single_agent",
    # viz/: frames for people, rerun recordings and their viewer
    "render": "viz.render",
    "viz": "viz.recorder",
    "viz_cars": "viz.cars",
    "viz_events": "viz.events",
    "viz_server": "viz.server",
    # config/: the frozen, validated configs and the shipped config files
    "config": "config.env",
    "config_car": "config.car",
    "config_rules": "config.rules",
    "config_sensors": "config.sensors",
    "config_checks": "config.checks",
    "configs": "config.shipped",
    # common/: small helpers that import nothing of the project
    "progress": "common.progress",
    "json_files": "common.json_files",
    "lifeline": "common.lifeline",
    "extras": "common.extras",
    # cli/: the h2h-racing command; the training commands move beside the training code
    "cli": "cli.command",
    "cli_help": "cli.help",
    "cli_training": "training.cli",
    "cli_train": "training.cli_train",
}

# Modules that stay in h2h_racing/ itself: the package, and the Python face of `h2h-racing race`
# (env + drivers + recordings), which the README shows as h2h_racing.match.run_race.
STAY = {"__init__", "match"}

PACKAGES: dict[str, str] = {
    "sim": "The batched simulation core: ``RaceCore`` (E env copies x N cars in arrays), its "
           "state, starts,\npenalties and events, the race rules, physics (the only pymunk "
           "importer), tyre dynamics,\nbot cars, re-placement and the built-in reward. It "
           "imports only ``track``, ``config`` and ``common``.",
    "track": "Tracks: the ``Track`` shape, its geometry, projection grid and lookup tables, "
             "file formats,\ngenerators and metrics. It imports only ``common``.",
    "envs": "The envs over the core: the PettingZoo env (``parallel``, the only pettingzoo "
            "importer, and the\nenv card), the Gymnasium view (``single_agent``), actions, "
            "rewards, infos and results.",
    "viz": "What people see: spectator frames (``render``, which the env's render mode "
           "uses), rerun\nrecordings (``recorder``, the only rerun importer, lazily), their "
           "per-car streams, event\nlines and the web viewer's server.",
    "config": "The frozen, validated configs (``EnvConfig``, ``RewardConfig``, ``CarParams``, "
              "``RaceRules``,\n``CameraConfig``, ``LidarConfig``) and the config files "
              "shipped by name.",
    "common": "Small helpers shared by every part, importing nothing of the project: the "
              "commands' progress\nline, JSON files read safely, processes that die with "
              "their parent, optional-dependency hints.",
    "cli": "The ``h2h-racing`` command (``command.main``) and its help pages; the training "
           "commands are in\n``h2h_racing.training.cli``, the league's in "
           "``h2h_racing.league.cli``.",
}

# Packages whose name was a module before: they keep that module's public names (lazily, so
# that importing one of their submodules does not import the face module).
FACES: dict[str, str] = {"track": "shape", "config": "env", "viz": "recorder", "cli": "command"}

# Text files rewritten (tracked by git); CHANGELOG.md keeps the names it recorded.
TEXT_SUFFIXES = {".py", ".md", ".toml", ".sh", ".cfg", ".txt", ".ipynb", ".rst", ".yml",
                 ".yaml"}
NOT_REWRITTEN = {"CHANGELOG.md", "tools/restructure.py"}


def new_path(new: str) -> str:
    """The file of a new module name (relative to h2h_racing) in the repository."""
    parts = new.split(".")
    if parts[0] in ("training", "league", "policies"):
        return "/".join(parts) + ".py"
    return "h2h_racing/" + "/".join(parts) + ".py"


def sh(*args: str) -> str:
    return subprocess.run(args, check=True, capture_output=True, text=True).stdout


# ---------------------------------------------------------------- rewriting references


def _module_names(moves: dict[str, str]) -> str:
    return "|".join(sorted(moves, key=len, reverse=True))


def rewrite_from_imports(text: str, moves: dict[str, str]) -> str:
    """``from h2h_racing import a, b as c`` with a or b an old module: one line per new package."""
    pattern = re.compile(
        r"^(?P<indent>[ \t]*)from h2h_racing import (?P<names>\([^)]*\)|[^\n#]+?)"
        r"(?P<comment>[ \t]*#[^\n]*)?$", re.M)

    def repl(m: re.Match[str]) -> str:
        raw = m.group("names").strip().strip("()")
        names = [n.strip() for n in raw.replace("\n", " ").split(",") if n.strip()]
        keep: list[str] = []
        moved: dict[str, list[str]] = {}
        for item in names:
            name, _, alias = item.partition(" as ")
            name, alias = name.strip(), alias.strip()
            if name in moves:
                package, _, module = moves[name].rpartition(".")
                local = alias or name
                moved.setdefault(package, []).append(module if local == module
                                                     else f"{module} as {local}")
            else:
                keep.append(item)
        if not moved:
            return m.group(0)
        indent, comment = m.group("indent"), m.group("comment") or ""
        lines = [f"{indent}from h2h_racing import {', '.join(keep)}"] if keep else []
        lines += [f"{indent}from h2h_racing.{package} import {', '.join(items)}"
                  for package, items in moved.items()]
        lines[0] += comment
        return "\n".join(lines)

    return pattern.sub(repl, text)


def rewrite_dotted(text: str, moves: dict[str, str]) -> str:
    """``h2h_racing.track_io`` (imports, strings, prose) and ``h2h_racing/track_io.py``."""
    names = _module_names(moves)

    def dotted(m: re.Match[str]) -> str:
        old, after = m.group(1), text[m.end():m.end() + 40]
        # h2h_racing.env(...) is the PettingZoo AEC factory, and the README's sentence about
        # the package's `h2h_racing.env` attribute speaks of it, not of the module.
        if old == "env" and re.match(r"\s*\(|` attribute", after):
            return m.group(0)
        # Already a package path (track.shape, config.env, ...): rewritten before.
        if old in FACES and re.match(r"\.(\w+)", after) and (
                re.match(r"\.(\w+)", after).group(1)  # type: ignore[union-attr]
                in {v.split(".")[1] for v in moves.values() if v.startswith(old + ".")}):
            return m.group(0)
        return "h2h_racing." + moves[old]

    text = re.sub(rf"(?<![\w.])h2h_racing\.({names})(?![\w])", dotted, text)
    text = re.sub(rf"(?<![\w])h2h_racing/({names})\.py\b",
                  lambda m: new_path(moves[m.group(1)]), text)
    return text


KEEP = re.compile(r"(<!-- restructure: keep -->.*?<!-- /restructure -->)", re.S)
"""Text between these markers names the old modules on purpose (the docs that tell of the move)."""


def rewrite_text(text: str, moves: dict[str, str]) -> str:
    pieces = KEEP.split(text)
    # Dotted names first: the from-imports it then writes name the new packages already.
    return "".join(piece if KEEP.fullmatch(piece) else
                   rewrite_from_imports(rewrite_dotted(piece, moves), moves) for piece in pieces)


# ---------------------------------------------------------------- generated files


def public_names(source: str) -> list[str]:
    """The names ``from module import *`` would give: __all__, else the public top level."""
    tree = ast.parse(source)
    names: list[str] = []
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(
                isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets):
            return [ast.literal_eval(e) for e in node.value.elts]  # type: ignore[attr-defined]
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.append(node.name)
        elif isinstance(node, ast.Assign):
            names += [t.id for t in node.targets if isinstance(t, ast.Name)]
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.append(node.target.id)
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith(
                "h2h_racing"):
            names += [a.asname or a.name for a in node.names]
    return sorted({n for n in names if not n.startswith("_")})


def package_init(package: str, doc: str, face: str | None, exports: list[str]) -> str:
    text = f'"""{doc}\n"""\n'
    if face is None:
        return text
    listed = "".join(f'    "{n}",\n' for n in exports)
    return (
        f'"""{doc}\n\nThe names of the old ``h2h_racing.{package}`` module are here too '
        f"(from ``{face}``, imported\nwhen first used).\n" + '"""\n\n'
        "from __future__ import annotations\n\n"
        "from h2h_racing.common.faces import lazy_face\n\n"
        f"__all__ = [\n{listed}]\n\n"
        f'__getattr__, __dir__ = lazy_face(__name__, "h2h_racing.{package}.{face}", __all__, '
        "globals())\n")


def shim(old: str, new: str) -> str:
    target = f"h2h_racing.{new}"
    return (
        f'"""Deprecated: ``h2h_racing.{old}`` is now ``{target}``;\nthe old path goes in the '
        f'next release."""\n\n'
        "import importlib\nimport sys\nimport warnings\n\n"
        f'warnings.warn("h2h_racing.{old} is now {target}; "\n'
        f'              "the old path goes in the next release: import {target}",\n'
        "              DeprecationWarning, stacklevel=2)\n"
        "# The old name gives the new module itself: monkeypatches, private names and pickles\n"
        "# keep working.\n"
        f'sys.modules[__name__] = importlib.import_module("{target}")\n')


ENV_SHIM = '''"""Deprecated: ``h2h_racing.env`` the module is now ``h2h_racing.envs.parallel``;
the old path goes in the next release. ``h2h_racing.env(...)``, the PettingZoo AEC factory, stays.

Importing this module sets the package's ``env`` attribute to it (the import system does), so
the module is callable too: ``h2h_racing.env(...)`` keeps making the AEC env either way.
"""

import sys
import types
import warnings
from typing import Any

from h2h_racing.envs import parallel as _parallel

warnings.warn("h2h_racing.env (the module) is now h2h_racing.envs.parallel; the old path goes "
              "in the next release: import h2h_racing.envs.parallel (h2h_racing.env(...) "
              "stays)", DeprecationWarning, stacklevel=2)


class _EnvModule(types.ModuleType):
    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return _parallel.env(*args, **kwargs)

    def __getattr__(self, name: str) -> Any:
        return getattr(_parallel, name)


sys.modules[__name__].__class__ = _EnvModule
'''

CLI_MAIN = '''"""``python -m h2h_racing.cli``: the h2h-racing command."""

import sys

from h2h_racing.cli.command import main

sys.exit(main())
'''

# Targeted edits after the rewrite: (file, old text, new text, why). Each is applied if its
# old text is there, and reported if not (edit by hand then); a file not there is skipped.
EDITS: list[tuple[str, str, str, str]] = [
    ("h2h_racing/track/projection.py",
     "from typing import TYPE_CHECKING\n",
     "from typing import Any, Protocol\n",
     "circle track.shape <-> track.projection"),
    ("h2h_racing/track/projection.py",
     "if TYPE_CHECKING:\n    from h2h_racing.track.shape import Track\n",
     "\nclass _TrackShape(Protocol):\n"
     '    """What :meth:`Projector.build` reads of a ``Track``: a protocol, so that this '
     "module does not\n    import ``track.shape`` (which imports this one).\"\"\"\n\n"
     "    _geo: dict[str, Any]\n    centre: npt.NDArray[np.float64]\n"
     "    bounds: tuple[float, float, float, float]\n",
     "circle track.shape <-> track.projection"),
    ("h2h_racing/track/projection.py",
     "def build(track: Track) -> Projector:",
     "def build(track: _TrackShape) -> Projector:",
     "circle track.shape <-> track.projection"),
    ("h2h_racing/track/io.py",
     "import h2h_racing\n",
     "",
     "track/ imports nothing above it (the root package only gave its folder)"),
    ("h2h_racing/track/io.py",
     "pkg = Path(h2h_racing.__file__).resolve().parent",
     "pkg = Path(__file__).resolve().parents[1]  # h2h_racing/",
     "track/ imports nothing above it (the root package only gave its folder)"),
    # multitrack branch: the core imports its views, and the views named the core's class
    ("h2h_racing/sim/view.py",
     "    from h2h_racing.sim.core import RaceCore\n",
     "",
     "circle sim.core -> sim.tracks -> sim.view -> sim.core (multitrack branch only)"),
    ("h2h_racing/sim/view.py",
     "def __init__(self, core: RaceCore, ",
     "def __init__(self, core: Any,  # a RaceCore: not imported, it imports this module\n"
     "                 ",
     "circle sim.core -> sim.tracks -> sim.view -> sim.core (multitrack branch only)"),
    ("h2h_racing/cli/command.py",
     'if __name__ == "__main__":',
     'if __name__ == "__main__":  # python -m h2h_racing.cli.command (or h2h_racing.cli)',
     "python -m h2h_racing.cli"),
]


# ---------------------------------------------------------------- main


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dry-run", action="store_true",
                        help="print the moves and the files to edit; change nothing "
                             "(default: off)")
    parser.add_argument("--leave-unknown", action="store_true",
                        help="leave modules the table does not know in h2h_racing/ instead of "
                             "refusing (default: off)")
    args = parser.parse_args(argv)
    root = Path.cwd()
    if not ((root / "h2h_racing" / "__init__.py").is_file()
            and (root / "pyproject.toml").is_file()):
        print("run from the repository root (h2h_racing/__init__.py and pyproject.toml)",
              file=sys.stderr)
        return 2
    done = [p for p in PACKAGES if (root / "h2h_racing" / p / "__init__.py").exists()]
    if done:
        print(f"already restructured: h2h_racing/{done[0]}/ exists; nothing to do "
              "(run it on a branch made before the move)", file=sys.stderr)
        return 1
    flat = sorted(p.stem for p in (root / "h2h_racing").glob("*.py"))
    unknown = [m for m in flat if m not in MOVES and m not in STAY]
    if unknown:
        print("modules the table does not know (add each to MOVES or STAY in "
              f"tools/restructure.py): {', '.join(unknown)}", file=sys.stderr)
        if not args.leave_unknown:
            print("nothing changed; --leave-unknown leaves them in h2h_racing/", file=sys.stderr)
            return 2
    moves = {old: new for old, new in MOVES.items() if old in flat}
    absent = sorted(set(MOVES) - set(moves))
    for old, new in moves.items():
        target = root / new_path(new)
        if target.exists():
            print(f"{new_path(new)} exists already: cannot move h2h_racing/{old}.py there",
                  file=sys.stderr)
            return 2
    files = [f for f in sh("git", "ls-files").splitlines()
             if Path(f).suffix in TEXT_SUFFIXES and f not in NOT_REWRITTEN and (root / f).is_file()]
    if args.dry_run:
        for old, new in moves.items():
            print(f"h2h_racing/{old}.py -> {new_path(new)}")
        print(f"not present (skipped): {', '.join(absent) or 'none'}")
        print(f"{len(files)} text files to rewrite")
        return 0

    for package in PACKAGES:
        (root / "h2h_racing" / package).mkdir(exist_ok=True)
    for old, new in moves.items():
        sh("git", "mv", f"h2h_racing/{old}.py", new_path(new))
    changed = []
    for f in files:
        f_new = f
        for old, new in moves.items():  # a moved file is read at its new place
            if f == f"h2h_racing/{old}.py":
                f_new = new_path(new)
        path = root / f_new
        text = path.read_text()
        out = rewrite_text(text, moves)
        if out != text:
            path.write_text(out)
            changed.append(f_new)
    for package, doc in PACKAGES.items():
        face = FACES.get(package)
        exports: list[str] = []
        if face is not None:
            face_file = root / "h2h_racing" / package / f"{face}.py"
            exports = public_names(face_file.read_text())
            submodules = {v.split(".")[1] for v in moves.values() if v.startswith(package + ".")}
            clash = sorted(set(exports) & submodules)
            if clash:
                print(f"h2h_racing.{package}.{face} exports {clash}, which are also submodule "
                      f"names of h2h_racing.{package}: rename one", file=sys.stderr)
                return 2
        (root / "h2h_racing" / package / "__init__.py").write_text(
            package_init(package, doc, face, exports))
    (root / "h2h_racing" / "cli" / "__main__.py").write_text(CLI_MAIN)
    shims = []
    for old, new in moves.items():
        if old in FACES:
            continue
        (root / "h2h_racing" / f"{old}.py").write_text(ENV_SHIM if old == "env" else shim(old, new))
        shims.append(f"h2h_racing/{old}.py")
    for file, before, after, why in EDITS:
        path = root / file
        if not path.is_file():  # a module of a branch not merged here
            continue
        text = path.read_text()
        if before in text:
            path.write_text(text.replace(before, after, 1))
        else:
            print(f"edit not applied ({why}): {file} has no {before.strip()[:60]!r}; "
                  "edit it by hand", file=sys.stderr)
    pyproject = root / "pyproject.toml"
    text = pyproject.read_text()
    listed = '"h2h_racing", '
    packages = "".join(f'"h2h_racing.{p}", ' for p in PACKAGES)
    if listed in text and '"h2h_racing.sim"' not in text:
        pyproject.write_text(text.replace(listed, listed + packages, 1))
    else:
        print("pyproject.toml: add the new packages to [tool.setuptools] packages by hand",
              file=sys.stderr)
    sh("git", "add", "--", *[f"h2h_racing/{p}" for p in PACKAGES], *shims)
    print(f"moved {len(moves)} modules into {', '.join(PACKAGES)} (and training/); "
          f"rewrote {len(changed)} files; wrote {len(shims)} shims")
    if absent:
        print(f"not present (skipped): {', '.join(absent)}")
    if unknown:
        print(f"left in h2h_racing/ (unknown): {', '.join(unknown)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
