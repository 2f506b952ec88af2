"""Where league work runs: this process, local worker processes, or a Ray cluster.

A backend has one method, ``map(fn, jobs, stop=None)``, that yields ``(job, fn(job))`` pairs as
jobs finish (in any order). ``fn`` must be a module-level function and jobs picklable. The
caller stores each result as it arrives, so whatever finished before a crash is kept. When
``stop()`` turns true (a Ctrl-C, a spent time budget), ``map`` raises ``JobsStopped`` within
``POLL`` seconds instead of waiting for the jobs still running; ``close(now=True)`` then ends
them (their results are lost, and run again when the command is resumed).

Worker processes ignore Ctrl-C (``league.stopping``): the command that started them decides
what stops and when, and a worker interrupted inside pymunk's cffi callbacks printed
"Exception ignored from cffi callback".

A worker that dies (killed, out of memory) loses no job: its jobs are run again, up to
``max_retries`` times, and because every result is stored under its match key, a job that
ran twice is still counted once.
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures.process import BrokenProcessPool
from typing import Any, TypeVar

from h2h_racing.league.stopping import ignore_sigint, sigint_ignored
from h2h_racing.common.lifeline import die_with_parent, started_from_main_thread

J = TypeVar("J")
R = TypeVar("R")

BACKENDS = ("inprocess", "local", "ray")
POLL = 0.2
"""How often a waiting ``map`` checks its ``stop`` [s]."""


class JobsStopped(Exception):
    """``map``'s ``stop()`` turned true before every job had finished."""


def _worker_init(parent_pid: int, death_signal: bool) -> None:
    """Initializer of a local worker: ignore Ctrl-C, die with the parent."""
    ignore_sigint()
    die_with_parent(parent_pid, death_signal)


class InProcessBackend:
    """Run jobs one after another in this process (tests, debugging, one-core machines)."""

    def map(self, fn: Callable[[J], R], jobs: Sequence[J],
            stop: Callable[[], bool] | None = None) -> Iterator[tuple[J, R]]:
        """Yield ``(job, fn(job))`` in order; ``stop`` is checked before each job (a running
        job finishes first)."""
        for job in jobs:
            if stop is not None and stop():
                raise JobsStopped
            yield job, fn(job)

    def close(self, now: bool = False) -> None:
        """Nothing to release."""


class LocalBackend:
    """Run jobs in ``workers`` local processes.

    Workers are started with ``spawn`` (a fresh interpreter: no inherited torch/OpenMP
    threads, which ``fork`` can deadlock on). They die with this process, even a ``kill -9``'d
    one (``h2h_racing.common.lifeline``), and with them multiprocessing's resource tracker, which
    exits once every process holding its pipe is gone.

    Args:
        workers: Worker processes; None uses every core.
        max_retries: Times a job is started again after its worker died.
    """

    def __init__(self, workers: int | None = None, max_retries: int = 2) -> None:
        if workers is not None and workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        self.workers = workers or os.cpu_count() or 1
        self.max_retries = max_retries
        self._pool: cf.ProcessPoolExecutor | None = None

    def map(self, fn: Callable[[J], R], jobs: Sequence[J],
            stop: Callable[[], bool] | None = None) -> Iterator[tuple[J, R]]:
        """Yield ``(job, fn(job))`` as jobs finish; raise ``JobsStopped`` when ``stop()``
        turns true (checked every ``POLL`` seconds), leaving the running jobs to ``close``.

        The worker processes stay up between calls (until ``close``), so state a job function
        caches in its process (a league learner's runner) is found again by later jobs.
        """
        pending = list(range(len(jobs)))
        attempts = [0] * len(jobs)
        while pending:
            if self._pool is None:
                # Workers are spawned by the thread that submits; the death signal is tied
                # to that thread, so it is only armed when that is the main thread.
                self._pool = cf.ProcessPoolExecutor(
                    self.workers, mp_context=multiprocessing.get_context("spawn"),
                    initializer=_worker_init,
                    initargs=(os.getpid(), started_from_main_thread()))
            # The pool spawns its workers on submit: they start with SIGINT ignored.
            with sigint_ignored():
                futures = {self._pool.submit(fn, jobs[i]): i for i in pending}
            broken = False
            waiting = set(futures)
            while waiting:
                if stop is not None and stop():
                    for future in waiting:
                        future.cancel()
                    raise JobsStopped
                finished, waiting = cf.wait(waiting, timeout=POLL,
                                            return_when=cf.FIRST_COMPLETED)
                for future in sorted(finished, key=futures.__getitem__):
                    index = futures[future]
                    try:
                        result = future.result()
                    except BrokenProcessPool:
                        broken = True
                        continue
                    pending.remove(index)
                    yield jobs[index], result
            if broken:
                self._pool.shutdown(wait=False, cancel_futures=True)
                self._pool = None
                for index in pending:
                    attempts[index] += 1
                    if attempts[index] > self.max_retries:
                        raise RuntimeError(
                            f"job {index} lost its worker {attempts[index]} times; giving up "
                            f"(max_retries={self.max_retries}): {jobs[index]!r}")

    def close(self, now: bool = False) -> None:
        """Stop the worker processes: after their running jobs, or with ``now`` at once
        (SIGTERM; a stopped command does not wait for work it will not store)."""
        if self._pool is None:
            return
        if now:
            # The executor has no public way to end running jobs; its processes are these.
            for process in list(getattr(self._pool, "_processes", {}).values()):
                if process.is_alive():
                    process.terminate()
        self._pool.shutdown(wait=True, cancel_futures=True)
        self._pool = None


LOOPBACK = "127.0.0.1"
"""Where a local Ray started by a backend listens."""
RAY_CLUSTER_ENV = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"
"""Ray's switch between a single-machine Ray on the loopback address (its default on macOS and
Windows) and a cluster-ready one on the machine's network address (its default on Linux)."""


def local_ray_options(num_cpus: int | None) -> dict[str, Any]:
    """``ray.init`` arguments of a local Ray that listens on 127.0.0.1 only.

    Ray's servers (GCS, raylet, object manager, workers) listen on the node's IP address, and
    on Linux ``ray.init`` replaces a loopback ``_node_ip_address`` with the machine's network
    address unless Ray runs in its single-machine mode. This switches that mode on: in the
    environment, which every Ray process inherits, and in Ray's constant of this process, which
    was read when ``ray`` was imported.
    """
    import ray._private.ray_constants as ray_constants

    os.environ[RAY_CLUSTER_ENV] = "0"
    ray_constants.ENABLE_RAY_CLUSTER = False
    return {"num_cpus": num_cpus, "_node_ip_address": LOOPBACK, "include_dashboard": False,
            "dashboard_host": LOOPBACK}


class RayBackend:
    """Run jobs as Ray tasks (one CPU-fraction each) on a local Ray or a cluster.

    Args:
        address: ``ray.init`` address (``"auto"`` or ``"ray://host:port"``); None starts a
            local Ray that listens on 127.0.0.1 only (``local_ray_options``: whoever reaches
            a Ray can run code in it), unless ``RAY_ADDRESS`` names a cluster. A cluster
            listens where its ``ray start`` put it: the user's choice.
        num_cpus: CPUs of a local Ray (None: all).
        cpus_per_task: Logical CPUs a job reserves. Fractional so that a long-lived actor
            elsewhere cannot starve the tasks (Ray reserves an actor's CPUs for its life).
        timeout: Seconds to wait for the next job to finish before giving up.
        max_retries: Times Ray restarts a task whose worker died.
    """

    def __init__(self, address: str | None = None, num_cpus: int | None = None,
                 cpus_per_task: float = 0.5, timeout: float = 1800.0,
                 max_retries: int = 3) -> None:
        try:
            import ray
        except ImportError:
            raise ImportError("the ray backend needs Ray: pip install 'h2h-racing[ray]'") \
                from None
        os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
        self._ray = ray
        self._started = False
        if not ray.is_initialized():
            kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False}
            if address is None and not os.environ.get("RAY_ADDRESS"):
                kwargs.update(local_ray_options(num_cpus))
            ray.init(address=address, **kwargs)
            self._started = True
        self.cpus_per_task = cpus_per_task
        self.timeout = timeout
        self.max_retries = max_retries

    def map(self, fn: Callable[[J], R], jobs: Sequence[J],
            stop: Callable[[], bool] | None = None) -> Iterator[tuple[J, R]]:
        """Yield ``(job, fn(job))`` as Ray tasks finish; on ``stop()`` cancel the rest and
        raise ``JobsStopped``."""
        import time

        ray = self._ray
        task = ray.remote(num_cpus=self.cpus_per_task, max_retries=self.max_retries)(fn)
        refs = {task.remote(job): job for job in jobs}
        last = time.monotonic()
        while refs:
            if stop is not None and stop():
                for ref in refs:
                    ray.cancel(ref, force=True)
                raise JobsStopped
            ready, _ = ray.wait(list(refs), num_returns=1, timeout=POLL)
            if not ready:
                if time.monotonic() - last > self.timeout:
                    raise TimeoutError(f"no Ray task finished within {self.timeout} s; "
                                       f"{len(refs)} jobs still pending")
                continue
            last = time.monotonic()
            ref = ready[0]
            yield refs.pop(ref), ray.get(ref, timeout=self.timeout)

    def close(self, now: bool = False) -> None:
        """Shut down the local Ray this backend started."""
        if self._started:
            self._ray.shutdown()
            self._started = False


def make_backend(name: str, workers: int | None = None, address: str | None = None) -> Any:
    """Build a backend by name (``inprocess``, ``local``, ``ray``)."""
    if name == "inprocess":
        return InProcessBackend()
    if name == "local":
        return LocalBackend(workers)
    if name == "ray":
        return RayBackend(address=address, num_cpus=workers)
    raise ValueError(f"backend must be one of {BACKENDS}, got {name!r}")
