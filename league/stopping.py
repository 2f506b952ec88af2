"""Ctrl-C on a long league command: a request to stop at the next safe point, not a traceback.

A terminal's Ctrl-C sends SIGINT to the whole foreground process group: the command and its
worker processes. Python turns it into ``KeyboardInterrupt`` wherever each process happens to
be: in ``concurrent.futures``' wait (a traceback), or in a worker inside one of pymunk's cffi
contact callbacks, which prints ``Exception ignored from cffi callback`` and swallows it. So:

- workers ignore SIGINT (``ignore_sigint``, and ``sigint_ignored`` around spawning them, so
  that a fresh interpreter ignores it from its first instruction: an ignored signal stays
  ignored across ``exec``, and Python then leaves it so);
- the command installs a ``StopSwitch``: the first Ctrl-C only sets a flag (and creates a
  file that workers' training loops look for between PPO iterations), which the command's
  loops check at their safe points; a second Ctrl-C ends the process at once, with one line
  and exit status 130 (128 + SIGINT, the shell's convention).

``resume_command`` (``h2h_racing.cli.help.command_line``) writes back the command line that
resumes a stopped command.
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

from h2h_racing.cli.help import command_line as resume_command  # noqa: F401  (re-exported)

EXIT_INTERRUPTED = 128 + signal.SIGINT
"""Exit status of a command stopped by Ctrl-C (130)."""


def ignore_sigint() -> None:
    """Ignore Ctrl-C in this (worker) process: its command decides when work stops."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextmanager
def sigint_ignored() -> Iterator[None]:
    """Ignore SIGINT while processes are started (they inherit it); a Ctrl-C in the few
    milliseconds this takes is lost. Does nothing off the main thread, where Python cannot
    set handlers."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


class StopSwitch:
    """Ctrl-C as a stop request (see the module docstring).

    Args:
        file: Created at the first Ctrl-C (its folder must exist), removed by ``install`` and
            ``uninstall``: training workers stop after their current iteration when it
            exists (``league.learners.train_round``). None: no file.
        hard_stop: Returns the line printed (on stderr) when a second Ctrl-C ends the process
            at once.
    """

    def __init__(self, file: str | Path | None = None,
                 hard_stop: Callable[[], str] | None = None) -> None:
        self.file = None if file is None else Path(file)
        self.hard_stop = hard_stop
        self.requested = False
        """Whether a Ctrl-C (or ``request``) asked the command to stop."""
        self.presses = 0
        self._previous: Any = None

    def install(self) -> StopSwitch:
        """Take over SIGINT (main thread only) and remove a stale stop file."""
        self._remove_file()
        self._previous = signal.signal(signal.SIGINT, self._on_sigint)
        return self

    def uninstall(self) -> None:
        """Give SIGINT back to its previous handler and remove the stop file."""
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)
            self._previous = None
        self._remove_file()

    def request(self) -> None:
        """Ask for a stop (what the first Ctrl-C does)."""
        self.requested = True
        if self.file is not None:
            try:
                self.file.touch()
            except OSError:
                pass  # workers then finish their round; the command still stops after it

    def _on_sigint(self, signum: int, frame: Any) -> None:
        # Runs between two bytecodes of the main thread, possibly inside a cffi callback:
        # it must not raise, and it only sets state (printing is left to the command).
        self.presses += 1
        if self.presses == 1:
            self.request()
            return
        line = self.hard_stop() if self.hard_stop is not None else "stopped at once (Ctrl-C)"
        try:
            sys.stderr.write("\n" + line + "\n")
            sys.stderr.flush()
        finally:
            # Everything committed to the league file is kept (one transaction per write);
            # workers die with this process (h2h_racing.common.lifeline).
            os._exit(EXIT_INTERRUPTED)

    def _remove_file(self) -> None:
        if self.file is not None:
            self.file.unlink(missing_ok=True)


def stop_file_exists(path: str | None) -> bool:
    """Whether a ``StopSwitch`` file asks this worker to stop (False for None)."""
    return path is not None and os.path.exists(path)


