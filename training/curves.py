"""A training run's curves as a CSV file and a PNG plot, beside its tensorboard log.

``curves.csv`` gets one row per PPO (or imitation) iteration, written as the iteration ends
(or with its evaluation, when one is due after it), so that a run that stops or is killed
keeps the row of every iteration its checkpoints hold:

- ``iteration``: iterations completed (1 for the first); ``steps``: samples collected so far
  (env copies x learner cars x steps per iteration, summed); ``seconds``: wall time of the run
  so far, setup and evaluations included (a resumed run goes on from where it stopped);
- ``return``: the mean return of the last 100 episodes (rsl-rl's ``Train/mean_reward``) and
  ``episode_length`` [steps], both of the reward in use;
- ``reward/<term>``: each term of the reward in use, the mean per step over the iteration's
  ended episodes' last steps (as tensorboard's ``reward/<term>``): the built-in reward's terms
  with a non-zero weight, or ``reward/reward_function``, the mean per-step reward of a
  DeepRacer reward file over the iteration;
- ``lap_completion``: the share of the learners' episodes that ended this iteration having
  completed a lap;
- ``eval_*``: the evaluation after that iteration (``train.evaluate_during_training``), empty
  in the other rows.

``plot_curves`` draws ``curves.png`` from the CSV with matplotlib (Agg, no display needed)
when it is installed.
"""

from __future__ import annotations

import csv
import math
import os
from pathlib import Path
from typing import Any

HEAD = ("iteration", "steps", "seconds", "return", "episode_length")
"""The first columns of every ``curves.csv``."""
EVAL = ("eval_lap_completion", "eval_mean_lap_time", "eval_best_lap_time", "eval_off_tracks",
        "eval_collisions", "eval_race_finished", "eval_race_position")
"""The evaluation's columns (``train.evaluate_during_training``'s figures)."""
REWARD_FUNCTION_TERM = "reward/reward_function"
"""The one term column of a run on a DeepRacer reward file."""


def columns(terms: tuple[str, ...]) -> tuple[str, ...]:
    """The CSV's columns for a run whose reward has ``terms`` (``reward/...`` names)."""
    return (*HEAD, *terms, "lap_completion", *EVAL)


class CurveWriter:
    """Writes ``curves.csv`` row by row; a row is written once its iteration's evaluation (if
    one is due) has been added, or when the next row comes.

    Args:
        path: The CSV file.
        terms: The reward term columns (``reward/...``).
        keep: For a resumed run, the iterations already done: the file's rows up to that
            iteration are kept (later ones, written after the checkpoint, are dropped), and new
            rows are appended; None starts a new file.

    Raises:
        ValueError: ``keep`` is given and the file's columns are not this run's.
    """

    def __init__(self, path: str | Path, terms: tuple[str, ...], keep: int | None = None) -> None:
        self.path = Path(path)
        self.columns = columns(terms)
        self._pending: dict[str, Any] | None = None
        rows: list[dict[str, str]] = []
        if keep is not None and self.path.is_file():
            header, rows = read_curves(self.path)
            if tuple(header) != self.columns:
                raise ValueError(f"{self.path}: its columns ({', '.join(header)}) are not this "
                                 f"run's ({', '.join(self.columns)}): it was written by another "
                                 "reward; resume with the run's own settings, or start a new "
                                 "run with --overwrite")
            rows = [row for row in rows if int(row["iteration"]) <= keep]
        self.path.parent.mkdir(parents=True, exist_ok=True)
        # Rewritten whole (through a temporary file): rows past the checkpoint go.
        temporary = self.path.with_suffix(".csv.tmp")
        with temporary.open("w", newline="") as file:
            writer = csv.DictWriter(file, fieldnames=self.columns)
            writer.writeheader()
            writer.writerows(rows)
        os.replace(temporary, self.path)

    def add_iteration(self, row: dict[str, Any]) -> None:
        """Queue the row of an iteration (keys of ``columns``; missing ones stay empty), after
        writing the one before."""
        self.flush()
        self._pending = dict(row)

    def add_evaluation(self, iteration: int, figures: dict[str, float]) -> None:
        """Add the evaluation after ``iteration`` (keys without the ``eval_`` prefix) to its
        row and write it."""
        if self._pending is None or self._pending.get("iteration") != iteration:
            self.flush()
            self._pending = {"iteration": iteration}
        self._pending.update({f"eval_{key}": value for key, value in figures.items()
                              if f"eval_{key}" in self.columns})
        self.flush()

    def flush(self) -> None:
        """Write the queued row, if any."""
        if self._pending is None:
            return
        with self.path.open("a", newline="") as file:
            writer = csv.DictWriter(file, fieldnames=self.columns, extrasaction="ignore")
            writer.writerow({key: _cell(value) for key, value in self._pending.items()})
        self._pending = None


def _cell(value: Any) -> Any:
    """A CSV cell: floats to 6 significant digits, NaN and None empty."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return ""
    if isinstance(value, float):
        return f"{value:.6g}"
    return value


def read_curves(path: str | Path) -> tuple[list[str], list[dict[str, str]]]:
    """``(columns, rows)`` of a ``curves.csv`` (cells as text; empty where no value)."""
    with Path(path).open(newline="") as file:
        reader = csv.DictReader(file)
        rows = list(reader)
        return list(reader.fieldnames or []), rows


def seconds_at(path: str | Path, iteration: int) -> float:
    """The run's ``seconds`` at ``iteration`` in a ``curves.csv``: where a resumed run's clock
    goes on from. Without that row (a run killed before writing it, or written before every
    row went to disk at once) the latest row before it gives the time, short of at most that
    iteration's; 0 without an earlier row or the file."""
    if not Path(path).is_file():
        return 0.0
    _, rows = read_curves(path)
    best = (-1, 0.0)
    for row in rows:
        try:
            at, seconds = int(row.get("iteration") or ""), float(row.get("seconds") or "")
        except ValueError:  # a row cut short by a killed run
            continue
        if best[0] < at <= iteration:
            best = (at, seconds)
    return best[1]


def plot_curves(csv_path: str | Path, png_path: str | Path) -> str:
    """Draw ``curves.png`` from ``curves.csv``: the return, the reward terms and the lap
    completion (training and evaluation) against the samples collected. Returns the line to
    print: where the plot went, or why there is none (matplotlib missing, no rows)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return (f"curves plot skipped: matplotlib is not installed (pip install matplotlib); "
                f"the curves are in {csv_path}")
    header, rows = read_curves(csv_path)
    if not rows:
        return f"curves plot skipped: {csv_path} has no iteration yet"

    def series(column: str) -> tuple[list[float], list[float]]:
        points = [(float(r["steps"]), float(r[column])) for r in rows
                  if r.get(column) not in (None, "") and r.get("steps") not in (None, "")]
        return [p[0] for p in points], [p[1] for p in points]

    terms = [c for c in header if c.startswith("reward/")]
    figure, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    axes[0].plot(*series("return"), color="black")
    axes[0].set_ylabel("return (mean of\nthe last 100 episodes)")
    for term in terms:
        axes[1].plot(*series(term), label=term.removeprefix("reward/"))
    axes[1].set_ylabel("reward per step")
    if terms:
        axes[1].legend(fontsize="small", ncol=2)
    axes[2].plot(*series("lap_completion"), label="training episodes")
    steps, laps = series("eval_lap_completion")
    if steps:
        axes[2].plot(steps, laps, "o-", label="evaluation attempts")
    axes[2].set_ylabel("lap completion")
    axes[2].set_ylim(-0.05, 1.05)
    axes[2].legend(fontsize="small")
    axes[2].set_xlabel("samples (env steps of the learner cars)")
    for axis in axes:
        axis.grid(alpha=0.3)
    figure.suptitle(f"{Path(csv_path).parent.name}: {rows[-1]['iteration']} iterations")
    figure.tight_layout()
    figure.savefig(png_path, dpi=100)
    plt.close(figure)
    return f"curves -> {csv_path}, {png_path}"
