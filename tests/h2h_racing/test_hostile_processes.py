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


# ------------------------------------------------------------ a local Ray on 127.0.0.1 only

class _FakeRay:
    """Records ``ray.init``'s arguments (a real Ray takes ~10 s to start)."""

    def __init__(self) -> None:
        self.calls: list[dict] = []

    def is_initialized(self) -> bool:
        return False

    def init(self, **kwargs) -> None:
        self.calls.append(kwargs)


@pytest.fixture
def fake_ray(monkeypatch):
    ray = pytest.importorskip("ray")
    import ray._private.ray_constants as ray_constants

    fake = _FakeRay()
    monkeypatch.setattr(ray, "is_initialized", fake.is_initialized)
    monkeypatch.setattr(ray, "init", fake.init)
    # What the backend switches, put back after the test.
    monkeypatch.setattr(ray_constants, "ENABLE_RAY_CLUSTER", ray_constants.ENABLE_RAY_CLUSTER)
    monkeypatch.delenv("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", raising=False)
    monkeypatch.delenv("RAY_ADDRESS", raising=False)
    return fake


def test_a_local_ray_is_started_on_the_loopback_address_only(fake_ray):
    import ray._private.ray_constants as ray_constants

    from h2h_racing.league.backends import RayBackend

    RayBackend(num_cpus=2)
    (kwargs,) = fake_ray.calls
    assert kwargs["address"] is None
    assert kwargs["_node_ip_address"] == "127.0.0.1"
    assert kwargs["include_dashboard"] is False
    assert kwargs["dashboard_host"] == "127.0.0.1"
    assert kwargs["num_cpus"] == 2
    # Without the single-machine mode, ray.init swaps 127.0.0.1 for the network address.
    assert os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] == "0"
    assert ray_constants.ENABLE_RAY_CLUSTER is False


def test_a_cluster_address_stays_the_users_choice(fake_ray, monkeypatch):
    """An address given, or one in ``RAY_ADDRESS`` (which ``ray.init`` reads): no local Ray
    options, and Ray's mode switch untouched."""
    import ray._private.ray_constants as ray_constants

    from h2h_racing.league.backends import RayBackend

    before = ray_constants.ENABLE_RAY_CLUSTER
    for address, env in (("ray://head:10001", None), ("auto", None), (None, "ray://head:1")):
        if env is not None:
            monkeypatch.setenv("RAY_ADDRESS", env)
        fake_ray.calls.clear()
        RayBackend(address=address)
        (kwargs,) = fake_ray.calls
        assert kwargs["address"] == address
        assert "_node_ip_address" not in kwargs and "num_cpus" not in kwargs, (address, env)
        assert "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER" not in os.environ
        assert ray_constants.ENABLE_RAY_CLUSTER is before


RAY_PARENT = """
    import json, os
    import psutil
    from h2h_racing.league.backends import RayBackend

    def pid(job):
        return os.getpid()

    if __name__ == "__main__":
        backend = RayBackend(num_cpus=1)
        workers = sorted({p for _, p in backend.map(pid, range(2))})
        me = psutil.Process()
        ours = {me.pid} | {p.pid for p in me.children(recursive=True)}
        listening = sorted({(c.laddr.ip, c.laddr.port, psutil.Process(c.pid).name())
                            for c in psutil.net_connections("inet")
                            if c.status == psutil.CONN_LISTEN and c.pid in ours})
        print(json.dumps({"workers": workers, "listening": listening}), flush=True)
        backend.close()
"""


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
def test_a_local_ray_listens_on_127_0_0_1_only(tmp_path):
    """Every listening socket of a real local Ray (GCS, raylet, workers, the driver)."""
    import json

    pytest.importorskip("ray")
    parent = _start(RAY_PARENT, tmp_path)
    try:
        report = json.loads(_read_line(parent, timeout=300))
        assert parent.wait(timeout=120) == 0
    finally:
        if parent.poll() is None:
            parent.kill()
    names = {name for _, _, name in report["listening"]}
    assert {"gcs_server", "raylet"} <= names, report
    assert len(report["workers"]) >= 1
    loopback = {"127.0.0.1", "::ffff:127.0.0.1", "::1"}
    assert [s for s in report["listening"] if s[0] not in loopback] == []
