"""Ctrl-C on ``train``: a request to stop after the current iteration, not a traceback.

Python turns SIGINT into ``KeyboardInterrupt`` wherever the main thread happens to be: inside
rsl-rl's update, numba's kernels or one of pymunk's cffi contact callbacks (which prints
``Exception ignored from cffi callback`` and swallows it). While training runs, ``StopRequest``
takes SIGINT over instead: the first Ctrl-C only sets a flag, which the loop reads at the end
of every iteration (``train_progress.IterationHook``); the loop then saves a checkpoint and
``policy.pt`` and raises ``TrainingInterrupted``, so that the command prints one line (what
was kept, the command that resumes) and exits with status 130 (128 + SIGINT, the shell's
convention). A second Ctrl-C ends the process at once (``os._exit``), after one line: whatever
the last checkpoint holds is kept.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

EXIT_INTERRUPTED = 128 + signal.SIGINT
"""Exit status of a command stopped by Ctrl-C (130)."""


class TrainingInterrupted(KeyboardInterrupt):
    """``train`` stopped at a Ctrl-C after saving what it had.

    Attributes:
        done: Iterations completed (the run's total, a resumed run's earlier ones included).
        checkpoint: The checkpoint a resumed run starts from, or None (no output folder).
        policy: The ``policy.pt`` written at the stop, or None.
    """

    def __init__(self, done: int, checkpoint: Path | None, policy: Path | None) -> None:
        super().__init__(f"training stopped after iteration {done}")
        self.done = done
        self.checkpoint = checkpoint
        self.policy = policy


class StopRequest:
    """Ctrl-C as a request to stop (see the module docstring).

    Args:
        hard_stop: Returns the line printed on stderr when a second Ctrl-C ends the process at
            once (None: a plain one).
    """

    def __init__(self, hard_stop: Callable[[], str] | None = None) -> None:
        self.hard_stop = hard_stop
        self.requested = False
        """Whether a Ctrl-C (or ``request``) asked training to stop."""
        self.presses = 0

    def request(self) -> None:
        """Ask for a stop after the current iteration (what the first Ctrl-C does)."""
        self.requested = True

    @contextmanager
    def installed(self) -> Iterator[StopRequest]:
        """Take SIGINT over while the block runs (main thread only: elsewhere Python cannot
        set handlers; and not where SIGINT is ignored, as in a job started in the background
        by a shell without job control: the block runs with SIGINT as it was)."""
        if (threading.current_thread() is not threading.main_thread()
                or signal.getsignal(signal.SIGINT) is signal.SIG_IGN):
            yield self
            return
        previous = signal.signal(signal.SIGINT, self._on_sigint)
        try:
            yield self
        finally:
            signal.signal(signal.SIGINT, previous)

    def _on_sigint(self, signum: int, frame: Any) -> None:
        # Runs between two bytecodes of the main thread, possibly inside a cffi callback: it
        # must not raise, and the first press only sets the flag.
        self.presses += 1
        if self.presses == 1:
            self.request()
            return
        line = (self.hard_stop() if self.hard_stop is not None
                else "stopped at once (a second Ctrl-C): the last checkpoint is kept")
        try:
            sys.stderr.write("\n" + line + "\n")
            sys.stderr.flush()
        finally:
            os._exit(EXIT_INTERRUPTED)
