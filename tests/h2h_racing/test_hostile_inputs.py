"""Hostile and careless inputs (issue 17): re-placements that land on other bodies, tracks
whose tables would not fit in memory, and configs of the wrong type must give a safe result or
a clear error. (Loading files: test_hostile_loading.py; processes: test_hostile_processes.py.)
"""

from __future__ import annotations

import numpy as np
import pytest

from h2h_racing.sim import layouts as spawn
from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.sim.core import RaceCore
from h2h_racing.track.io import load_track

from conftest import box_corners, box_penetration

# --------------------------------------------------------------------------- re-placement


def replacement_overlap(core: RaceCore, replaced: np.ndarray) -> np.ndarray:
    """Deepest overlap [m] of each car in ``replaced`` (E, N) with any other body of its copy
    (every other car, obstacle and bot), measured on the box footprints now; shape (R,)."""
    cfg = core.config
    car = box_corners(core.position, core.yaw, cfg.car.length, cfg.car.width)
    n = core.num_cars
    depth = box_penetration(car[:, :, None], car[:, None, :])
    depth[:, np.arange(n), np.arange(n)] = 0.0
    worst = depth.max(axis=2)
    if core.num_obstacles:
        box = box_corners(core.obstacle_position, core.obstacle_yaw, cfg.obstacle_length,
                          cfg.obstacle_width)
        worst = np.maximum(worst, box_penetration(car[:, :, None], box[:, None]).max(axis=2))
    if core.num_bots:
        bot = box_corners(core.bot_position, core.bot_yaw, cfg.car.length, cfg.car.width)
        worst = np.maximum(worst, box_penetration(car[:, :, None], bot[:, None]).max(axis=2))
    return worst[replaced]


def fuzz_replacements(num_cars: int, num_envs: int, steps: int, seed: int) -> tuple[int, int]:
    """Race ``num_cars`` cars with 6 boxes and 3 bots on ``technical`` under race rules with
    random and extreme actions; return (re-placements, re-placements that overlapped)."""
    rng = np.random.default_rng(seed)
    cfg = EnvConfig(track="technical", race_type="head_to_head", num_cars=num_cars,
                    num_obstacles=6, num_bots=3, randomize_obstacles=True,
                    rules=RaceRules.preset("head_to_head", "race"))
    core = RaceCore(cfg, load_track("technical"), num_envs=num_envs)
    core.reset(seed=seed)
    steer_mid, steer_half, speed_mid, speed_half = cfg.action_affine
    total = overlapped = 0
    for _ in range(steps):
        act = rng.uniform(-1.0, 1.0, (num_envs, num_cars, 2))
        extreme = np.sign(rng.uniform(-1.0, 1.0, act.shape))
        act[::2] = extreme[::2]  # every second copy drives full lock / full throttle
        ev = core.step(steer_mid + steer_half * act[..., 0], speed_mid + speed_half * act[..., 1])
        if ev.replaced.any():
            depth = replacement_overlap(core, ev.replaced)
            total += depth.size
            overlapped += int((depth > 0.0).sum())
        over = core.done.all(axis=1)
        if over.any():
            core.reset_envs(over)
    return total, overlapped


def test_replacements_never_overlap_a_body() -> None:
    # Before the fix this run put 19 of ~1,150 re-placed cars on another body.
    total, overlapped = fuzz_replacements(num_cars=12, num_envs=16, steps=600, seed=0)
    assert total > 500
    assert overlapped == 0, f"{overlapped} of {total} re-placements overlapped another body"


@pytest.mark.slow
@pytest.mark.parametrize("num_cars", [12, 6, 4])
def test_replacements_never_overlap_a_body_long(num_cars: int) -> None:
    # Before the fix: 12 cars 321 of 5,083 overlapped, 6 cars 97 of 2,541 (up to 0.196 m).
    total, overlapped = fuzz_replacements(num_cars=num_cars, num_envs=16, steps=2400,
                                          seed=num_cars)
    assert total > 100 * num_cars
    assert overlapped == 0, f"{overlapped} of {total} re-placements overlapped another body"


def frozen_core(num_cars: int, num_obstacles: int = 0) -> RaceCore:
    """A race on the oval with every car frozen in place (no car will be re-placed)."""
    cfg = EnvConfig(track="oval", num_cars=num_cars, race_type="head_to_head", grid="fixed",
                    num_obstacles=num_obstacles, rules=RaceRules.preset("head_to_head", "race"))
    core = RaceCore(cfg, load_track("oval"), num_envs=1)
    core.reset(seed=0)
    core.frozen_until[:] = 1e9
    core._racing[:] = False
    return core


def queue_replacement(core: RaceCore, car: int, distance: float, lane: float) -> None:
    """Make ``car`` due for re-placement at ``distance`` on ``lane`` after the next step."""
    core.frozen_until[0, car] = 0.0
    core.pending_replace[0, car] = True
    core.replace_distance[0, car] = distance
    core.d[0, car] = 0.1 * lane
    core._pending_any = True


def step(core: RaceCore):
    return core.step(np.zeros((1, core.num_cars)), np.zeros((1, core.num_cars)))


def test_cars_replaced_in_the_same_step_avoid_each_other() -> None:
    # Both cars are due back at the same spot: the second must see the first's new position,
    # not the old one (before the fix both landed on the same spot, 0.196 m deep).
    core = frozen_core(2)
    queue_replacement(core, 0, 8.0, 1.0)
    queue_replacement(core, 1, 8.0, 1.0)
    ev = step(core)
    assert ev.replaced[0].all()
    assert replacement_overlap(core, ev.replaced).max() == 0.0
    gap = np.linalg.norm(core.position[0, 0] - core.position[0, 1])
    length, width = core.config.car.length, core.config.car.width
    assert gap >= np.hypot(length, width)  # the footprint circles do not touch


def test_car_with_no_clear_spot_stays_frozen_until_one_clears() -> None:
    # A box stands on every candidate spot of car 0; before the fix car 0 took the last
    # candidate and landed on a box.
    from h2h_racing.sim.replacement import REPLACE_STEP, REPLACE_TRIES

    core = frozen_core(2, num_obstacles=2 * REPLACE_TRIES)
    track = core.track
    cand_dist, cand_lane = spawn.replacement_candidates(track, np.array([8.0]), np.array([1.0]),
                                                        REPLACE_STEP, REPLACE_TRIES)
    cand_s = np.mod(cand_dist[0], track.length)
    spots = track.point_at(cand_s, spawn.lane_offset(track, cand_s, cand_lane[0]))
    core.obstacle_position[0] = spots
    core.obstacle_yaw[0] = track.heading_at(cand_s)
    core._sync_physics()
    queue_replacement(core, 0, 8.0, 1.0)
    where = core.position[0, 0].copy()
    for _ in range(5):
        time = core.time[0]
        ev = step(core)
        assert not ev.replaced.any()
        assert core.time[0] > time  # the clock runs
        assert core.frozen[0, 0] and not core.racing[0, 0] and core.waiting[0, 0]
        # It waits parked off the track, where it blocks nobody; its last pose is kept.
        np.testing.assert_allclose(core.position[0, 0], core._park[0, 0], atol=1e-9)
        np.testing.assert_allclose(core.final_position[0, 0], where, atol=1e-9)
        assert core.resets[0, 0] == 0
    # The boxes on the first spot and on the next one behind it (0.02 m from it) go: car 0 is
    # put on the first spot on the next step.
    core.obstacle_position[0, [0, 2]] = core._park[0, 1] + 5.0
    core._sync_physics()
    ev = step(core)
    assert ev.replaced[0, 0] and core.resets[0, 0] == 1
    np.testing.assert_allclose(core.position[0, 0], spots[0], atol=1e-9)
    assert replacement_overlap(core, ev.replaced).max() == 0.0
    assert core.racing[0, 0] and not core.waiting[0, 0]


# --------------------------------------------------------------------------- memory

# Run in a child whose address space may grow by at most 1 GiB beyond what its imports took,
# so a table that outgrows memory fails there (MemoryError) instead of taking the machine.
HUGE_TRACK_CHILD = r"""
import json, resource, sys, tracemalloc
import numpy as np
import h2h_racing
from h2h_racing.viz.render import SpectatorRenderer
from h2h_racing.track.io import load_track
from h2h_racing.track.lookup import TrackLookup

path = sys.argv[1]
# A DeepRacer route written in millimetres: a circle of radius 1e6 (m, as read), 1,000 wide.
a = np.linspace(0.0, 2.0 * np.pi, 200, endpoint=False)
rings = [r * np.stack([np.cos(a), np.sin(a)], axis=1) for r in (1e6, 1e6 - 500.0, 1e6 + 500.0)]
route = np.concatenate(rings, axis=1)
np.save(path, np.concatenate([route, route[:1]]))
with open("/proc/self/status") as status:
    vm = next(int(line.split()[1]) for line in status if line.startswith("VmSize:")) << 10
resource.setrlimit(resource.RLIMIT_AS, (vm + (1 << 30), vm + (1 << 30)))
tracemalloc.start()
track = load_track(path)
lookup = TrackLookup.from_track(track)
track.projector()
env = h2h_racing.parallel_env(track=path, num_cars=2, sensors=("state", "lidar", "camera"))
env.reset(seed=0)
env.step({agent: env.action_space(agent).sample() for agent in env.agents})
SpectatorRenderer(track)
print(json.dumps({"length": track.length, "samples": len(lookup.x),
                  "peak": tracemalloc.get_traced_memory()[1]}))
"""


def test_huge_track_tables_stay_bounded(tmp_path) -> None:
    # Before the fix the 2 cm lookup table alone asked for 8 x 2.3 GiB (the process grew to
    # 23 GB); the camera's centre-line dashes asked for 4.7 GiB and the spectator's 0.5 GiB.
    import json
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", HUGE_TRACK_CHILD, str(tmp_path / "mm.npy")],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["length"] > 6e6
    assert out["samples"] == (1 << 20) + 1  # track_lookup.MAX_SAMPLES, ds = 6 m
    assert out["peak"] < 512 << 20, f"traced peak {out['peak'] >> 20} MiB"


def test_projection_grid_builds_in_small_chunks() -> None:
    # Projector.build took ~140 MiB at its peak for a shipped track (every process's peak).
    import tracemalloc

    from h2h_racing.track.shape import Projector

    track = load_track("speedway")
    tracemalloc.start()
    try:
        Projector.build(track)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 40 << 20, f"Projector.build peak {peak >> 20} MiB"


# --------------------------------------------------------------------------- bad values


@pytest.mark.parametrize("field", ["num_cars", "num_obstacles", "physics_substeps", "max_cycles",
                                   "opponent_slots", "obstacle_slots"])
def test_a_bool_is_not_a_count(field: str) -> None:
    # True passed every check (Python's bool is an int) and failed later deep inside numpy.
    with pytest.raises(ValueError, match=rf"EnvConfig\.{field} must be .*int.*got True"):
        EnvConfig(**{field: True})


def test_parallel_env_refuses_num_cars_true() -> None:
    import h2h_racing

    with pytest.raises(ValueError, match=r"EnvConfig\.num_cars must be an int in \[1, 16\], "
                                         r"got True"):
        h2h_racing.parallel_env(track="oval", num_cars=True)


@pytest.mark.parametrize(("field", "value"), [
    ("laps", True), ("reversed_steps", True), ("immobilised_steps", True),
    ("max_resets_per_lap", True), ("time_limit", "60"), ("crash_penalty", "5"),
])
def test_race_rules_name_a_value_of_the_wrong_type(field: str, value: object) -> None:
    # Strings failed in a comparison ("'>' not supported") that named no field.
    with pytest.raises(ValueError, match=rf"RaceRules\.{field} must be .*got {value!r}"):
        RaceRules(**{field: value})


def write(tmp_path, name: str, text: str):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_league_toml_takes_one_track_name_as_a_list(tmp_path) -> None:
    # tuple("oval") made the league's tracks o, v, a, l ("Unknown track 'o'" later).
    from h2h_racing.league.config import LeagueConfig

    config = LeagueConfig.from_toml(write(tmp_path, "l.toml", 'tracks = "oval"\n'
                                                              'anchors = "racing_line"\n'))
    assert config.tracks == ("oval",)
    assert config.anchors == ("racing_line",)


def test_league_toml_names_the_key_of_a_value_of_the_wrong_type(tmp_path) -> None:
    from h2h_racing.league.config import LeagueConfig

    path = write(tmp_path, "l.toml", '[races]\neval_recent = "6"\n')
    with pytest.raises(ValueError) as err:
        LeagueConfig.from_toml(path)
    assert str(err.value) == f"{path}: [races] eval_recent must be an integer, got '6' (str)"
    path = write(tmp_path, "m.toml", 'tracks = ["oval", 3]\n')
    with pytest.raises(ValueError, match=r"tracks must be a list of strings \(or one string\), "
                                         r"got \['oval', 3\]"):
        LeagueConfig.from_toml(path)


def test_train_toml_names_the_key_of_a_value_of_the_wrong_type(tmp_path) -> None:
    from h2h_racing.training.config import TrainConfig

    path = write(tmp_path, "t.toml", 'num_envs = "64"\n')
    with pytest.raises(ValueError) as err:
        TrainConfig.from_toml(path)
    assert str(err.value) == f"{path}: num_envs must be an integer, got '64' (str)"
    path = write(tmp_path, "u.toml", "hidden_dims = 128\n")
    with pytest.raises(ValueError, match=r"hidden_dims must be a list of integers, got 128"):
        TrainConfig.from_toml(path)


def test_train_command_names_the_key_of_a_value_of_the_wrong_type(tmp_path, capsys) -> None:
    from h2h_racing.cli.command import main

    path = write(tmp_path, "t.toml", "num_steps_per_env = [32]\n")
    assert main(["train", "--out", str(tmp_path / "run"), "--config", str(path)]) == 2
    assert (f"h2h-racing: error: {path}: num_steps_per_env must be an integer, got [32] "
            f"(list)") in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


def test_model_metadata_says_that_lidar_config_is_ignored(tmp_path) -> None:
    import json

    from h2h_racing.deepracer.metadata import load_model_metadata

    path = write(tmp_path, "model_metadata.json", json.dumps({
        "action_space": [{"steering_angle": 0.0, "speed": 1.0}],
        "sensor": ["FRONT_FACING_CAMERA", "SECTOR_LIDAR"],
        "lidar_config": {"num_sectors": 16, "num_values_per_sector": 4, "clipping_dist": 1.0}}))
    with pytest.warns(UserWarning, match=r"lidar_config .* is ignored \(keys \['clipping_dist', "
                                         r"'num_sectors', 'num_values_per_sector'\]\).*"
                                         r"SECTOR_LIDAR gives 8 sectors"):
        overrides = load_model_metadata(path)
    # As in DeepRacer: SECTOR_LIDAR keeps its 8 sectors at 0.5 m whatever lidar_config says.
    assert overrides["lidar"].mode == "sector_lidar"
    assert (overrides["lidar"].sectors, overrides["lidar"].sector_clip) == (8, 0.5)


# ---------------------------------------------------------------- upper bounds on counts (issue 38)


@pytest.mark.parametrize(("text", "message"), [
    ("num_envs = 100000\n", r"num_envs must be an int in \[1, 4096\], got 100000"),
    ("num_steps_per_env = 10000000\n", r"num_steps_per_env must be an int in \[1, 1024\], got 10000000"),
    ("hidden_dims = [60000, 60000]\n", r"hidden_dims must be 1 to 8 layer sizes, each an int in \[1, 4096\], "
                                       r"got \[60000, 60000\]"),
    ("hidden_dims = [" + "8, " * 100 + "8]\n", r"hidden_dims must be 1 to 8 layer sizes.*a list of 101 values"),
    ("num_envs = 4096\nnum_steps_per_env = 1024\n", r"4096 \* 1024 transitions .* GiB of rollout storage; "
                                                    r"at most 4 GiB"),
    ('observations = "camera_only"\ncamera_size = [640, 480]\ncamera_frames = 8\n',
     r"256 \* 32 transitions of 2458112 float32 values need 75\.0 GiB"),
])
def test_train_toml_counts_are_bounded(tmp_path, text: str, message: str) -> None:
    # Before, each of these took gigabytes, or gave numpy's or torch's allocation traceback.
    from h2h_racing.training.config import TrainConfig

    with pytest.raises(ValueError, match=message):
        TrainConfig.from_toml(write(tmp_path, "t.toml", text))


@pytest.mark.parametrize("key", ["num_envs", "num_steps_per_env"])
def test_league_toml_counts_are_bounded(tmp_path, key: str) -> None:
    from h2h_racing.league.config import LeagueConfig

    with pytest.raises(ValueError, match=rf"\[training\] {key} must be an int in \[1, \d+\], got 10000000"):
        LeagueConfig.from_toml(write(tmp_path, "l.toml", f"[training]\n{key} = 10000000\n"))


@pytest.mark.parametrize(("field", "value", "allowed"), [
    ("opponent_slots", 10**9, r"an int in \[0, 27\]"),
    ("obstacle_slots", 10**9, r"an int in \[0, 32\]"),
])
def test_observation_slots_are_bounded(field: str, value: int, allowed: str) -> None:
    with pytest.raises(ValueError, match=rf"EnvConfig\.{field} must be {allowed}, got {value}"):
        EnvConfig(**{field: value})


def test_camera_values_of_all_cars_are_bounded() -> None:
    # Each field is in range; together 16 cars of 4096 x 4096 stereo with 32 frames asked for 8 GiB of
    # observation bounds before anything failed.
    from h2h_racing.config.sensors import CameraConfig

    camera = CameraConfig(width=4096, height=4096, stereo=True, frame_stack=32)
    with pytest.raises(ValueError, match=r"EnvConfig\.camera must be at most 67108864 camera values a step "
                                         r".*16 \* 4096 \* 4096 \* 2 \* 32 = 17179869184"):
        EnvConfig(num_cars=16, sensors=("camera",), camera=camera)
    EnvConfig(num_cars=16, sensors=("camera",), camera=CameraConfig(frame_stack=32))


# ---------------------------------------------------------------- odd JSON and .npy files (issue 38)

_ACTIONS = '{"action_space": [{"steering_angle": 0, "speed": 1}]}'


@pytest.mark.parametrize(("content", "message"), [
    # Before: a RecursionError traceback.
    (b"[" * 100_000 + b"]" * 100_000, r"nested deeper than 32 levels"),
    ('{"action_space": ' + "[" * 40 + "]" * 40 + "}", r"nested deeper than 32 levels"),
    # Before: UnicodeDecodeError without the file.
    (_ACTIONS.encode("utf-16"), r"must be UTF-8 text \(JSON\), but byte 0 is b'\\xff'"),
    (bytes(range(256)), r"must be UTF-8 text \(JSON\), but byte 128"),
    # Before: int() 's digit limit, without the file.
    ('{"action_space": [{"steering_angle": 0, "speed": ' + "1" * 5000 + "}]}",
     r"holds a number too long to read"),
    # Before: OverflowError from math.isfinite.
    ('{"action_space": [{"steering_angle": 0, "speed": ' + "1" * 400 + "}]}",
     r"action_space\[0\]\.speed must be a finite number, got <an integer of about 400 digits>"),
])
def test_model_metadata_errors_name_the_file(tmp_path, content, message: str) -> None:
    from h2h_racing.deepracer import load_model_metadata

    path = tmp_path / "model_metadata.json"
    path.write_bytes(content.encode() if isinstance(content, str) else content)
    with pytest.raises(ValueError, match=message) as info:
        load_model_metadata(path)
    assert str(info.value).startswith(f"{path}: ")
    assert len(str(info.value)) < 400


@pytest.mark.parametrize("content", ["x".encode("utf-16"), b"[" * 100_000])
def test_track_json_errors_name_the_file(tmp_path, content: bytes) -> None:
    path = tmp_path / "odd.json"
    path.write_bytes(content)
    with pytest.raises(ValueError, match=rf"^{path}: .*(UTF-8|nested deeper)"):
        load_track(path)


def _npy_header_only(path, shape) -> None:
    with path.open("wb") as f:
        np.lib.format.write_array_header_1_0(f, {"descr": "<f8", "fortran_order": False, "shape": shape})


def test_npy_header_claiming_huge_shape(tmp_path) -> None:
    # Before: numpy tried to allocate 4.8 TB and raised its own MemoryError traceback.
    path = tmp_path / "huge.npy"
    _npy_header_only(path, (10**11, 6))
    with pytest.raises(ValueError, match=r"huge\.npy: the header claims 100000000000 rows; a route may "
                                         r"have at most 100000"):
        load_track(path)
    _npy_header_only(path, (1000, 6))
    with pytest.raises(ValueError, match=r"huge\.npy: the header claims 1000 rows .* but the file holds 0 "
                                         r"bytes of data"):
        load_track(path)


@pytest.mark.parametrize(("content", "message"), [
    # Before: a RecursionError traceback, and a UnicodeDecodeError without the file.
    (b"num_envs = " + b"[" * 5000 + b"]" * 5000 + b"\n", r"nested too deep to read"),
    (b"num_envs = " + b"[" * 40 + b"]" * 40 + b"\n", r"nested deeper than 32 levels"),
    ("num_envs = 8\n".encode("utf-16"), r"must be UTF-8 text \(TOML\), but byte 0 is b'\\xff'"),
])
@pytest.mark.parametrize("kind", ["train", "league"])
def test_odd_toml_files_name_the_file(tmp_path, content: bytes, message: str, kind: str) -> None:
    from h2h_racing.league.config import LeagueConfig
    from h2h_racing.training.config import TrainConfig

    path = tmp_path / "c.toml"
    path.write_bytes(content)
    with pytest.raises(ValueError, match=rf"^{path}: .*{message}"):
        (TrainConfig if kind == "train" else LeagueConfig).from_toml(path)


def test_toml_file_size_is_bounded(tmp_path) -> None:
    from h2h_racing.training.config import TrainConfig
    from h2h_racing.training.toml_types import MAX_TOML_BYTES

    path = tmp_path / "big.toml"
    with path.open("wb") as f:
        f.truncate(MAX_TOML_BYTES + 1)  # sparse
    with pytest.raises(ValueError, match=rf"big\.toml: the file is {MAX_TOML_BYTES + 1} bytes; a config "
                                         rf"file may be at most {MAX_TOML_BYTES} bytes"):
        TrainConfig.from_toml(path)
