"""Hostile processes, ports and league files (issue 17, "Crash safety" and the local Ray).

A careless or hostile user kills a command with ``kill -9``, starts a race on a port that is
already taken, reuses a tournament name with other settings, or hands the league commands an
empty or corrupt file. Each test here failed on the code before the fix.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

psutil = pytest.importorskip("psutil")

REPO = Path(__file__).resolve().parents[2]
GONE_WITHIN = 5.0  # [s] the bound for children outliving a killed parent


def _python_env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), env.get("PYTHONPATH", "")])
    env["GIT_PYTHON_REFRESH"] = "quiet"
    env["RAY_USAGE_STATS_ENABLED"] = "0"
    return env


def _start(script: str, tmp_path: Path) -> subprocess.Popen:
    path = tmp_path / "parent.py"
    path.write_text(textwrap.dedent(script))
    return subprocess.Popen([sys.executable, str(path)], stdout=subprocess.PIPE, text=True,
                            env=_python_env(), cwd=tmp_path)


def _read_line(proc: subprocess.Popen, timeout: float = 120.0) -> str:
    """The parent's next stdout line (it prints once its children are up)."""
    deadline = time.monotonic() + timeout
    line = ""
    while time.monotonic() < deadline and not line:
        line = proc.stdout.readline()
        if proc.poll() is not None and not line:
            raise AssertionError(f"the parent script exited with {proc.returncode}")
    return line.strip()


def _alive(pids: list[int]) -> list[int]:
    alive = []
    for pid in pids:
        try:
            if psutil.Process(pid).status() != psutil.STATUS_ZOMBIE:
                alive.append(pid)
        except psutil.NoSuchProcess:
            pass
    return alive


def _kill_and_wait_for(parent: subprocess.Popen, children: list[int]) -> list[int]:
    """kill -9 the parent; the children still alive after ``GONE_WITHIN`` seconds."""
    parent.send_signal(signal.SIGKILL)
    parent.wait(timeout=10)
    deadline = time.monotonic() + GONE_WITHIN
    while time.monotonic() < deadline and _alive(children):
        time.sleep(0.1)
    left = _alive(children)
    for pid in left:  # do not leave them to the next test
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    return left


# ------------------------------------------------------------ workers of a killed parent

LOCAL_POOL_PARENT = """
    import os, sys, time
    from h2h_racing.league.backends import LocalBackend

    def worker_pid(job):
        time.sleep(0.5)  # keep both workers busy so that both get a job
        return os.getpid()

    if __name__ == "__main__":
        backend = LocalBackend(workers=2)
        pids = sorted({pid for _, pid in backend.map(worker_pid, range(4))})
        print(" ".join(map(str, pids)), flush=True)
        time.sleep(600)
"""


def test_local_workers_and_resource_tracker_die_with_a_killed_parent(tmp_path):
    parent = _start(LOCAL_POOL_PARENT, tmp_path)
    try:
        workers = [int(pid) for pid in _read_line(parent).split()]
        children = [p.pid for p in psutil.Process(parent.pid).children(recursive=True)]
        assert set(workers) <= set(children)
        # The workers and multiprocessing's resource tracker.
        assert len(children) >= len(workers) + 1, children
        assert _kill_and_wait_for(parent, children) == []
    finally:
        if parent.poll() is None:
            parent.kill()


WATCHED_CHILD_PARENT = """
    import subprocess, sys, time

    child = subprocess.Popen([sys.executable, "-c", (
        "import os, time; from h2h_racing.lifeline import die_with_parent; "
        "die_with_parent(%d, death_signal=False); print('armed', flush=True); time.sleep(600)"
    ) % __import__("os").getpid()], stdout=subprocess.PIPE, text=True)
    child.stdout.readline()
    print(child.pid, flush=True)
    time.sleep(600)
"""


def test_parent_watch_alone_ends_a_child_of_a_killed_parent(tmp_path):
    """The fallback of platforms without PR_SET_PDEATHSIG: the watch thread on its own."""
    parent = _start(WATCHED_CHILD_PARENT, tmp_path)
    try:
        child = int(_read_line(parent))
        assert _alive([child]) == [child]
        assert _kill_and_wait_for(parent, [child]) == []
    finally:
        if parent.poll() is None:
            parent.kill()
