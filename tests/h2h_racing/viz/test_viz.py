"""Rerun recordings of races (``h2h_racing.viz.recorder``), read back from the ``.rrd`` file."""

from __future__ import annotations

import socket
import subprocess
import sys
import urllib.request
from collections import defaultdict
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
from h2h_racing.policies import make_driver

import h2h_racing
from h2h_racing.cli.command import main
from h2h_racing.config.env import CameraConfig, RaceRules

rr = pytest.importorskip("rerun", reason='needs rerun-sdk: pip install "h2h-racing[viz]"')
psutil = pytest.importorskip("psutil")

from h2h_racing.viz import recorder as viz

SCRIPTED_STEPS = 240
"""Steps of the scripted race: off track at step 8, a collision at 29, a pass at 225."""
AGENTS = ("car_0", "car_1", "car_2")
SMALL_CAMERA = CameraConfig(width=80, height=60)


def scripted_actions(env: Any, drivers: list[Any], step: int) -> dict[str, np.ndarray]:
    """car_0 crawls on the centre line (0.5 m/s), car_1 races on the racing line and
    runs into it and passes it, car_2 steers hard right at the start and leaves the track."""
    actions = {}
    for i, agent in enumerate(env.possible_agents):
        if agent not in env.agents:
            continue
        action = drivers[i].act(env.core, i)[0].copy()
        if i == 0:
            action[1] = -1.0
        if i == 2 and step < 40:
            action[0] = -1.0
        actions[agent] = action
    return actions


def read_rrd(path: Path) -> dict[str, list[Any]]:
    """Return the record batches of every temporal chunk of ``path``, by entity path."""
    batches: dict[str, list[Any]] = defaultdict(list)
    for chunk in rr.chunk.RrdReader(path).stream():
        if not chunk.is_static:
            batches[chunk.entity_path].append(chunk.to_record_batch())
    return batches


def column(batches: list[Any], name: str) -> list[Any]:
    """Concatenate column ``name`` of the record batches that have it (durations as int ns)."""
    values: list[Any] = []
    for batch in batches:
        if name in batch.schema.names:
            array = batch.column(name)
            if str(array.type).startswith("duration"):
                array = array.cast("int64")
            values.extend(array.to_pylist())
    return values


def first(rows: list[Any]) -> list[Any]:
    """The single component of each row (rerun stores every component as a list per row)."""
    return [row[0] for row in rows]


def decode(blob: list[int]) -> np.ndarray:
    return cv2.imdecode(np.asarray(blob, dtype=np.uint8), cv2.IMREAD_UNCHANGED)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def scripted_race(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, int]:
    """The scripted three-car race recorded through ``RecordingEnv``: (path, steps)."""
    path = tmp_path_factory.mktemp("viz") / "scripted.rrd"
    env = h2h_racing.parallel_env(track="speedway", num_cars=3, grid="fixed",
                                  rules=RaceRules(laps=1, time_limit=40.0), camera=SMALL_CAMERA)
    recording = viz.RecordingEnv(env, path=path)
    recording.reset(seed=0)
    drivers = [make_driver("pure_pursuit"), make_driver("racing_line"),
               make_driver("pure_pursuit")]
    for driver in drivers:
        driver.reset(env.core)
    steps = 0
    while env.agents and steps < SCRIPTED_STEPS:
        recording.step(scripted_actions(env, drivers, steps))
        steps += 1
    recording.close()
    assert "step" not in vars(env.core), "close() must restore env.core.step"
    return path, steps


class TestRecordingContents:
    """A recorded race holds the track, the cars, the cameras, the scalars and the events."""

    def test_file_verifies_and_has_a_blueprint(self, scripted_race: tuple[Path, int]) -> None:
        path, _ = scripted_race
        status = subprocess.run([viz.rerun_binary(), "rrd", "verify", str(path)],
                                check=False, capture_output=True, text=True, timeout=60)
        assert status.returncode == 0, status.stderr
        reader = rr.chunk.RrdReader(path)
        assert [r.application_id for r in reader.recordings()] == [viz.APPLICATION_ID]
        assert len(reader.blueprints()) == 1

    def test_entity_paths(self, scripted_race: tuple[Path, int]) -> None:
        path, _ = scripted_race
        paths = set(map(str, rr.chunk.RrdReader(path).store().schema().entity_paths()))
        expected = {f"/map/track/{name}" for name in viz.TRACK_COLOURS}
        expected.add("/events")
        for agent in AGENTS:
            expected |= {f"/map/cars/{agent}/box", f"/map/cars/{agent}/trajectory/0",
                         f"/cars/{agent}/camera", f"/cars/{agent}/action",
                         f"/cars/{agent}/reward_terms"}
            expected |= {f"/metrics/{name}/{agent}" for name in viz.METRICS}
        assert expected <= paths, sorted(expected - paths)
        # 240 steps in pieces of 128 points: a second trajectory piece exists.
        assert "/map/cars/car_1/trajectory/1" in paths
        # No lidar without a lidar sensor (and lidar=None).
        assert not any("lidar" in p for p in paths)

    def test_every_step_is_logged_on_both_timelines(self,
                                                    scripted_race: tuple[Path, int]) -> None:
        path, steps = scripted_race
        batches = read_rrd(path)
        logged = column(batches["/metrics/speed/car_1"], "step")
        # The reset at step 0, then one row per env step.
        assert sorted(logged) == list(range(steps + 1))
        rewards = column(batches["/metrics/reward/car_1"], "step")
        assert sorted(rewards) == list(range(1, steps + 1))
        sim_time = column(batches["/metrics/speed/car_1"], "sim_time")
        dt = 1.0 / 15.0
        assert max(sim_time) * 1e-9 == pytest.approx(steps * dt, abs=1e-6)

    def test_each_provoked_event_is_in_the_log(self, scripted_race: tuple[Path, int]) -> None:
        path, _ = scripted_race
        texts = first(column(read_rrd(path)["/events"], "TextLog:text"))
        kinds = {text[1:text.index("]")] for text in texts}
        assert {"start", "off_track", "collision", "overtake", "penalty", "results"} <= kinds
        off = [t for t in texts if t.startswith("[off_track]")]
        assert any("car_2 went off track" in t for t in off), off
        collisions = [t for t in texts if t.startswith("[collision]")]
        # Both cars and the car behind are named.
        assert any(" hit car_" in t and "was behind" in t for t in collisions), collisions
        passes = [t for t in texts if t.startswith("[overtake]")]
        assert any("car_1 overtook car_0" in t for t in passes), passes
        assert all(" t=" in t for t in texts)
        results = [t for t in texts if t.startswith("[results]")]
        assert len(results) == 1 and "car_0" in results[0] and "pos" in results[0]

    def test_camera_images_have_the_camera_shape(self,
                                                 scripted_race: tuple[Path, int]) -> None:
        path, steps = scripted_race
        # car_0 (pure_pursuit) races all the steps; car_1 (racing_line) finishes its lap on the
        # last one, and a car's camera is logged only while it races.
        batches = read_rrd(path)["/cars/car_0/camera"]
        assert first(column(batches, "EncodedImage:media_type"))[0] == "image/jpeg"
        blobs = first(column(batches, "EncodedImage:blob"))
        assert len(blobs) == steps + 1
        for blob in (blobs[0], blobs[-1]):
            image = decode(blob)
            assert image.shape == (SMALL_CAMERA.height, SMALL_CAMERA.width)
            assert image.std() > 5.0, "the camera image is blank"


class TestBots:
    """Bot cars are drawn on the map every step and their contacts are logged as events."""

    def test_bots_and_a_bot_contact_are_recorded(self, tmp_path: Path) -> None:
        from conftest import circle_track

        track = circle_track()
        env = h2h_racing.parallel_env(
            track=track, num_cars=1, num_bots=2, bot_lane_change=False, camera=SMALL_CAMERA,
            rules=RaceRules(laps=1, time_limit=20.0, immobilised_steps=10**6))
        path = tmp_path / "bots.rrd"
        recording = viz.RecordingEnv(env, path=path)
        recording.reset(seed=0)
        # The car crawls (0.5 m/s) on the inner lane 0.6 m ahead of bot 0 (0.75 m/s): the bot
        # closes 0.25 m/s on a 0.28 m gap and runs into it from behind within ~1.2 s.
        core = env.core
        core.s[0, 0], core.d[0, 0], core.distance[0, 0] = 2.6, 0.25, 2.6
        core.position[0, 0] = track.point_at(2.6, 0.25)
        core.yaw[0, 0] = track.heading_at(2.6)
        core._sync_physics()
        for _ in range(30):
            recording.step({"car_0": np.array([0.0, -1.0])})
        recording.close()
        batches = read_rrd(path)
        assert sorted(column(batches["/map/bots"], "step")) == list(range(31))
        texts = first(column(batches["/events"], "TextLog:text"))
        assert any("bot_car_0 ran into car_0 from behind: every bot pauses 5 s" in t
                   for t in texts), texts


class TestSensorsFromTheEnv:
    """With camera and lidar sensors the recorder logs what the env observed."""

    def test_env_camera_and_lidar_are_logged(self, tmp_path: Path) -> None:
        path = tmp_path / "sensors.rrd"
        env = h2h_racing.parallel_env(track="oval", num_cars=2, grid="fixed",
                                      sensors=("state", "camera", "lidar"),
                                      camera=CameraConfig(width=64, height=48, stereo=True))
        with viz.RaceRecorder(env, path=path) as recorder:
            obs, infos = env.reset(seed=1)
            recorder.log_reset(obs, infos)
            for _ in range(5):
                actions = {a: np.array([0.0, 1.0], dtype=np.float32) for a in env.agents}
                recorder.log_step(actions, *env.step(actions))
        batches = read_rrd(path)
        image = decode(first(column(batches["/cars/car_0/camera"], "EncodedImage:blob"))[-1])
        # Stereo: left and right images side by side.
        assert image.shape == (48, 2 * 64)
        # car_0 starts right behind car_1 on the fixed grid: its lidar sees it.
        hits = column(batches["/map/cars/car_0/lidar/hits"], "Points2D:positions")
        assert len(column(batches["/map/cars/car_0/lidar/beams"], "LineStrips2D:strips")) == 6
        assert any(len(h) > 0 for h in hits)


class TestOptionalDependency:
    """rerun stays optional: the env never imports it, and a missing one says what to do."""

    def test_env_match_and_cli_do_not_import_rerun(self) -> None:
        code = ("import sys, h2h_racing, h2h_racing.envs.parallel, h2h_racing.match, h2h_racing.cli.command; "
                "h2h_racing.parallel_env(track='oval').reset(seed=0); "
                "assert 'rerun' not in sys.modules, 'rerun was imported'")
        subprocess.run([sys.executable, "-c", code], check=True, timeout=120)

    def test_missing_rerun_gives_the_install_command(self,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
        monkeypatch.setitem(sys.modules, "rerun", None)
        with pytest.raises(ImportError, match=r'pip install "h2h-racing\[viz\]"'):
            viz.import_rerun()

    def test_recorder_needs_a_sink(self) -> None:
        env = h2h_racing.parallel_env(track="oval")
        with pytest.raises(ValueError, match="path="):
            viz.RaceRecorder(env)


class TestCommandLine:
    """``h2h-racing race --save`` and ``--serve``."""

    def test_save_writes_a_recording_and_prints_the_table(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        path = tmp_path / "race.rrd"
        assert main(["race", "--track", "oval", "--laps", "1", "--save", str(path)]) == 0
        out = capsys.readouterr().out
        assert "pos" in out and "car_0 (racing_line)" in out and str(path) in out
        texts = first(column(read_rrd(path)["/events"], "TextLog:text"))
        assert sum(t.startswith("[finish]") for t in texts) == 2
        assert sum(t.startswith("[lap]") for t in texts) == 2
        assert any(t.startswith("[results]") and "racing_line" in t for t in texts)

    def test_serve_seconds_without_serve_is_an_error(
            self, capsys: pytest.CaptureFixture[str]) -> None:
        assert main(["race", "--serve-seconds", "1"]) == 2
        assert "--serve-seconds needs --serve" in capsys.readouterr().err

    def test_serve_binds_loopback_only_and_shuts_down(self) -> None:
        web, grpc = free_port(), free_port()
        env = h2h_racing.parallel_env(track="oval", num_cars=2)
        recorder = viz.RaceRecorder(env, serve=True, web_port=web, grpc_port=grpc)
        server = recorder._server
        assert server is not None
        try:
            listening = {(c.laddr.ip, c.laddr.port)
                         for c in psutil.Process(server.pid).net_connections(kind="inet")
                         if c.status == psutil.CONN_LISTEN}
            assert listening == {("127.0.0.1", web), ("127.0.0.1", grpc)}
            assert recorder.viewer_url.startswith(f"http://127.0.0.1:{web}/?url=")
            with urllib.request.urlopen(f"http://127.0.0.1:{web}/", timeout=10) as page:
                assert b"<html" in page.read(4096).lower()
            obs, infos = env.reset(seed=0)
            recorder.log_reset(obs, infos)
        finally:
            recorder.serve_until(0.2)
        assert server.poll() is not None, "the rerun server is still running"
        for port in (web, grpc):
            with socket.socket() as s:
                assert s.connect_ex(("127.0.0.1", port)) != 0, f"port {port} still open"

    def test_cli_serve_stops_after_serve_seconds(
            self, capsys: pytest.CaptureFixture[str]) -> None:
        web, grpc = free_port(), free_port()
        assert main(["race", "--track", "oval", "--laps", "1", "--serve", "--serve-seconds",
                     "0.5", "--web-port", str(web), "--grpc-port", str(grpc)]) == 0
        out = capsys.readouterr().out
        assert f"web viewer: http://127.0.0.1:{web}/?url=" in out
        with socket.socket() as s:
            assert s.connect_ex(("127.0.0.1", web)) != 0
