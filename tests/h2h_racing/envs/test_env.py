"""Tests for :mod:`h2h_racing.envs.parallel`: PettingZoo conformance, determinism, pickling, seat fairness,
input validation, spaces/dtypes/infos and rendering."""

from __future__ import annotations

import json
import math
import pickle
from typing import Any

import numpy as np
import pytest
from pettingzoo.test import api_test, max_cycles_test, parallel_api_test, render_test
from pettingzoo.utils.conversions import parallel_to_aec

import h2h_racing
from h2h_racing.config.env import EnvConfig, RaceRules, RewardConfig
from h2h_racing.policies import make_driver
from h2h_racing.track.io import list_tracks

from conftest import circle_track

DETERMINISM_STEPS = 500
REWARD_TERMS = {"progress", "speed", "off_track", "crash", "contact", "overtake", "lap", "time"}
# The env card's list, written out by hand.
DOCUMENTED_INFO_KEYS = {
    "progress", "distance", "last_lap_time", "best_lap_time", "gap_to_leader", "time",
    "lap", "rank", "overtakes", "overtaken", "defences", "resets", "penalties",
    "frozen", "finished", "off_track", "crashed", "collided", "penalised", "parked",
} | {f"reward_{term}" for term in REWARD_TERMS}


# ---------------------------------------------------------------------- helpers

def assert_tree_equal(a: Any, b: Any, where: str) -> None:
    """Exact, type-strict equality of nested dicts / lists / arrays / scalars (NaN == NaN)."""
    assert type(a) is type(b), f"{where}: type {type(a).__name__} != {type(b).__name__}"
    if isinstance(a, dict):
        assert list(a) == list(b), f"{where}: keys {list(a)} != {list(b)}"
        for k in a:
            assert_tree_equal(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), f"{where}: length {len(a)} != {len(b)}"
        for i, (x, y) in enumerate(zip(a, b)):
            assert_tree_equal(x, y, f"{where}[{i}]")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, f"{where}: {a.dtype}{a.shape} != {b.dtype}{b.shape}"
        assert np.array_equal(a, b, equal_nan=True), f"{where}: arrays differ\n{a}\n{b}"
    elif isinstance(a, float):
        assert a == b or (math.isnan(a) and math.isnan(b)), f"{where}: {a!r} != {b!r}"
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"


class MixedDrivers:
    """Scripted drivers for car 0 (racing line) and car 1 (blocker), seeded random for the rest.

    Acts from ``env.core`` (privileged state), so two envs in the same state get the same actions.
    Every ``period`` steps all cars get a burst of random actions so that they also leave the
    track, get penalised and bump into each other.
    """

    def __init__(self, env: Any, seed: int, period: int = 120) -> None:
        self.env = env
        self.rng = np.random.default_rng(seed)
        self.drivers = [make_driver("racing_line"), make_driver("blocker")]
        self.period = period
        self.count = 0

    def reset(self) -> None:
        for d in self.drivers:
            d.reset(self.env.core)

    def __call__(self) -> dict[str, np.ndarray]:
        core = self.env.core
        self.count += 1
        burst = (self.count % self.period) >= self.period - 25
        out = {}
        for agent in self.env.agents:
            i = int(agent.split("_")[1])
            noise = self.rng.uniform(-1.0, 1.0, 2).astype(np.float32)
            if i < len(self.drivers) and not burst:
                out[agent] = np.asarray(self.drivers[i].act(core, i)[0], dtype=np.float32)
            else:
                out[agent] = noise
        return out


def rollout(env: Any, seed: int | None, steps: int, driver_seed: int = 7) -> list[Any]:
    """Reset with ``seed`` and run ``steps`` steps of MixedDrivers, resetting (unseeded) on done."""
    trace: list[Any] = [env.reset(seed=seed)]
    drivers = MixedDrivers(env, driver_seed)
    drivers.reset()
    for _ in range(steps):
        if not env.agents:
            trace.append(env.reset())
            drivers.reset()
            continue
        trace.append(env.step(drivers()))
    return trace


# ---------------------------------------------------------------------- conformance

class TestPettingZooConformance:
    """The stock PettingZoo test suite on several configurations."""

    CONFIGS = [
        {"num_cars": 1},
        {"num_cars": 3},
        {"num_cars": 2, "action_type": "discrete"},
        {"num_cars": 3, "action_type": "discrete", "race_type": "object_avoidance"},
        {"num_cars": 3, "race_type": "object_avoidance"},
        {"num_cars": 2, "rules": "training"},
    ]

    @pytest.mark.parametrize("kwargs", CONFIGS, ids=lambda k: "-".join(f"{v}" for v in k.values()))
    def test_parallel_api(self, kwargs: dict[str, Any]) -> None:
        parallel_api_test(h2h_racing.parallel_env(track="oval", **kwargs), num_cycles=300)

    @pytest.mark.parametrize("kwargs", CONFIGS, ids=lambda k: "-".join(f"{v}" for v in k.values()))
    def test_aec_api(self, kwargs: dict[str, Any]) -> None:
        api_test(parallel_to_aec(h2h_racing.parallel_env(track="oval", **kwargs)), num_cycles=300)

    def test_max_cycles(self) -> None:
        max_cycles_test(h2h_racing)

    def test_render(self) -> None:
        render_test(lambda render_mode=None: parallel_to_aec(
            h2h_racing.parallel_env(track="oval", render_mode=render_mode)))

    def test_module_factories(self) -> None:
        aec = h2h_racing.env(track="oval", num_cars=2)
        assert aec.possible_agents == ["car_0", "car_1"]
        par = h2h_racing.parallel_env(track="oval", num_cars=2, max_cycles=4)
        assert par.max_cycles == 4
        assert par.metadata["is_parallelizable"] is True

    def test_spaces_are_identical_objects(self, make_env: Any) -> None:
        env = make_env(num_cars=3)
        for a in env.possible_agents:
            assert env.observation_space(a) is env.observation_space(a)
            assert env.action_space(a) is env.action_space(a)

    def test_observation_size_matches_card(self, make_env: Any) -> None:
        # F = 19 + 4 x opponent_slots + 3 x obstacle_slots: defaults 19 + 8 + 6 = 33.
        assert make_env().observation_space("car_0").shape == (33,)
        # 19 + 4*3 + 3*1 = 34.
        env = make_env(opponent_slots=3, obstacle_slots=1)
        assert env.observation_space("car_0").shape == (34,)


# ---------------------------------------------------------------------- determinism

class TestDeterminism:
    """Exact multi-step determinism (replaces PettingZoo's one-step parallel_seed_test)."""

    @pytest.mark.parametrize("kwargs", [
        {"track": "speedway", "num_cars": 3},
        {"track": "oval", "num_cars": 3, "race_type": "object_avoidance",
         "randomize_obstacles": True},
    ], ids=["speedway-3", "oval-objects-3"])
    def test_rollout_is_deterministic(self, kwargs: dict[str, Any]) -> None:
        a = h2h_racing.parallel_env(**kwargs)
        b = h2h_racing.parallel_env(**kwargs)
        ta = rollout(a, 123, DETERMINISM_STEPS)
        tb = rollout(b, 123, DETERMINISM_STEPS)
        contacts = penalties = 0
        for step, (ra, rb) in enumerate(zip(ta, tb)):
            assert_tree_equal(ra, rb, f"[{step}]")
            obs = ra[0]
            for agent, o in obs.items():
                assert a.observation_space(agent).contains(o), f"[{step}] {agent} obs out of space"
            if len(ra) == 5:
                contacts += sum(i["collided"] for i in ra[4].values())
                penalties += sum(i["penalised"] for i in ra[4].values())
        # The rollout must actually exercise contacts and penalties, or it proves little.
        assert contacts > 0 and penalties > 0, (contacts, penalties)

    def test_reset_with_same_seed_replays(self, make_env: Any) -> None:
        env = make_env(track="speedway", num_cars=3)
        first = rollout(env, 99, 200)
        second = rollout(env, 99, 200)
        for step, (x, y) in enumerate(zip(first, second)):
            assert_tree_equal(x, y, f"[{step}]")

    def test_unseeded_reset_continues_deterministically(self, make_env: Any) -> None:
        # Seeded reset then an unseeded one: the second episode depends only on the seed.
        a, b = make_env(num_cars=4), make_env(num_cars=4)
        for env in (a, b):
            env.reset(seed=5)
        for k in range(5):
            oa, ia = a.reset()
            ob, ib = b.reset()
            assert_tree_equal((oa, ia), (ob, ib), f"[unseeded reset {k}]")

    def test_different_seeds_draw_different_grids(self, make_env: Any) -> None:
        env = make_env(num_cars=4, grid="random")
        grids = set()
        for seed in range(8):
            _, infos = env.reset(seed=seed)
            grids.add(tuple(infos[a]["distance"] for a in env.possible_agents))
        # 8 seeds over 4! = 24 permutations: all equal has probability 24^-7.
        assert len(grids) > 1
        # Each grid is a permutation of the slots 0, -0.75, -1.5, -2.25 m.
        for g in grids:
            assert sorted(g) == pytest.approx([-2.25, -1.5, -0.75, 0.0])

    def test_fixed_grid_puts_car_i_in_slot_i(self, make_env: Any) -> None:
        _, infos = make_env(num_cars=3, grid="fixed").reset(seed=3)
        # slot k starts k * 0.75 m behind the line.
        assert [infos[f"car_{k}"]["distance"] for k in range(3)] == [0.0, -0.75, -1.5]

    def test_grid_option_overrides_draw(self, make_env: Any) -> None:
        _, infos = make_env(num_cars=3).reset(seed=3, options={"grid": [2, 0, 1]})
        assert [infos[f"car_{k}"]["distance"] for k in range(3)] == [-1.5, 0.0, -0.75]


# ---------------------------------------------------------------------- pickle

class TestPickle:
    """Pickling mid-race and continuing gives the identical trajectory, later contacts included.

    One documented exception: pymunk cannot pickle the impulses it caches for contacts that are
    ongoing (pymunk issue 181), so a clone made *while two bodies touch* continues validly but
    not bit-for-bit.
    """

    @staticmethod
    def _continue_both(env: Any, clone: Any, actions_fn: Any, steps: int) -> int:
        contacts = 0
        for step in range(steps):
            if not env.agents:
                break
            assert env.agents == clone.agents
            actions = actions_fn()
            ra, rb = env.step(actions), clone.step(actions)
            contacts += sum(i["collided"] for i in ra[4].values())
            assert_tree_equal(ra, rb, f"[{step}]")
        assert_tree_equal(env.results(), clone.results(), "[results]")
        return contacts

    def test_pickle_roundtrip_without_contact(self) -> None:
        # One car alone on the oval: no contact can happen, so only the car state matters.
        env = h2h_racing.parallel_env(track="oval", num_cars=1)
        env.reset(seed=1)
        rng = np.random.default_rng(0)
        for _ in range(30):
            env.step({"car_0": rng.uniform(-1, 1, 2).astype(np.float32)})
        clone = pickle.loads(pickle.dumps(env))
        self._continue_both(env, clone, lambda: {"car_0": rng.uniform(-1, 1, 2).astype(np.float32)},
                            300)

    def test_pickle_then_contact_is_reported(self) -> None:
        env = h2h_racing.parallel_env(track="oval", num_cars=3, grid="fixed")
        env.reset(seed=1)
        drivers = MixedDrivers(env, seed=3, period=40)
        drivers.reset()
        for _ in range(5):
            env.step(drivers())
        clone = pickle.loads(pickle.dumps(env))
        contacts = self._continue_both(env, clone, drivers, 600)
        assert contacts > 0

    def test_pickle_roundtrip_during_contact_continues_validly(self) -> None:
        env = h2h_racing.parallel_env(track="oval", num_cars=3, grid="fixed")
        env.reset(seed=1)
        drivers = MixedDrivers(env, seed=3, period=40)
        drivers.reset()
        for _ in range(2000):
            _, _, _, _, infos = env.step(drivers())
            if any(i["collided"] for i in infos.values()):
                break
        else:
            pytest.fail("no contact happened; the test needs one")
        clone = pickle.loads(pickle.dumps(env))
        assert clone.agents == env.agents
        assert np.array_equal(clone.core.position, env.core.position)
        rng = np.random.default_rng(0)
        for step in range(300):
            if not clone.agents:
                break
            obs, rewards, _, _, _ = clone.step({a: rng.uniform(-1, 1, 2).astype(np.float32)
                                                for a in clone.agents})
            for agent, o in obs.items():
                assert clone.observation_space(agent).contains(o), f"[{step}] {agent}"
            assert all(np.isfinite(r) for r in rewards.values()), f"[{step}]"

    def test_pickle_with_renderer(self) -> None:
        env = h2h_racing.parallel_env(track="oval", num_cars=2, render_mode="rgb_array")
        env.reset(seed=0)
        env.render()
        clone = pickle.loads(pickle.dumps(env))
        assert np.array_equal(env.render(), clone.render())


# ---------------------------------------------------------------------- fairness

def _seat_run(grid: list[int], streams: list[np.ndarray], steps: int, radius: float = 3.0,
              ) -> list[Any]:
    env = h2h_racing.parallel_env(track=circle_track(radius), num_cars=2)
    out = [env.reset(seed=0, options={"grid": grid})]
    for t in range(steps):
        if not env.agents:
            break
        out.append(env.step({a: streams[i][t] for i, a in enumerate(env.possible_agents)
                             if a in env.agents}))
    return out


def _swap(result: Any) -> Any:
    """Swap car_0 and car_1 in every per-agent dict of an env return tuple."""
    return tuple({"car_0": d["car_1"], "car_1": d["car_0"]} for d in result)


class TestSeatFairness:
    """Swapping start slots and action streams swaps the outcomes: no car-index dependence."""

    def test_swap_without_contact_is_exact(self) -> None:
        # Both cars hold their own lane at moderate, equal-ish speeds: no contact, so each car's
        # trajectory depends only on its slot and its action stream, never on its index.
        steps = 150
        rng = np.random.default_rng(4)
        # steer ~ atan(L_wb / R) / 30 deg keeps a car on a 3 m circle: atan(0.164/3) = 3.13 deg
        # -> 0.104; small noise. The car ahead (slot 0) is faster: speed action -0.5 -> 1.375 m/s
        # against -0.7 -> 1.025 m/s behind (speed = 2.25 + 1.75 a), so the gap only grows.
        base = [np.array([0.104, -0.5]), np.array([0.104, -0.7])]
        streams = [(b + rng.uniform(-0.02, 0.02, (steps, 2))).astype(np.float32) for b in base]
        straight = _seat_run([0, 1], streams, steps)
        swapped = _seat_run([1, 0], streams[::-1], steps)
        assert len(straight) == len(swapped)
        for step, (x, y) in enumerate(zip(straight, swapped)):
            if len(x) == 5:
                assert not any(i["collided"] for i in x[4].values()), f"[{step}] contact"
            assert_tree_equal(x, _swap(y), f"[{step}]")

    def test_swap_with_contact_is_exact(self) -> None:
        # The car in slot 1 (0.75 m behind) runs into the car in slot 0 from behind: the contact
        # is resolved by pymunk, whose solver iterates bodies in index order. Fairness requires
        # the same outcome whichever index the car behind has.
        steps = 120
        slow = np.tile(np.array([0.104, -0.9], np.float32), (steps, 1))  # 0.675 m/s ahead
        fast = np.tile(np.array([0.104, 0.3], np.float32), (steps, 1))  # 2.775 m/s behind
        # The car behind (inner lane) swerves right onto the leader's outer lane for 3 steps.
        fast[:3, 0] = -1.0
        straight = _seat_run([0, 1], [slow, fast], steps)
        swapped = _seat_run([1, 0], [fast, slow], steps)
        contacts = sum(i["collided"] for r in straight[1:] for i in r[4].values())
        assert contacts > 0
        for step, (x, y) in enumerate(zip(straight, swapped)):
            assert_tree_equal(x, _swap(y), f"[{step}]")


# ---------------------------------------------------------------------- bad inputs

class TestInputValidation:
    """Every bad input raises the documented error type with a helpful message."""

    def test_step_before_reset(self, make_env: Any) -> None:
        env = make_env()
        with pytest.raises(RuntimeError, match="reset"):
            env.step({"car_0": [0, 0], "car_1": [0, 0]})

    def test_step_after_race_over(self, make_env: Any) -> None:
        env = make_env(max_cycles=3)
        env.reset(seed=0)
        for _ in range(3):
            env.step({a: np.zeros(2, np.float32) for a in env.agents})
        assert env.agents == []
        with pytest.raises(RuntimeError, match="over"):
            env.step({})
        with pytest.raises(RuntimeError, match="over"):
            env.step({"car_0": [0, 0], "car_1": [0, 0]})

    @pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
    def test_non_finite_action_names_agent(self, make_env: Any, bad: float) -> None:
        env = make_env()
        env.reset(seed=0)
        with pytest.raises(ValueError, match=r"finite.*car_1"):
            env.step({"car_0": np.zeros(2), "car_1": np.array([0.0, bad])})

    def test_out_of_range_is_clipped(self, make_env: Any) -> None:
        a, b = make_env(grid="fixed"), make_env(grid="fixed")
        a.reset(seed=0)
        b.reset(seed=0)
        for step in range(30):
            # steer 5.0 == 1.0, speed -7 == -1, and 1e30 == 1.
            ra = a.step({"car_0": np.array([5.0, -7.0]), "car_1": np.array([-1e30, 1e30])})
            rb = b.step({"car_0": np.array([1.0, -1.0]), "car_1": np.array([-1.0, 1.0])})
            assert_tree_equal(ra, rb, f"[{step}]")

    def test_missing_agent_lists_live_agents(self, make_env: Any) -> None:
        env = make_env()
        env.reset(seed=0)
        with pytest.raises(ValueError, match=r"\['car_0', 'car_1'\].*missing \['car_1'\]"):
            env.step({"car_0": np.zeros(2)})

    def test_unknown_agent_lists_live_agents(self, make_env: Any) -> None:
        env = make_env()
        env.reset(seed=0)
        with pytest.raises(ValueError, match=r"\['car_0', 'car_1'\].*unknown agents \['car_7'\]"):
            env.step({"car_0": np.zeros(2), "car_1": np.zeros(2), "car_7": np.zeros(2)})
        with pytest.raises(ValueError, match=r"missing \['car_1'\].*\['car_9'\]"):
            env.step({"car_0": np.zeros(2), "car_9": np.zeros(2)})

    def test_actions_not_a_dict(self, make_env: Any) -> None:
        env = make_env()
        env.reset(seed=0)
        with pytest.raises(ValueError, match="dict"):
            env.step([np.zeros(2), np.zeros(2)])

    @pytest.mark.parametrize("bad", [np.zeros(3), np.zeros((2, 1)), 0.5, [0.1], "ab", [[0, 0], [0, 0]]])
    def test_wrong_shape(self, make_env: Any, bad: Any) -> None:
        env = make_env()
        env.reset(seed=0)
        with pytest.raises(ValueError, match=r"\(2,\)|2 numbers"):
            env.step({"car_0": np.zeros(2), "car_1": bad})

    @pytest.mark.parametrize("bad", [
        np.array(["0.5", "1"]), ["0.5", "1"], np.array([0.5 + 0j, 1]),
        np.array(["2020-01-01", "2020-01-02"], dtype="datetime64[D]"),
        np.ma.masked_array([0.1, 0.2], mask=[True, False]), np.array([True, False]), [True, 0.5]])
    def test_non_real_dtypes_are_refused(self, make_env: Any, bad: Any) -> None:
        # Before (issue 38): numpy turned each of these into floats without a word (a masked
        # value's hidden data, a complex number's real part, a date's day count).
        env = make_env()
        env.reset(seed=0)
        with pytest.raises(ValueError, match=r"action of car_1 must be 2 numbers \[steer, speed\] \(real"):
            env.step({"car_0": np.zeros(2), "car_1": bad})

    @pytest.mark.parametrize("bad", [-1, True, [1, 2], 1.5, "3", np.bool_(True)])
    def test_bad_seed_is_refused(self, make_env: Any, bad: Any) -> None:
        # Before (issue 38): numpy's own message for -1, and True or [1, 2] were accepted.
        env = make_env()
        with pytest.raises(ValueError, match=r"reset\(seed=\.\.\.\) must be None or an int >= 0, got "):
            env.reset(seed=bad)
        env.reset(seed=np.int64(3))

    @pytest.mark.parametrize("bad", [15, -1, 2.5, math.nan, True, np.bool_(False), [1],
                                     np.array([1, 2]), None])
    def test_discrete_bad_index(self, make_env: Any, bad: Any) -> None:
        env = make_env(action_type="discrete")
        env.reset(seed=0)
        # 15 default actions: valid indices 0..14.
        with pytest.raises(ValueError, match=r"car_1.*\[0, 14\]"):
            env.step({"car_0": 0, "car_1": bad})

    def test_discrete_string_index_rejected(self, make_env: Any) -> None:
        env = make_env(action_type="discrete")
        env.reset(seed=0)
        with pytest.raises(ValueError, match=r"car_1.*\[0, 14\]"):
            env.step({"car_0": 0, "car_1": "3"})

    @pytest.mark.parametrize("good", [0, 14, np.int64(7), np.int32(3)])
    def test_discrete_good_index(self, make_env: Any, good: Any) -> None:
        env = make_env(action_type="discrete")
        env.reset(seed=0)
        env.step({"car_0": 0, "car_1": good})

    def test_discrete_action_maps_to_table(self) -> None:
        # Action 13 of the default table = (steer 30 deg, 2 m/s): index = 5 steers x 3 speeds,
        # 13 = 4 * 3 + 1. A custom table with the same entry must give the same trajectory.
        a = h2h_racing.parallel_env(track="oval", num_cars=1, action_type="discrete")
        b = h2h_racing.parallel_env(track="oval", num_cars=1, action_type="discrete",
                                    discrete_actions=((0.0, 1.0), (30.0, 2.0)))
        a.reset(seed=0)
        b.reset(seed=0)
        for step in range(20):
            assert_tree_equal(a.step({"car_0": 13}), b.step({"car_0": 1}), f"[{step}]")

    def test_unknown_track_lists_catalogue(self) -> None:
        with pytest.raises(ValueError, match="nowhere_ring") as info:
            h2h_racing.parallel_env(track="nowhere_ring")
        for name in list_tracks():
            assert name in str(info.value)

    def test_bad_track_file_names_file(self, tmp_path: Any) -> None:
        path = tmp_path / "broken.json"
        path.write_text(json.dumps({"centre": [[0, 0], [1, 0]], "width": "wide"}))
        with pytest.raises(ValueError, match="broken.json"):
            h2h_racing.parallel_env(track=str(path))
        garbage = tmp_path / "garbage.json"
        garbage.write_text("{not json")
        with pytest.raises(ValueError, match="garbage.json"):
            h2h_racing.parallel_env(track=str(garbage))

    def test_missing_track_file(self, tmp_path: Any) -> None:
        with pytest.raises(FileNotFoundError, match="absent.json"):
            h2h_racing.parallel_env(track=str(tmp_path / "absent.json"))

    @pytest.mark.parametrize(("kwargs", "field"), [
        ({"num_cars": 0}, "num_cars"),
        ({"num_cars": 17}, "num_cars"),
        ({"race_type": "drag"}, "race_type"),
        ({"action_type": "hybrid"}, "action_type"),
        ({"min_speed": 3.0, "max_speed": 2.0}, "min_speed/max_speed"),
        ({"max_speed": 9.0}, "min_speed/max_speed"),
        ({"step_dt": 0.0}, "step_dt"),
        ({"step_dt": math.nan}, "step_dt"),
        ({"grid": "reverse"}, "grid"),
        ({"physics_substeps": 0}, "physics_substeps"),
        ({"max_cycles": 0}, "max_cycles"),
        ({"num_obstacles": -1}, "num_obstacles"),
        ({"obstacle_positions": ((1.5, 1),)}, "obstacle_positions[0]"),
        ({"discrete_actions": ((0.0, math.inf),)}, "discrete_actions[0]"),
        ({"grid_spacing": -0.1}, "grid_spacing"),
    ])
    def test_bad_config_names_field(self, kwargs: dict[str, Any], field: str) -> None:
        with pytest.raises(ValueError, match=f"EnvConfig.{field}".replace("[", r"\[").replace("]", r"\]")):
            h2h_racing.parallel_env(track="oval", **kwargs)

    @pytest.mark.parametrize(("kwargs", "field"), [
        ({"laps": -1}, "laps"),
        ({"time_limit": 0.0}, "time_limit"),
        ({"mode": "practice"}, "mode"),
        ({"off_track_penalty": -1.0}, "off_track_penalty"),
        ({"reversed_steps": 0}, "reversed_steps"),
    ])
    def test_bad_rules_name_field(self, kwargs: dict[str, Any], field: str) -> None:
        with pytest.raises(ValueError, match=f"RaceRules.{field}"):
            RaceRules(**kwargs)

    def test_bad_reward_weight(self) -> None:
        with pytest.raises(ValueError, match="RewardConfig.progress"):
            RewardConfig(progress=math.nan)

    def test_bad_rules_string(self) -> None:
        with pytest.raises(ValueError, match="rules"):
            h2h_racing.parallel_env(track="oval", rules="practice")
        with pytest.raises(ValueError, match="rules"):
            h2h_racing.parallel_env(track="oval", rules=3)

    def test_bad_render_mode(self) -> None:
        with pytest.raises(ValueError, match="render_mode"):
            h2h_racing.parallel_env(track="oval", render_mode="ansi")

    def test_unknown_kwarg_is_type_error(self) -> None:
        with pytest.raises(TypeError, match=r"\['num_laps'\].*num_cars"):
            h2h_racing.parallel_env(track="oval", num_laps=3)

    def test_config_and_overrides_conflict(self) -> None:
        with pytest.raises(TypeError, match="config"):
            h2h_racing.parallel_env(track="oval", config=EnvConfig(track="oval"), num_obstacles=2)

    def test_bad_max_cycles_attribute(self, make_env: Any) -> None:
        env = make_env()
        with pytest.raises(ValueError, match="max_cycles"):
            env.max_cycles = 0

    def test_bad_grid_option(self, make_env: Any) -> None:
        env = make_env(num_cars=3)
        with pytest.raises(ValueError, match="grid"):
            env.reset(seed=0, options={"grid": [0, 1]})
        with pytest.raises(ValueError, match="permutation"):
            env.reset(seed=0, options={"grid": [0, 0, 1]})


# ---------------------------------------------------------------------- spaces, types, infos

class TestReturnsAndInfos:
    """Observations in their space with the right dtype, Python types, documented infos."""

    @pytest.mark.parametrize("kwargs", [
        {"num_cars": 3},
        {"num_cars": 4, "race_type": "object_avoidance", "action_type": "discrete"},
    ])
    def test_types_every_step(self, make_env: Any, kwargs: dict[str, Any]) -> None:
        env = make_env(**kwargs)
        obs, infos = env.reset(seed=2)
        drivers = MixedDrivers(env, seed=2, period=60)
        drivers.reset()
        rng = np.random.default_rng(2)
        for step in range(400):
            for agent, o in obs.items():
                space = env.observation_space(agent)
                assert o.dtype == np.float32 and space.contains(o), f"[{step}] {agent}"
            if not env.agents:
                break
            if kwargs.get("action_type") == "discrete":
                actions = {a: int(rng.integers(15)) for a in env.agents}
            else:
                actions = drivers()
            obs, rew, term, trunc, infos = env.step(actions)
            for agent in actions:
                assert type(rew[agent]) is float, f"[{step}] reward {type(rew[agent])}"
                assert type(term[agent]) is bool and type(trunc[agent]) is bool, f"[{step}]"
                info = infos[agent]
                assert set(info) == DOCUMENTED_INFO_KEYS, f"[{step}] {set(info)}"
                total = sum(info[f"reward_{term}"] for term in REWARD_TERMS)
                assert rew[agent] == pytest.approx(total, abs=1e-9), f"[{step}] {agent}"

    def test_documented_info_keys_present(self, make_env: Any) -> None:
        env = make_env()
        _, infos = env.reset(seed=0)
        assert set(infos["car_0"]) == DOCUMENTED_INFO_KEYS
        _, _, _, _, infos = env.step({a: np.zeros(2, np.float32) for a in env.agents})
        assert set(infos["car_0"]) == DOCUMENTED_INFO_KEYS

    def test_reward_weights_scale_terms(self, make_env: Any) -> None:
        # progress weight 2, time weight -0.1: reward = 2 * progress_m - 0.1 per racing step.
        env = make_env(num_cars=1, reward=RewardConfig(progress=2.0, time=-0.1))
        env.reset(seed=0)
        ref = make_env(num_cars=1)
        ref.reset(seed=0)
        for step in range(20):
            _, r, _, _, info = env.step({"car_0": np.array([0.0, 0.0], np.float32)})
            _, r0, _, _, info0 = ref.step({"car_0": np.array([0.0, 0.0], np.float32)})
            progress = info0["car_0"]["reward_progress"]
            assert info["car_0"]["reward_progress"] == 2.0 * progress, f"[{step}]"
            assert info["car_0"]["reward_time"] == -0.1, f"[{step}]"
            assert r["car_0"] == pytest.approx(2.0 * progress - 0.1, abs=1e-12), f"[{step}]"

    def test_reset_infos_are_zero(self, make_env: Any) -> None:
        _, infos = make_env(num_cars=2).reset(seed=0)
        for info in infos.values():
            assert info["time"] == 0.0 and info["lap"] == 0 and info["progress"] == 0.0
            # No lap yet: the documented finite -1.0, not inf.
            assert info["last_lap_time"] == -1.0 and info["best_lap_time"] == -1.0
            assert all(info[f"reward_{term}"] == 0.0 for term in REWARD_TERMS)

    def test_agents_removed_on_termination(self, make_env: Any) -> None:
        # Training rules end a car at its first infraction; full lock at top speed on the oval
        # leaves the track within a couple of seconds.
        env = make_env(num_cars=2, rules="training")
        env.reset(seed=0)
        for step in range(300):
            live = list(env.agents)
            _, _, term, trunc, _ = env.step({a: np.array([1.0, 1.0], np.float32) for a in live})
            assert set(term) == set(live)
            for a in live:
                assert (a in env.agents) == (not (term[a] or trunc[a])), f"[{step}] {a}"
            if not env.agents:
                break
        assert env.agents == []


# ---------------------------------------------------------------------- render

class TestRender:
    """rgb_array frames, and the renderer never feeds back into observations."""

    def test_rgb_array_frame(self, make_env: Any) -> None:
        env = make_env(render_mode="rgb_array")
        env.reset(seed=0)
        frame = env.render()
        assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
        env.step({a: np.array([0.0, 1.0], np.float32) for a in env.agents})
        frame2 = env.render()
        assert frame2.shape == frame.shape
        assert not np.array_equal(frame, frame2), "the frame does not change when cars move"
        env.close()

    def test_no_render_mode_returns_none(self, make_env: Any) -> None:
        env = make_env()
        env.reset(seed=0)
        assert env.render() is None

    def test_human_mode_explains(self, make_env: Any) -> None:
        env = make_env(render_mode="human")
        env.reset(seed=0)
        with pytest.raises(RuntimeError, match="rgb_array"):
            env.render()

    def test_observations_independent_of_rendering(self, make_env: Any) -> None:
        plain = make_env(num_cars=3, race_type="object_avoidance")
        drawn = make_env(num_cars=3, race_type="object_avoidance", render_mode="rgb_array")
        rp, rd = plain.reset(seed=8), drawn.reset(seed=8)
        assert_tree_equal(rp, rd, "[reset]")
        rng = np.random.default_rng(8)
        for step in range(120):
            if not plain.agents:
                break
            drawn.render()
            actions = {a: rng.uniform(-1, 1, 2).astype(np.float32) for a in plain.agents}
            assert_tree_equal(plain.step(actions), drawn.step(actions), f"[{step}]")


# ---------------------------------------------------------------------- trainers' conventions

def _drive_racing_line(env: Any, steps: int) -> list[Any]:
    """Run the racing-line driver for every racing car; return the step results."""
    drivers = [make_driver("racing_line") for _ in env.possible_agents]
    for d in drivers:
        d.reset(env.core)
    out = []
    for _ in range(steps):
        if not env.agents:
            break
        actions = {a: np.asarray(drivers[i].act(env.core, i)[0], dtype=np.float32)
                   for i, a in enumerate(env.possible_agents) if a in env.agents}
        out.append(env.step(actions))
    return out


class TestTrainerConventions:
    """Flat infos, ignored actions of departed cars, parked agents, sensors as a list."""

    def test_infos_flat_fixed_and_finite_through_laps(self) -> None:
        env = h2h_racing.parallel_env(track=circle_track(), num_cars=1)
        _, infos = env.reset(seed=0)
        kinds = {k: type(v) for k, v in infos["car_0"].items()}
        assert set(kinds) == DOCUMENTED_INFO_KEYS
        assert set(kinds.values()) <= {float, int, bool}
        laps_seen = []
        for _, _, _, _, step_infos in _drive_racing_line(env, 400):
            info = step_infos["car_0"]
            assert {k: type(v) for k, v in info.items()} == kinds
            assert all(math.isfinite(v) for v in info.values())
            if info["lap"] == 0:
                assert info["last_lap_time"] == -1.0 and info["best_lap_time"] == -1.0
            laps_seen.append((info["lap"], info["last_lap_time"], info["time"]))
        lapped = [row for row in laps_seen if row[0] >= 1]
        assert lapped, "the racing line never completed a lap of the 3 m circle"
        # The first lap's time: positive, at most the time on the clock when it was counted.
        lap, last, time = lapped[0]
        assert 0.0 < last <= time

    def test_full_info_level_adds_the_structures(self) -> None:
        env = h2h_racing.parallel_env(track=circle_track(), num_cars=1, info_level="full")
        _, infos = env.reset(seed=0)
        assert infos["car_0"]["lap_times"] == [] and set(infos["car_0"]) > DOCUMENTED_INFO_KEYS
        results = _drive_racing_line(env, 400)
        info = results[-1][4]["car_0"]
        assert info["lap_times"] == list(env.core.lap_times[0][0]) and info["lap"] >= 1
        assert info["last_lap_time"] == info["lap_times"][-1]
        assert info["reward_terms"] == {t: info[f"reward_{t}"] for t in REWARD_TERMS}

    def test_info_level_checked(self) -> None:
        with pytest.raises(ValueError, match=r"info_level.*'flat', 'full'.*'rich'"):
            h2h_racing.parallel_env(info_level="rich")

    def test_actions_of_departed_cars_are_ignored(self, make_env: Any) -> None:
        # Training rules: full lock at top speed takes both cars off the oval, car_1 first
        # when car_0 drives straight at low speed.
        env = make_env(rules="training", grid="fixed")
        ref = make_env(rules="training", grid="fixed")
        env.reset(seed=0)
        ref.reset(seed=0)
        slow = np.array([0.0, -1.0], np.float32)
        wild = np.array([1.0, 1.0], np.float32)
        for _ in range(300):
            if env.agents != ["car_0"]:
                assert "car_1" in env.agents, "car_0 left the race before car_1"
                env.step({"car_0": slow, "car_1": wild})
                ref.step({"car_0": slow, "car_1": wild})
        assert env.agents == ["car_0"]
        # A trainer keeps sending car_1's action: ignored, the race goes on as without it.
        for step in range(5):
            got = env.step({"car_0": slow, "car_1": wild})
            want = ref.step({"car_0": slow})
            assert_tree_equal(got, want, f"[{step}]")
        with pytest.raises(ValueError, match=r"unknown agents \['car_7'\]"):
            env.step({"car_0": slow, "car_1": wild, "car_7": slow})
        with pytest.raises(ValueError, match=r"missing \['car_0'\]"):
            env.step({"car_1": wild})
        with pytest.raises(ValueError, match=r"finite.*car_0"):
            env.step({"car_0": np.array([np.nan, 0.0]), "car_1": wild})

    def test_sensors_as_a_list(self, make_env: Any) -> None:
        env = make_env(sensors=["camera", "lidar", "state"])
        assert env.config.sensors == ("camera", "lidar", "state")
        obs, _ = env.reset(seed=0)
        assert list(obs["car_0"]) == ["camera", "lidar", "state"]
        assert env.observation_space("car_0").contains(obs["car_0"])
        with pytest.raises(ValueError, match=r"sensors.*\('state', 'camera', 'lidar'\)"):
            make_env(sensors=["state", "radar"])

    def test_parked_agents_stay_until_the_race_ends(self, make_env: Any) -> None:
        # car_1 retires (training rules, full lock) long before the time limit stops car_0
        # (which, driving straight and slowly, would leave the oval after about 100 steps).
        parked = make_env(rules="training", grid="fixed", max_cycles=60, parked_agents=True)
        plain = make_env(rules="training", grid="fixed", max_cycles=60)
        parked.reset(seed=0)
        plain.reset(seed=0)
        slow = np.array([0.0, -1.0], np.float32)
        wild = np.array([1.0, 1.0], np.float32)
        retired_at = None
        for step in range(60):
            assert parked.agents == ["car_0", "car_1"], f"[{step}]"
            obs, rew, term, trunc, infos = parked.step({"car_0": slow, "car_1": wild})
            ref = plain.step({a: {"car_0": slow, "car_1": wild}[a] for a in plain.agents})
            # The racing car's results are those of the plain env.
            assert_tree_equal([r["car_0"] for r in (obs, rew, infos)],
                              [r["car_0"] for r in (ref[0], ref[1], ref[4])], f"[{step}]")
            if retired_at is None and "car_1" not in plain.agents:
                retired_at = step
                assert rew["car_1"] == ref[1]["car_1"] and infos["car_1"]["parked"]
            elif retired_at is not None and parked.agents:
                assert rew["car_1"] == 0.0 and infos["car_1"]["parked"], f"[{step}]"
                assert obs["car_1"] in parked.observation_space("car_1")
            if not parked.agents:
                break
            assert not any(term.values()) and not any(trunc.values()), f"[{step}]"
        assert retired_at is not None and retired_at < 50
        assert step == 59 and parked.agents == []
        # The race ends: car_1 retired (terminated), car_0 was stopped (truncated).
        assert term == {"car_0": False, "car_1": True}
        assert trunc == {"car_0": True, "car_1": False}

    def test_parked_agents_pass_pettingzoo_api(self, make_env: Any) -> None:
        env = make_env(rules="training", parked_agents=True)
        parallel_api_test(env, num_cycles=300)
        api_test(parallel_to_aec(make_env(rules="training", parked_agents=True)), num_cycles=300)

    def test_rewards_and_terms_match_the_reward_module(self, make_env: Any) -> None:
        # The env computes rewards and info terms in one compiled call; rewards.reward_terms
        # (what the batched VecEnv uses) is the reference.
        from h2h_racing.sim import rewards

        env = make_env(num_cars=3, reward=RewardConfig(speed=0.1, time=-0.01, contact=-1.0))
        env.reset(seed=3)
        weights = rewards.weights_of(env.config.reward)
        drivers = MixedDrivers(env, seed=5, period=40)
        drivers.reset()
        for step in range(200):
            if not env.agents:
                break
            racing = env.core.racing.copy()
            _, rew, _, _, infos = env.step(drivers())
            terms, reward = rewards.reward_terms(weights, env.last_events, env.core.speed, racing)
            for agent in rew:
                i = env.possible_agents.index(agent)
                assert rew[agent] == reward[0, i], f"[{step}] {agent}"
                got = [infos[agent][f"reward_{t}"] for t in rewards.TERMS]
                assert got == terms[:, 0, i].tolist(), f"[{step}] {agent}"
