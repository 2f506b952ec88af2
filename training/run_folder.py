"""A training run's output folder: what a run writes there, and whether a new run may.

``train`` writes rsl-rl's checkpoints (``model_<i>.pt``, ``i`` the index of the iteration they
hold, counted from 0) and tensorboard event files, ``curves.csv`` and ``curves.png``,
``policy.pt`` (and ``policy.onnx``), ``eval/`` recordings, ``simtrace/`` logs and rsl-rl's
``git/`` diffs into one folder. A second run into the same folder would mix its checkpoints and
curves with the first's, so ``check_out`` refuses a folder that holds anything unless the run
continues the old one (``resume``: from its latest checkpoint) or replaces it (``overwrite``:
the old run's files are deleted first; files a run never writes are left alone).
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

RUN_FILES = ("model_*.pt", "events.out.tfevents.*", "policy.pt", "policy.onnx",
             "policy.export.json", "curves.csv", "curves.png", "eval", "simtrace", "git")
"""Glob patterns of what a training run writes into its folder (``overwrite`` deletes them)."""

_CHECKPOINT = re.compile(r"model_(\d+)\.pt")


class RunFolderError(ValueError):
    """The output folder does not suit the run asked for (the message says what to do)."""


def checkpoints(out: str | Path) -> list[tuple[int, Path]]:
    """rsl-rl checkpoints in ``out``, ``(iteration index, path)``, oldest first."""
    found = []
    for path in Path(out).glob("model_*.pt"):
        match = _CHECKPOINT.fullmatch(path.name)
        if match and path.is_file():
            found.append((int(match.group(1)), path))
    return sorted(found)


def latest_checkpoint(out: str | Path) -> Path | None:
    """The checkpoint of the latest iteration in ``out``, or None."""
    found = checkpoints(out)
    return found[-1][1] if found else None


def run_files(out: str | Path) -> list[Path]:
    """What earlier runs wrote into ``out`` (``RUN_FILES``), sorted."""
    out = Path(out)
    return sorted({path for pattern in RUN_FILES for path in out.glob(pattern)})


def check_out(out: str | Path, resume: bool = False, overwrite: bool = False) -> Path | None:
    """Check the output folder ``out`` before any work; return the checkpoint to resume from.

    A missing or empty folder starts a new run. A folder that holds anything is refused unless
    ``resume`` (continue from its latest checkpoint, returned) or ``overwrite`` (delete the old
    run's files, ``RUN_FILES``, and start again).

    Raises:
        RunFolderError: ``out`` holds files and neither flag is given, both are given,
            ``resume`` finds no checkpoint, or ``out`` is a file.
    """
    out = Path(out)
    if resume and overwrite:
        raise RunFolderError("give --resume (continue the run in the folder) or --overwrite "
                             "(delete it and start again), not both")
    if out.exists() and not out.is_dir():
        raise RunFolderError(f"--out {out} is a file, not a folder; name a folder for the run")
    if resume:
        latest = latest_checkpoint(out) if out.is_dir() else None
        if latest is None:
            raise RunFolderError(f"--resume: {out} holds no checkpoint (model_<i>.pt) to resume "
                                 f"from; leave out --resume to start a new run there")
        return latest
    entries = sorted(p.name for p in out.iterdir()) if out.is_dir() else []
    if not entries:
        return None
    if overwrite:
        clear_run(out)
        return None
    shown = ", ".join(entries[:4]) + (f" and {len(entries) - 4} more" if len(entries) > 4 else "")
    latest = latest_checkpoint(out)
    resume_hint = (f"--resume to continue it from {latest.name}, " if latest is not None
                   else "")
    raise RunFolderError(f"--out {out} already exists and holds {shown}: give {resume_hint}"
                         f"--overwrite to delete the old run's checkpoints, logs and curves "
                         f"first, or another --out")


def clear_run(out: str | Path) -> list[Path]:
    """Delete what earlier runs wrote into ``out`` (``run_files``); return what was deleted."""
    deleted = run_files(out)
    for path in deleted:
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        else:
            path.unlink(missing_ok=True)
    return deleted
