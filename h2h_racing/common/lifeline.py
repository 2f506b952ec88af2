"""Child processes that die with their parent.

A ``kill -9`` gives a process no chance to stop its children, and neither multiprocessing's
workers nor a plain subprocess notice that their parent is gone: they keep running (and
holding memory and ports) for good. Two layers make a child exit within about a second:

- Linux: ``prctl(PR_SET_PDEATHSIG)`` asks the kernel to send the child a signal when its
  parent dies. The kernel ties this to the parent *thread* that started the child, so it is
  only used where that thread is the parent's main thread (which lives as long as the
  process); it survives ``exec``, so it also covers a binary started by ``subprocess``.
- Everywhere: a daemon thread in the child polls ``os.getppid()``; when the parent is gone
  the child is re-parented (to init or a subreaper) and the thread ends the process.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import signal
import sys
import threading
import time
from collections.abc import Callable

PR_SET_PDEATHSIG = 1
"""``prctl`` option from <linux/prctl.h>."""
POLL_SECONDS = 0.5
"""How often the watch thread checks the parent."""


def set_parent_death_signal(sig: int = signal.SIGTERM) -> bool:
    """Ask the kernel to send ``sig`` to this process when its parent (thread) dies.

    Returns:
        True when set (Linux with a usable libc), False elsewhere.
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
    except OSError:
        return False
    return libc.prctl(PR_SET_PDEATHSIG, int(sig), 0, 0, 0) == 0


def _exit_now() -> None:
    # os._exit: the parent is gone, nobody waits for our results, and normal interpreter
    # shutdown would join the pool's threads, which wait on the dead parent's pipes.
    os._exit(1)


def watch_parent(parent_pid: int, poll: float = POLL_SECONDS) -> threading.Thread:
    """Start a daemon thread that ends this process once ``parent_pid`` is no longer its
    parent."""

    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(poll)
        _exit_now()

    thread = threading.Thread(target=watch, name="h2h-parent-watch", daemon=True)
    thread.start()
    return thread


def die_with_parent(parent_pid: int, death_signal: bool = True) -> None:
    """Make this (child) process exit soon after ``parent_pid`` dies.

    Call it first thing in a worker (a pool ``initializer``).

    Args:
        parent_pid: The pid of the process that started this one.
        death_signal: Also use ``PR_SET_PDEATHSIG`` (Linux). Pass False when the parent
            started this process from a thread that may end before the parent does.
    """
    if death_signal:
        set_parent_death_signal(signal.SIGTERM)
    # The parent may have died before the signal was armed: then no signal comes.
    if os.getppid() != parent_pid:
        _exit_now()
    watch_parent(parent_pid)


def death_signal_preexec() -> Callable[[], None] | None:
    """A ``subprocess.Popen(preexec_fn=...)`` for a child (any binary) that must die with this
    process; None off Linux (no death signal there). Call ``Popen`` from the main thread."""
    if not sys.platform.startswith("linux"):
        return None
    parent = os.getpid()

    def arm() -> None:
        set_parent_death_signal(signal.SIGTERM)
        # This process may have died between fork and prctl: then no signal comes.
        if os.getppid() != parent:
            os._exit(1)

    return arm


def started_from_main_thread() -> bool:
    """Whether the calling thread is the main thread (where a death signal is safe)."""
    return threading.current_thread() is threading.main_thread()
