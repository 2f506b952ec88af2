"""``train``'s console output: one progress line (``h2h_racing.progress``) instead of rsl-rl's
block of about 40 lines per iteration, or rsl-rl's block with the run's totals (``verbose``).

rsl-rl's runners print through ``Logger.log`` once per iteration; ``TrainDisplay`` wraps that
method on the runner's logger (rsl-rl offers no print hook): the tensorboard figures are
written as before, and the block is either swallowed (the loop runs rsl-rl's calls in
``quiet``, which sends its prints nowhere) or printed with the run's iteration count and ETA.
``train`` calls ``learn()`` in chunks (track changes, evaluations, the ``--minutes`` check),
and rsl-rl counts each chunk as its own run (``Learning iteration 0/10``, ``10/20``, an ETA to
the chunk's end); the wrapper passes the run's first iteration and its total instead.
"""

from __future__ import annotations

import contextlib
import io
import statistics
import time
from typing import Any, TextIO

from h2h_racing.progress import Mode, Progress


class TrainDisplay:
    """Shows a training run's progress; install on a runner before its first ``learn()``.

    Args:
        runner: The rsl-rl runner (``OnPolicyRunner`` or ``DistillationRunner``).
        iterations: The run's iteration cap.
        minutes: The run's time budget [min], or None: it ends at ``iterations``.
        mode: ``Progress`` mode of the compact line (``"off"``: nothing).
        verbose: Print rsl-rl's block (with the run's totals) instead of the compact line.
        stream: Where the compact line goes (stderr by default).
    """

    def __init__(self, runner: Any, iterations: int, minutes: float | None,
                 mode: Mode = "auto", verbose: bool = False,
                 stream: TextIO | None = None) -> None:
        self.iterations = iterations
        self.minutes = minutes
        self.verbose = verbose
        self.first = runner.current_learning_iteration
        self.start = time.monotonic()
        self.progress = Progress("train", mode="off" if verbose else mode, stream=stream)
        self.logger = runner.logger
        self._log = runner.logger.log
        runner.logger.log = self._log_iteration

    def planned(self, done: int) -> int:
        """Iterations the run will make: the cap, or with a time budget the iterations that fit
        in it at the pace so far (never more than the cap)."""
        if self.minutes is None or done == 0:
            return self.iterations
        pace = (time.monotonic() - self.start) / done
        return max(done, min(self.iterations, round(60.0 * self.minutes / pace)))

    def _log_iteration(self, it: int, start_it: int, total_it: int, collect_time: float,
                       learn_time: float, *args: Any, **kwargs: Any) -> None:
        laps = _mean_extra(self.logger.ep_extras, "lap_completion")  # log() clears them
        done = it + 1 - self.first
        total = self.first + self.planned(done)
        # Without verbose, stdout is quiet() here: the block goes nowhere.
        self._log(it, self.first, total, collect_time, learn_time, *args, **kwargs)
        samples = self.logger.cfg["num_steps_per_env"] * self.logger.num_envs
        self.show(done, samples / max(collect_time + learn_time, 1e-9),
                  statistics.mean(self.logger.rewbuffer) if self.logger.rewbuffer else None,
                  laps)

    def line_info(self, done: int, samples_per_second: float, reward: float | None,
                  laps: float | None) -> str:
        """The line's text after the bar: iterations, samples/s, mean reward, lap completion."""
        total = self.planned(done)
        count = (f"it {done}/{self.iterations}" if self.minutes is None
                 else f"it {done}/~{total} ({self.minutes:g} min)")
        parts = [count, f"{samples_per_second:,.0f} samples/s"]
        if reward is not None:
            parts.append(f"reward {reward:.1f}")
        if laps is not None:
            parts.append(f"laps {100 * laps:.0f} %")
        return "  ".join(parts)

    def show(self, done: int, samples_per_second: float, reward: float | None,
             laps: float | None) -> None:
        """Draw the line after ``done`` iterations of the run."""
        elapsed = time.monotonic() - self.start
        fraction = done / self.iterations
        eta = elapsed / done * (self.iterations - done) if done else None
        if self.minutes is not None:
            fraction = max(fraction, elapsed / (60.0 * self.minutes))
            left = max(60.0 * self.minutes - elapsed, 0.0)
            eta = left if eta is None else min(eta, left)
        self.progress.update(min(fraction, 1.0),
                             self.line_info(done, samples_per_second, reward, laps), eta=eta)

    def clear(self) -> None:
        """Take the line off the terminal before something else prints there."""
        self.progress.clear()

    def close(self) -> None:
        """End the line."""
        self.progress.close()


def quiet(verbose: bool) -> contextlib.AbstractContextManager[Any]:
    """Around rsl-rl's calls: its prints (model summaries, "Storing git diff", the
    per-iteration block) reach stdout only when ``verbose``."""
    return contextlib.nullcontext() if verbose else contextlib.redirect_stdout(io.StringIO())


def _mean_extra(extras: list[dict[str, Any]], key: str) -> float | None:
    """Mean of ``key`` over the episode statistics rsl-rl gathered this iteration."""
    values = [float(e[key]) for e in extras if key in e]
    return sum(values) / len(values) if values else None
