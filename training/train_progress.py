"""``train``'s per-iteration bookkeeping: the figures of each iteration, the time budget, the
console line, and when to stop.

rsl-rl's runners print through ``Logger.log`` once per iteration and hand every step's
rewards to ``Logger.process_env_step``; rsl-rl offers no hook, so ``IterationHook`` wraps both
methods on the runner's logger. After rsl-rl has logged an iteration (tensorboard as before),
the hook builds its ``Iteration`` figures and hands them to its listeners (the console line,
``TrainDisplay``; the curves, ``training.curves``), then asks whether to stop: a Ctrl-C
(``training.interrupt.StopRequest``) or the time budget (``Budget``). A stop inside one of
``train``'s ``learn()`` calls raises ``StopTraining`` there, after a whole iteration.

``TrainDisplay`` shows one progress line (``h2h_racing.common.progress``) instead of rsl-rl's block
of about 40 lines per iteration, or rsl-rl's block with the run's totals (``verbose``): the
loop runs rsl-rl's calls in ``quiet``, which sends its prints nowhere. ``train`` calls
``learn()`` in chunks (track changes, evaluations), and rsl-rl counts each chunk as its own
run; the hook passes the run's first iteration and its total instead.
"""

from __future__ import annotations

import contextlib
import io
import math
import statistics
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TextIO

from h2h_racing.common.progress import NO_ETA, Mode, Progress, clock


def _now() -> float:
    """The budget's clock [s] (tests replace it to run a budget without waiting)."""
    return time.monotonic()


class StopTraining(Exception):
    """Raised by ``IterationHook`` after a whole iteration to end rsl-rl's ``learn()``."""


class Budget:
    """A run's wall-clock budget and pace.

    Args:
        minutes: The budget [min], or None: no budget.
        spent: Seconds the run already ran (a resumed run's earlier invocations).
    """

    def __init__(self, minutes: float | None, spent: float = 0.0) -> None:
        self.seconds = None if minutes is None else 60.0 * minutes
        self.spent = float(spent)
        self.origin = _now()
        self._mark = self.origin
        self.pace: float | None = None
        """Wall time of the last iteration [s] (evaluations excluded)."""

    def elapsed(self, now: float | None = None) -> float:
        """The run's wall time so far [s], earlier invocations included."""
        return self.spent + ((_now() if now is None else now) - self.origin)

    def tick(self) -> tuple[float, bool]:
        """At the end of an iteration: ``(elapsed, stop)``, stop when the next iteration, at
        the last one's pace, would end past the budget. So a run stops within one iteration
        of its budget, and before it."""
        now = _now()
        self.pace = now - self._mark
        self._mark = now
        elapsed = self.elapsed(now)
        return elapsed, self.seconds is not None and elapsed + self.pace > self.seconds

    def after_pause(self) -> bool:
        """After work between iterations (an evaluation): whether the budget leaves no room for
        another iteration; the pause does not count in the pace."""
        now = _now()
        self._mark = now
        return (self.seconds is not None
                and self.elapsed(now) + (self.pace or 0.0) > self.seconds)

    def spent_all(self) -> bool:
        """Whether the earlier invocations already used the whole budget."""
        return self.seconds is not None and self.spent >= self.seconds


@dataclass(frozen=True)
class Iteration:
    """The figures of one iteration (``training.curves`` explains each)."""

    done: int
    """Iterations completed in the run (1 after the first)."""
    samples: int
    """Samples collected in the run so far."""
    seconds: float
    """The run's wall time so far [s] (``Budget.elapsed``)."""
    samples_per_second: float
    """This iteration's samples over its collection and update time."""
    mean_return: float | None
    """Mean return of the last 100 episodes (None before one ended)."""
    episode_length: float | None
    """Mean length of those episodes [steps]."""
    terms: dict[str, float] = field(default_factory=dict)
    """``reward/<term>`` of the reward in use."""
    lap_completion: float | None = None
    """Share of the episodes ended this iteration with a lap completed."""
    update_seconds: float = 0.0
    """The iteration's collection plus update time [s] (rsl-rl's own)."""

    def row(self) -> dict[str, Any]:
        """The iteration's ``curves.csv`` row."""
        return {"iteration": self.done, "steps": self.samples, "seconds": self.seconds,
                "return": self.mean_return, "episode_length": self.episode_length,
                **self.terms, "lap_completion": self.lap_completion}


class IterationHook:
    """Installs on a runner's logger before its first ``learn()`` (see the module docstring).

    Args:
        runner: The rsl-rl runner, its ``current_learning_iteration`` the iterations done.
        iterations: The run's iteration cap.
        terms: The ``reward/<term>`` columns of the reward in use.
        reward_function: The run trains on a DeepRacer reward file: the built-in reward's
            terms are taken out of the log (tensorboard too), and ``reward/reward_function``,
            the file's mean reward per step over the iteration, goes in.
        budget: The run's time budget.
        listeners: Called with every ``Iteration``.
        stop: Returns True when a stop was asked for (a Ctrl-C).
        verbose: Let rsl-rl's block through, with the run's totals.
    """

    def __init__(self, runner: Any, iterations: int, terms: tuple[str, ...],
                 reward_function: bool, budget: Budget,
                 listeners: list[Callable[[Iteration], None]],
                 stop: Callable[[], bool] = lambda: False, planned: Callable[[int], int] |
                 None = None) -> None:
        self.runner = runner
        self.logger = runner.logger
        self.iterations = iterations
        self.terms = terms
        self.reward_function = reward_function
        self.budget = budget
        self.listeners = listeners
        self.stop = stop
        self.planned = planned or (lambda done: iterations)
        self.first = runner.current_learning_iteration
        self.stopping: str | None = None
        """Why the run stops (``"interrupted"`` or ``"budget"``), once it must."""
        self._reward_sum = 0.0
        self._reward_count = 0
        self._log = runner.logger.log
        self._process_step = runner.logger.process_env_step
        runner.logger.log = self._on_log
        runner.logger.process_env_step = self._on_step

    def _on_step(self, rewards: Any, *args: Any, **kwargs: Any) -> None:
        self._reward_sum += float(rewards.sum())
        self._reward_count += int(rewards.numel())
        self._process_step(rewards, *args, **kwargs)

    def _on_log(self, it: int, start_it: int, total_it: int, collect_time: float,
                learn_time: float, *args: Any, **kwargs: Any) -> None:
        extras = self.logger.ep_extras
        if self.reward_function:
            # The built-in reward's terms are not what was trained on: the file's reward is.
            for entry in extras:
                for key in [k for k in entry if k.startswith("reward/")]:
                    del entry[key]
            if self._reward_count:
                extras.append({"reward/reward_function": self._reward_sum / self._reward_count})
        self._reward_sum, self._reward_count = 0.0, 0
        means = {key: _mean_extra(extras, key) for key in (*self.terms, "lap_completion")}
        done = it + 1
        # Without verbose, stdout is quiet() here: rsl-rl's block goes nowhere.
        self._log(it, self.first, self.planned(done), collect_time, learn_time, *args,
                  **kwargs)
        samples = self.logger.cfg["num_steps_per_env"] * self.logger.num_envs
        elapsed, over_budget = self.budget.tick()
        buffer = self.logger.rewbuffer
        figures = Iteration(
            done=done, samples=done * samples, seconds=elapsed,
            samples_per_second=samples / max(collect_time + learn_time, 1e-9),
            mean_return=statistics.mean(buffer) if buffer else None,
            episode_length=statistics.mean(self.logger.lenbuffer) if buffer else None,
            terms={key: value for key in self.terms
                   if (value := means[key]) is not None},
            lap_completion=means["lap_completion"], update_seconds=collect_time + learn_time)
        for listener in self.listeners:
            listener(figures)
        if self.stop():
            self.stopping = "interrupted"
        elif over_budget and done < self.iterations:
            self.stopping = "budget"
        # The last iteration of a learn() call ends it anyway (and rsl-rl saves its checkpoint).
        if self.stopping is not None and it + 1 < total_it:
            raise StopTraining(self.stopping)


class TrainDisplay:
    """Shows a training run's progress line (see the module docstring).

    Args:
        iterations: The run's iteration cap.
        budget: The run's time budget.
        mode: ``Progress`` mode of the compact line (``"off"``: nothing).
        verbose: rsl-rl's block is printed instead of the compact line.
        stream: Where the compact line goes (stderr by default).
        first: Iterations already done when this invocation started (a resumed run).
    """

    def __init__(self, iterations: int, budget: Budget, mode: Mode = "auto",
                 verbose: bool = False, stream: TextIO | None = None, first: int = 0) -> None:
        self.iterations = iterations
        self.budget = budget
        self.first = first
        self.progress = Progress("train", mode="off" if verbose else mode, stream=stream)
        self._times: deque[float] = deque(maxlen=20)
        self._done = first
        self._info = ""

    @property
    def minutes(self) -> float | None:
        """The budget [min], or None."""
        return None if self.budget.seconds is None else self.budget.seconds / 60.0

    def pace(self) -> float | None:
        """Seconds an iteration takes: the mean of the last ones (up to 20) of this invocation
        but the first, whose time is mostly compiling the kernels; None before the second."""
        return statistics.mean(self._times) if self._times else None

    def planned(self, done: int) -> int:
        """Iterations the run will make: the cap, or with a time budget the iterations that fit
        in it at the pace so far (never more than the cap)."""
        pace = self.pace()
        if self.budget.seconds is None or pace is None:
            return self.iterations
        left = self.budget.seconds - self.budget.elapsed()
        return max(done, min(self.iterations, done + math.floor(max(left, 0.0) / pace)))

    def starting(self, what: str) -> None:
        """Before the first iteration: say what the wait is (compiling, the first rollout)."""
        self.progress.update(self._done / max(self.iterations, 1), what, force=True)

    def __call__(self, figures: Iteration) -> None:
        """Draw the line after an iteration."""
        if figures.done > self.first + 1:
            self._times.append(figures.update_seconds)
        self._done = figures.done
        fraction = figures.done / max(self.iterations, 1)
        pace = self.pace()
        eta = None if pace is None else pace * (self.planned(figures.done) - figures.done)
        if self.budget.seconds is not None:
            fraction = max(fraction, figures.seconds / self.budget.seconds)
            left = max(self.budget.seconds - figures.seconds, 0.0)
            eta = left if eta is None else min(eta, left)
        self._info = self.line_info(figures)
        if pace is None:
            self._info += "  (first iteration: compiling)"
        # 100 % only once training has ended (``finish``): work may remain.
        self.progress.update(min(fraction, 0.98), self._info, eta=eta)

    def line_info(self, figures: Iteration) -> str:
        """The line's text after the bar: iterations, samples/s, return, lap completion."""
        done = figures.done
        count = (f"it {done}/{self.iterations}" if self.minutes is None
                 else f"it {done}/~{self.planned(done)} ({self.minutes:g} min)")
        parts = [count, f"{figures.samples_per_second:,.0f} samples/s"]
        if figures.mean_return is not None:
            parts.append(f"reward {figures.mean_return:.1f}")
        if figures.lap_completion is not None:
            parts.append(f"laps {100 * figures.lap_completion:.0f} %")
        return "  ".join(parts)

    def phase(self, what: str) -> None:
        """Show work between iterations (an evaluation, the saving) on the line, in place of
        its text, with no ETA (the iterations' rate says nothing of it)."""
        self.progress.update(min(self._done / max(self.iterations, 1), 0.98), what,
                             eta=NO_ETA, force=True)

    def clear(self) -> None:
        """Take the line off the terminal before something else prints there."""
        self.progress.clear()

    def finish(self, reason: str, complete: bool = True) -> None:
        """End the line: training is over (``reason`` says why), at 100 % if ``complete`` (the
        cap or the budget reached), else where it stopped."""
        text = f"it {self._done}: {reason} ({clock(self.budget.elapsed())} in all)"
        if complete:
            self.progress.update(1.0, text, force=True)
        elif self.progress.mode != "off":
            # Stopped short: no bar, whose ETA would promise work that will not run.
            self.progress.message(f"train {text}")
        self.progress.close()


def quiet(verbose: bool) -> contextlib.AbstractContextManager[Any]:
    """Around rsl-rl's calls: its prints (model summaries, "Storing git diff", the
    per-iteration block) reach stdout only when ``verbose``."""
    return contextlib.nullcontext() if verbose else contextlib.redirect_stdout(io.StringIO())


def _mean_extra(extras: list[dict[str, Any]], key: str) -> float | None:
    """Mean of ``key`` over the episode statistics rsl-rl gathered this iteration."""
    values = [float(e[key]) for e in extras if key in e]
    return sum(values) / len(values) if values else None
