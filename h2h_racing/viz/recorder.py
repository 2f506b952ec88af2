"""Record races for the rerun viewer: the map, every car's camera, scalars and race events.

This is the only module of h2h-racing that imports ``rerun`` (an optional dependency:
``pip install "h2h-racing[viz]"``), and it imports it lazily; the env never does (see the
house style, "render vs camera vs viz"). A :class:`RaceRecorder` follows a ``RacingEnv`` in
the user's own loop::

    env = h2h_racing.parallel_env(track="speedway", num_cars=2)
    with RaceRecorder(env, path="race.rrd") as rec:
        obs, infos = env.reset(seed=0)
        rec.log_reset(obs, infos)
        while env.agents:
            actions = {a: policy(obs[a]) for a in env.agents}
            out = env.step(actions)
            rec.log_step(actions, *out)
            obs = out[0]
        rec.log_results(env.results())

or :class:`RecordingEnv` wraps the env and logs every ``reset`` and ``step`` itself.
Open the file with ``rerun race.rrd``.

The recorder's parts stand in their own modules, none of which imports rerun:
:mod:`h2h_racing.viz.cars` (the per-car streams), :mod:`h2h_racing.viz.events` (the event
lines) and :mod:`h2h_racing.viz.server` (the web viewer's server process and ports).

What is recorded (entity paths):

- ``/map/track/{left_border,right_border,centre,left_lane,right_lane,start_line}``: static
  2-D line strips in track coordinates [m]; ``/map/obstacles``: obstacle boxes (outlines);
  ``/map/bots``: the bot cars' boxes (outlines with a heading tick), every step.
- ``/map/cars/<agent>/box``: the car's oriented box in its colour (``render.car_colour``);
  ``/map/cars/<agent>/trajectory/<k>``: its path as a growing line, in pieces of
  ``TRAJECTORY_PIECE`` points (so that the recording grows linearly with the race);
  ``/map/cars/<agent>/lidar``: lidar beams and hit points when the lidar is on.
- ``/cars/<agent>/camera``: the car's camera as a JPEG (greyscale, the env's own camera
  when it has one, otherwise one the recorder renders); stereo cameras side by side.
- ``/cars/<agent>/action`` (steer and speed in [-1, 1]) and ``/cars/<agent>/reward_terms``
  (each weighted reward term): multi-series scalars.
- ``/metrics/{speed,progress,reward,rank,gap_to_leader}/<agent>``: scalars, one series per
  car per plot.
- ``/events``: a text log of race events, each line ``[kind] t=12.34 s car_0 ...`` with kind
  one of ``start``, ``lap``, ``overtake``, ``collision``, ``off_track``, ``infraction``,
  ``penalty``, ``reset``, ``finish``, ``retired``, ``results``.
- Timelines ``step`` (env steps since the reset) and ``sim_time`` (simulated seconds).

Events come from the core's ``StepEvents``: the recorder wraps ``env.core.step`` while it is
open (``close`` restores it), so collisions and passes name both cars. Do not pickle the env
while a recorder is attached.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, Self

import numpy as np

from h2h_racing.common.extras import install_hint, missing_extra
from h2h_racing.viz.render import car_colour
# Re-exported here, where users and tests look for them: TRAJECTORY_PIECE, EVENT_KINDS and
# check_ports_free.
from h2h_racing.viz.cars import REWARD_TERMS, TRAJECTORY_PIECE, CarStreams, _box_corners
from h2h_racing.viz.events import EVENT_KINDS, EVENT_LEVELS, step_event_lines
from h2h_racing.viz.server import (
    check_ports_free,
    has_display,
    start_native_viewer,
    start_viewer_server,
    stop_viewer_server,
)

if TYPE_CHECKING:
    from h2h_racing.sim.core import StepEvents
    from h2h_racing.envs.parallel import RacingEnv

INSTALL_HINT = install_hint("viz")
"""The command that installs the optional rerun dependency."""
APPLICATION_ID = "h2h_racing"
"""Application id of every recording (recordings of one id share blueprints in the viewer)."""
METRICS = ("speed", "progress", "reward", "rank", "gap_to_leader")
"""Per-car scalars under ``/metrics/<name>/<agent>``."""
TRACK_COLOURS = {"left_border": (235, 235, 235), "right_border": (235, 235, 235),
                 "centre": (225, 190, 40), "left_lane": (120, 120, 130),
                 "right_lane": (120, 120, 130), "start_line": (230, 60, 60)}
OBSTACLE_COLOUR = (160, 110, 60)


def import_rerun() -> Any:
    """Import and return the ``rerun`` module.

    Raises:
        ImportError: rerun-sdk is missing; the message gives the command that installs it.
    """
    try:
        import rerun
    except ImportError as exc:
        raise missing_extra("viz", "recording races", exc) from exc
    return rerun


def rerun_binary() -> str:
    """Return the path of the ``rerun`` viewer binary shipped with rerun-sdk.

    Raises:
        ImportError: rerun-sdk is missing.
        FileNotFoundError: The wheel has no viewer binary here.
    """
    import_rerun()
    try:
        import rerun_cli
    except ImportError as exc:
        raise ImportError(f"rerun-sdk is installed without its viewer (rerun_cli); reinstall "
                          f"it with: {INSTALL_HINT}") from exc
    path = Path(rerun_cli.__file__).parent / ("rerun.exe" if sys.platform == "win32" else "rerun")
    if not path.exists():
        found = shutil.which("rerun")
        if found is None:
            raise FileNotFoundError(f"expected the rerun viewer binary at {path}, found none; "
                                    f"reinstall it with: {INSTALL_HINT}")
        return found
    return str(path)


class RaceRecorder(CarStreams):
    """Logs a ``RacingEnv`` race to rerun: a file, a native viewer or a local web viewer.

    Args:
        env: The env to follow (a ``RacingEnv``; its ``core`` and ``track`` are read).
        path: Write the recording to this ``.rrd`` file.
        spawn: Open the native rerun viewer and stream to it (needs a display; its gRPC
            server listens on 127.0.0.1:``grpc_port`` only).
        serve: Serve the web viewer on 127.0.0.1 only (``viewer_url``); keep it up with
            :meth:`serve_until` after the race.
        cameras: Log every car's camera image.
        camera_every: Log the camera on every k-th step only (1: every step).
        jpeg_quality: JPEG quality of the camera images (1 to 100).
        lidar: Log lidar beams and hits; None logs them when the env has a lidar sensor,
            True renders a lidar of the recorder's own when it has none.
        web_port: HTTP port of the web viewer with ``serve``.
        grpc_port: gRPC port of the rerun server with ``serve``.
        recording_id: Recording id (None: a random one).

    Raises:
        ImportError: rerun-sdk is not installed (the message says how to install it).
        ValueError: No sink, a bad argument, or (``serve``) a port already in use on
            127.0.0.1 (checked before the server starts).
    """

    def __init__(self, env: RacingEnv, path: str | Path | None = None, *, spawn: bool = False,
                 serve: bool = False, cameras: bool = True, camera_every: int = 1,
                 jpeg_quality: int = 80, lidar: bool | None = None, web_port: int = 9090,
                 grpc_port: int = 9876, recording_id: str | None = None) -> None:
        rr = import_rerun()
        if path is None and not spawn and not serve:
            raise ValueError("RaceRecorder needs somewhere to send the recording: give "
                             "path='race.rrd', spawn=True or serve=True")
        if spawn and serve:
            raise ValueError("spawn and serve both start a viewer on grpc_port: choose one "
                             "(--spawn for the native viewer, --serve for the web viewer)")
        if spawn and not has_display():
            start_native_viewer(grpc_port, rerun_binary)  # raises the no-display error
        if not isinstance(camera_every, int) or camera_every < 1:
            raise ValueError(f"camera_every must be an int >= 1, got {camera_every!r}")
        if not 1 <= int(jpeg_quality) <= 100:
            raise ValueError(f"jpeg_quality must be in [1, 100], got {jpeg_quality!r}")
        if not hasattr(env, "core") or not hasattr(env, "track"):
            raise ValueError(f"env must be a h2h_racing RacingEnv (with .core and .track), got "
                             f"{type(env).__name__}")
        self._rr = rr
        self.env = env
        self.agents = list(env.possible_agents)
        self.camera_every = camera_every
        self.jpeg_quality = int(jpeg_quality)
        self.path = Path(path) if path is not None else None
        self.viewer_url: str | None = None
        """URL of the web viewer with ``serve`` (127.0.0.1)."""
        self._server: subprocess.Popen | None = None
        config = env.config
        obstacle_size = (config.obstacle_length, config.obstacle_width)
        self._camera_from_obs = "camera" in config.sensors
        self._own_camera = None
        if cameras and not self._camera_from_obs:
            from h2h_racing.sensors.camera import CameraSensor

            self._own_camera = CameraSensor(config.camera, env.track, config.car, obstacle_size)
        self.cameras = bool(cameras)
        self._lidar_from_obs = lidar is not False and "lidar" in config.sensors
        self._own_lidar = None
        if lidar and not self._lidar_from_obs:
            from h2h_racing.sensors.lidar import LidarSensor

            self._own_lidar = LidarSensor(config.lidar, config.car, obstacle_size)
        self.lidar = self._lidar_from_obs or self._own_lidar is not None
        self._lidar_angles = config.lidar.angles
        self._lidar_mount = np.array([config.lidar.mount_forward_m, config.lidar.mount_left_m])
        self.rec = rr.RecordingStream(APPLICATION_ID, recording_id=recording_id)
        self.blueprint = self.default_blueprint()
        sinks: list[Any] = []
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            sinks.append(rr.FileSink(str(self.path)))
        if serve:
            grpc_url = self._start_server(web_port, grpc_port)
            sinks.append(rr.GrpcSink(grpc_url))
        if spawn:
            sinks.append(rr.GrpcSink(start_native_viewer(grpc_port, rerun_binary)))
        self.rec.set_sinks(*sinks, default_blueprint=self.blueprint)
        self._events: StepEvents | None = None
        self._core_step: Callable[..., Any] | None = None
        self._hook_core()
        self._step = 0
        self._trail: dict[str, list[list[float]]] = {a: [] for a in self.agents}
        self._piece = dict.fromkeys(self.agents, 0)
        self._closed = False
        self._log_static()

    # ------------------------------------------------------------------ setup
    def _start_server(self, web_port: int, grpc_port: int) -> str:
        self._server, grpc_url, self.viewer_url = start_viewer_server(web_port, grpc_port,
                                                                      rerun_binary)
        return grpc_url

    def _stop_server(self) -> None:
        server, self._server = self._server, None
        stop_viewer_server(server)

    def _hook_core(self) -> None:
        core = self.env.core
        original = core.step

        def step(*args: Any, **kwargs: Any) -> Any:
            events = original(*args, **kwargs)
            self._events = events
            return events

        self._core_step = original
        core.step = step

    def _unhook_core(self) -> None:
        core = self.env.core
        if self._core_step is not None and "step" in vars(core):
            del core.step
        self._core_step = None

    def default_blueprint(self) -> Any:
        """Return the default layout: the map large, the cameras in a grid beside it, and
        the time series and the event log below."""
        import rerun.blueprint as rrb

        xmin, ymin, xmax, ymax = self.env.track.bounds
        margin = 0.5
        bounds = rrb.VisualBounds2D(x_range=[xmin - margin, xmax + margin],
                                    y_range=[ymin - margin, ymax + margin])
        top: list[Any] = [rrb.Spatial2DView(origin="/map", name="track", visual_bounds=bounds,
                                            background=[46, 58, 46])]
        shares = [3.0]
        if self.cameras:
            views = [rrb.Spatial2DView(origin=f"/cars/{a}/camera", name=f"{a} camera")
                     for a in self.agents]
            columns = 1 if len(views) <= 3 else 2
            top.append(rrb.Grid(*views, grid_columns=columns))
            shares.append(1.2 if columns == 1 else 2.0)
        plots = [rrb.TimeSeriesView(origin=f"/metrics/{name}", name=name) for name in METRICS]
        plots += [rrb.TimeSeriesView(origin=f"/cars/{a}/reward_terms", name=f"{a} reward terms")
                  for a in self.agents]
        plots += [rrb.TimeSeriesView(origin=f"/cars/{a}/action", name=f"{a} action")
                  for a in self.agents]
        bottom = rrb.Horizontal(rrb.Tabs(*plots), rrb.TextLogView(origin="/events",
                                                                  name="events"),
                                column_shares=[2.0, 1.0])
        return rrb.Blueprint(rrb.Vertical(rrb.Horizontal(*top, column_shares=shares), bottom,
                                          row_shares=[2.0, 1.0]),
                             collapse_panels=True)

    def _log_static(self) -> None:
        rr, rec, track = self._rr, self.rec, self.env.track
        for name, line in (("left_border", track.left_border),
                           ("right_border", track.right_border), ("centre", track.centre),
                           ("left_lane", track.left_lane), ("right_lane", track.right_lane)):
            closed = np.vstack([line, line[:1]])
            radius = 0.025 if name.endswith("border") else 0.01
            rec.log(f"/map/track/{name}", rr.LineStrips2D([closed], radii=radius,
                                                          colors=TRACK_COLOURS[name],
                                                          draw_order=1.0), static=True)
        left0, right0 = track.half_widths_at(np.array([0.0]))
        start = track.point_at(np.array([0.0, 0.0]), np.array([left0[0], -right0[0]]))
        rec.log("/map/track/start_line", rr.LineStrips2D([start], radii=0.03,
                                                         colors=TRACK_COLOURS["start_line"],
                                                         draw_order=2.0), static=True)
        for i, agent in enumerate(self.agents):
            colour = car_colour(i)
            for name in METRICS:
                rec.log(f"/metrics/{name}/{agent}", rr.SeriesLines(colors=colour, names=agent),
                        static=True)
            rec.log(f"/cars/{agent}/action", rr.SeriesLines(names=["steer", "speed"]),
                    static=True)
            base = f"/map/cars/{agent}"
            rec.log(f"{base}/box", rr.LineStrips2D.from_fields(
                radii=0.02, colors=colour, labels=agent, show_labels=True, draw_order=10.0),
                static=True)
            if self.lidar:
                rec.log(f"{base}/lidar/beams", rr.LineStrips2D.from_fields(
                    radii=0.004, colors=(*colour, 70), draw_order=4.0), static=True)
                rec.log(f"{base}/lidar/hits", rr.Points2D.from_fields(
                    radii=0.025, colors=colour, draw_order=6.0), static=True)
            rec.log(f"/cars/{agent}/reward_terms", rr.SeriesLines(names=list(REWARD_TERMS)),
                    static=True)

    # ------------------------------------------------------------------ logging
    def _set_time(self) -> None:
        self.rec.set_time("step", sequence=self._step)
        self.rec.set_time("sim_time", duration=float(self.env.core.time[0]))

    def _event(self, kind: str, text: str, car: int | None = None) -> None:
        core_time = float(self.env.core.time[0])
        colour = car_colour(car) if car is not None else None
        self.rec.log("/events", self._rr.TextLog(f"[{kind}] t={core_time:.2f} s {text}",
                                                 level=EVENT_LEVELS[kind], color=colour))

    def log_reset(self, obs: dict[str, Any] | None = None,
                  infos: dict[str, dict[str, Any]] | None = None) -> None:
        """Log the start of an episode (call right after ``env.reset``).

        Args:
            obs: The observations ``reset`` returned (their camera and lidar are logged).
            infos: The infos ``reset`` returned.
        """
        self._check_open()
        rr, rec, core = self._rr, self.rec, self.env.core
        self._step = 0
        self._events = None
        self._set_time()
        for agent in self.agents:
            self._trail[agent] = []
            self._piece[agent] = 0
        rec.log("/map/cars", rr.Clear(recursive=True))
        if core.num_obstacles:
            cfg = core.config
            boxes = _box_corners(core.obstacle_position[0], core.obstacle_yaw[0],
                                 cfg.obstacle_length, cfg.obstacle_width)
            rec.log("/map/obstacles", rr.LineStrips2D(list(boxes), radii=0.02,
                                                      colors=OBSTACLE_COLOUR, draw_order=3.0))
        if self._own_camera is not None:
            self._own_camera.reset(core)
        order = ", ".join(f"P{int(core.rank[0, i])} {a}" for i, a in enumerate(self.agents))
        self._event("start", f"race start on {self.env.track.name}: {order}")
        self._log_cars(obs or {}, dict.fromkeys(self.agents, None), infos or {})

    def log_step(self, actions: dict[str, Any], obs: dict[str, Any], rewards: dict[str, float],
                 terminations: dict[str, bool], truncations: dict[str, bool],
                 infos: dict[str, dict[str, Any]]) -> None:
        """Log one env step (call right after ``env.step`` with its inputs and outputs).

        Args:
            actions: The actions passed to ``step``.
            obs: Observations returned by ``step``.
            rewards: Rewards returned by ``step``.
            terminations: Terminations returned by ``step``.
            truncations: Truncations returned by ``step``.
            infos: Infos returned by ``step``.
        """
        self._check_open()
        self._step += 1
        self._set_time()
        self._log_events(infos, terminations, truncations)
        self._log_cars(obs, actions, infos, rewards)
        for agent in infos:
            if terminations.get(agent) or truncations.get(agent):
                self.rec.log(f"/map/cars/{agent}/box", self._rr.Clear(recursive=False))

    def log_results(self, rows: list[dict[str, Any]], names: dict[str, str] | None = None,
                    ) -> None:
        """Log the final results table (``env.results()``) as a ``[results]`` event.

        Args:
            rows: Result rows, winner first (see ``h2h_racing.envs.results.race_results``).
            names: Optional display name (e.g. driver) of each agent.
        """
        from h2h_racing.envs.results import format_results

        self._check_open()
        self._event("results", "final results\n" + format_results(rows, names))

    def close(self) -> None:
        """Flush and close the recording, restore ``env.core.step`` and stop a web server.

        With ``serve`` the server stops here: call :meth:`serve_until` first to keep it up.
        """
        if self._closed:
            return
        self._closed = True
        self._unhook_core()
        self.rec.flush()
        self.rec.disconnect()
        self._stop_server()

    def serve_until(self, seconds: float | None = None) -> None:
        """Keep the web viewer up for ``seconds`` (None: until Ctrl-C), then close.

        Raises:
            ValueError: The recorder was not created with ``serve=True``.
        """
        if self._server is None:
            raise ValueError("serve_until needs a recorder created with serve=True")
        self.rec.flush()
        deadline = None if seconds is None else time.monotonic() + seconds
        try:
            while self._server.poll() is None:
                if deadline is not None and time.monotonic() >= deadline:
                    break
                time.sleep(0.1 if deadline is None else min(0.1, max(0.0, deadline -
                                                                      time.monotonic())))
        except KeyboardInterrupt:
            pass
        finally:
            self.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError("this RaceRecorder is closed; create a new one to record again")

    # ------------------------------------------------------------------ parts
    def _log_events(self, infos: dict[str, dict[str, Any]], terminations: dict[str, bool],
                    truncations: dict[str, bool]) -> None:
        events, self._events = self._events, None
        if events is None:
            return
        for kind, text, car in step_event_lines(events, self.agents, self.env.core,
                                                self.env.config.bot_penalty, truncations):
            self._event(kind, text, car)


class RecordingEnv:
    """A ``RacingEnv`` that logs every ``reset`` and ``step`` to a :class:`RaceRecorder`.

    Every other attribute is the wrapped env's. ``close`` closes the recorder (logging the
    results first) and the env.

    Args:
        env: The env to wrap.
        **recorder: Arguments of :class:`RaceRecorder` (``path``, ``spawn``, ``serve``, ...).
    """

    def __init__(self, env: RacingEnv, **recorder: Any) -> None:
        self.env = env
        self.recorder = RaceRecorder(env, **recorder)

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None,
              ) -> tuple[dict[str, Any], dict[str, dict[str, Any]]]:
        """Reset the env and log the new episode."""
        obs, infos = self.env.reset(seed=seed, options=options)
        self.recorder.log_reset(obs, infos)
        return obs, infos

    def step(self, actions: dict[str, Any]) -> tuple[Any, ...]:
        """Step the env and log the step."""
        out = self.env.step(actions)
        self.recorder.log_step(actions, *out)
        return out

    def close(self) -> None:
        """Log the results, close the recorder and the env."""
        if not self.recorder._closed:
            self.recorder.log_results(self.env.results())
            self.recorder.close()
        self.env.close()

    def __getattr__(self, name: str) -> Any:
        return getattr(self.env, name)
