"""rerun's web viewer server for ``race --serve``: free ports, the server process and its stop.

The server is rerun's own binary (found by :func:`h2h_racing.viz.recorder.rerun_binary`), started
listening on 127.0.0.1 only. This module never imports rerun:
:class:`h2h_racing.viz.recorder.RaceRecorder` hands it the binary's locator.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
import urllib.parse
from collections.abc import Callable

from h2h_racing.common.lifeline import death_signal_preexec, started_from_main_thread


def check_ports_free(ports: dict[str, int], host: str = "127.0.0.1") -> None:
    """Raise a clear error unless every port can be bound on ``host``.

    The rerun server fails on a taken port only after it started, and a client connecting to
    that port meanwhile reaches whatever holds it; a trial bind finds the clash up front.

    Args:
        ports: Argument name -> port (``{"web_port": 9090, "grpc_port": 9876}``).

    Raises:
        ValueError: A port out of range, two equal ports, or a port something else holds.
    """
    for name, port in ports.items():
        if isinstance(port, bool) or not isinstance(port, int) or not 1 <= port <= 65535:
            raise ValueError(f"{name} must be a port number in [1, 65535], got {port!r}")
    if len(set(ports.values())) < len(ports):
        raise ValueError(f"the viewer's ports must differ, got {ports}")
    for name, port in ports.items():
        probe = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            if os.name == "posix":
                # As servers do: a port whose last connection is in TIME_WAIT is free.
                probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            probe.bind((host, port))
        except OSError as err:
            flag = "--" + name.replace("_", "-")
            raise ValueError(f"{name} {port} is already in use on {host} ({err.strerror}): "
                             f"stop what holds it or choose another port ({name}= or "
                             f"{flag})") from None
        finally:
            probe.close()


def _wait_for_port(port: int, process: subprocess.Popen, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise RuntimeError(f"the rerun server exited with status {process.returncode} "
                               f"before listening on 127.0.0.1:{port}; is the port taken? "
                               f"Choose others with web_port= / grpc_port=")
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.2):
                return
        except OSError:
            time.sleep(0.05)
    raise RuntimeError(f"the rerun server did not listen on 127.0.0.1:{port} within "
                       f"{timeout:.0f} s")


def start_viewer_server(web_port: int, grpc_port: int, binary: Callable[[], str],
                        ) -> tuple[subprocess.Popen, str, str]:
    """Start rerun's web viewer server on 127.0.0.1 and wait until both ports listen.

    Args:
        web_port: HTTP port of the web viewer.
        grpc_port: gRPC port of the server the recording streams to.
        binary: Returns the path of the ``rerun`` binary (called after the port check).

    Returns:
        ``(process, grpc_url, viewer_url)``: the server, the URL to stream to and the web
        viewer's URL.

    Raises:
        ValueError: A bad or taken port (see :func:`check_ports_free`).
        RuntimeError: The server exited or did not listen within 20 s (it is stopped).
    """
    check_ports_free({"web_port": web_port, "grpc_port": grpc_port})
    command = [binary(), "--serve-web", "--bind", "127.0.0.1", "--port",
               str(grpc_port), "--web-viewer-port", str(web_port),
               "--server-memory-limit", "1GiB"]
    # The server is a separate binary: a kill -9'd race would leave it holding the ports.
    # On Linux the kernel ends it with us (the death signal belongs to the starting
    # thread, so only the main thread arms it); elsewhere close() is the only stop.
    preexec = death_signal_preexec() if started_from_main_thread() else None
    server = subprocess.Popen(command, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL,
                              preexec_fn=preexec)
    try:
        _wait_for_port(grpc_port, server, timeout=20.0)
        _wait_for_port(web_port, server, timeout=20.0)
    except RuntimeError:
        stop_viewer_server(server)
        raise
    grpc_url = f"rerun+http://127.0.0.1:{grpc_port}/proxy"
    viewer_url = (f"http://127.0.0.1:{web_port}/?url="
                  f"{urllib.parse.quote(grpc_url, safe='')}")
    return server, grpc_url, viewer_url


def has_display() -> bool:
    """Whether a native window can open: always off Linux; on Linux, ``DISPLAY`` (X11) or
    ``WAYLAND_DISPLAY`` must be set."""
    if not sys.platform.startswith("linux"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def start_native_viewer(grpc_port: int, binary: Callable[[], str]) -> str:
    """Start rerun's native viewer with its gRPC server on 127.0.0.1 and wait until it listens.

    rerun's own ``spawn`` listens on 0.0.0.0 (every network interface), and without a display
    it waited for a viewer that never came up. Here the display is checked first and the
    viewer binds the loopback address only; it is detached (its window stays open after the
    race).

    Args:
        grpc_port: Port of the viewer's gRPC server, which the recording streams to.
        binary: Returns the path of the ``rerun`` binary.

    Returns:
        The URL to stream to.

    Raises:
        ValueError: No display, or a bad or taken port.
        RuntimeError: The viewer exited or did not listen within 20 s (it is stopped).
    """
    if not has_display():
        raise ValueError("--spawn opens rerun's native viewer window, but this machine has no "
                         "display (DISPLAY and WAYLAND_DISPLAY are unset): use --serve (the web "
                         "viewer on 127.0.0.1) or --save RACE.rrd")
    check_ports_free({"grpc_port": grpc_port})
    command = [binary(), "--bind", "127.0.0.1", "--port", str(grpc_port),
               "--memory-limit", "75%"]
    viewer = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                              stdin=subprocess.DEVNULL, start_new_session=True)
    try:
        _wait_for_port(grpc_port, viewer, timeout=20.0)
    except RuntimeError:
        stop_viewer_server(viewer)
        raise
    return f"rerun+http://127.0.0.1:{grpc_port}/proxy"


def stop_viewer_server(server: subprocess.Popen | None) -> None:
    """Stop the server (SIGINT, then kill after 5 s); nothing if it is None or has exited."""
    if server is None or server.poll() is not None:
        return
    server.send_signal(signal.SIGINT if os.name == "posix" else signal.SIGTERM)
    try:
        server.wait(timeout=5.0)
    except subprocess.TimeoutExpired:
        server.kill()
        server.wait(timeout=5.0)
