"""Backends run every job once, survive a dead worker, and stop when asked (issue 37)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from h2h_racing.league.backends import (InProcessBackend, JobsStopped, LocalBackend,
                                        make_backend)


def square(x: int) -> int:
    return x * x


def die_once(job: tuple[str, int]) -> int:
    """Kill this worker process the first time it sees the marker job (a crashed worker)."""
    marker, x = job
    if x == 3 and not Path(marker).exists():
        Path(marker).write_text("died")
        os._exit(1)
    return x * x


def interrupt_self(_: object) -> int:
    """A Ctrl-C reaching this worker (a terminal sends it to the whole process group)."""
    import signal
    import time

    os.kill(os.getpid(), signal.SIGINT)
    time.sleep(0.2)  # a KeyboardInterrupt would be raised by now
    return os.getpid()


def test_in_process_backend_maps_in_order():
    assert list(InProcessBackend().map(square, [1, 2, 3])) == [(1, 1), (2, 4), (3, 9)]


def test_local_backend_runs_every_job_once_and_retries_a_dead_worker(tmp_path):
    backend = LocalBackend(workers=2)
    marker = str(tmp_path / "died")
    jobs = [(marker, x) for x in range(6)]
    try:
        results = dict(backend.map(die_once, jobs))
    finally:
        backend.close()
    assert Path(marker).read_text() == "died"  # the worker really died once
    assert results == {job: job[1] ** 2 for job in jobs}


def test_make_backend_rejects_unknown_names():
    with pytest.raises(ValueError, match="backend must be one of"):
        make_backend("cloud")
    with pytest.raises(ValueError, match="workers must be >= 1"):
        LocalBackend(workers=0)


def test_local_workers_ignore_ctrl_c():
    """Before: a worker's Ctrl-C was a KeyboardInterrupt in its job (a traceback, or
    "Exception ignored from cffi callback" inside pymunk), and the job was lost."""
    backend = LocalBackend(workers=1)
    try:
        [(_, pid)] = list(backend.map(interrupt_self, [None]))
    except KeyboardInterrupt:  # sent back by the worker: pytest would end the whole run
        pytest.fail("the worker's Ctrl-C came back as a KeyboardInterrupt from its job")
    finally:
        backend.close()
    assert pid != os.getpid()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_a_stopped_map_leaves_its_running_job_to_close_now():
    """Before: map waited for every job (a Ctrl-C landed in concurrent.futures' wait as a
    traceback) and close waited for the running ones."""
    import time

    backend = LocalBackend(workers=1)
    asked = []
    try:
        [(_, pid)] = list(backend.map(interrupt_self, [None]))
        stop_at = time.monotonic() + 0.5
        with pytest.raises(JobsStopped):
            for _ in backend.map(time.sleep, [600.0], stop=lambda: asked.append(1) or
                                 time.monotonic() > stop_at):
                pass
        assert asked  # checked while the job ran
    finally:
        backend.close(now=True)
    end = time.monotonic() + 30.0
    while _alive(pid) and time.monotonic() < end:
        time.sleep(0.1)
    assert not _alive(pid)  # the worker running the 600 s job was ended
    with pytest.raises(JobsStopped):
        list(InProcessBackend().map(square, [1, 2], stop=lambda: True))
