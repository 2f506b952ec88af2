"""Backends run every job once and survive a dead worker."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from h2h_racing.league.backends import InProcessBackend, LocalBackend, make_backend


def square(x: int) -> int:
    return x * x


def die_once(job: tuple[str, int]) -> int:
    """Kill this worker process the first time it sees the marker job (a crashed worker)."""
    marker, x = job
    if x == 3 and not Path(marker).exists():
        Path(marker).write_text("died")
        os._exit(1)
    return x * x


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
