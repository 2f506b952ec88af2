"""Training runs end in policy files that load safely and drive like the trained actor."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import torch
from tensordict import TensorDict

import h2h_racing
from h2h_racing.training.config import TrainConfig
from h2h_racing.training.imitation import ImitationConfig
from h2h_racing.training.tracks import ProceduralTracks
from h2h_racing.training.train import train
from h2h_racing.policies import make_driver
from h2h_racing.policies.trained import TrainedPolicy, shipped_policies
from h2h_racing.sensors.state import state_observation
from h2h_racing.track.io import list_tracks, load_track

SMALL = TrainConfig(track="oval", num_envs=8, num_steps_per_env=8, hidden_dims=(16, 16))

# pytest's deprecations of how fixtures are written fail here, not in pytest 10.
pytestmark = pytest.mark.filterwarnings("error::pytest.PytestRemovedIn10Warning")


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    out = tmp_path_factory.mktemp("run")
    runner = train(SMALL, iterations=2, out=out)
    return out / "policy.pt", runner


class TestPolicyFile:
    """policy.pt loads with weights_only=True and carries its configs."""

    def test_loads_with_weights_only(self, trained: tuple[Path, object]) -> None:
        payload = torch.load(trained[0], weights_only=True)
        assert payload["format"] == "h2h-racing-policy/1"
        assert payload["env_config"]["track"] == "oval"
        assert payload["training"]["iterations"] == 2

    def test_reloaded_policy_acts_like_the_trained_actor(
            self, trained: tuple[Path, object]) -> None:
        # The file's driver acts in numpy float32 (policies/trained_numpy.py), torch's actor
        # through MKL: the same sums in another order, within a few float32 ulps of 1
        # (tests/policies/test_trained_numpy.py allows 8; a wrong weight or layer is off by
        # orders of magnitude more).
        path, runner = trained
        env = h2h_racing.parallel_env(track="oval", num_cars=1, race_type="time_trial")
        env.reset(seed=4)
        for _ in range(10):
            env.step({"car_0": np.array([0.1, 0.2], np.float32)})
        policy = make_driver(str(path))
        policy.reset(env.core)
        obs = torch.from_numpy(np.ascontiguousarray(state_observation(env.core)[:, 0]))
        actor = runner.alg.actor
        actor.eval()
        with torch.inference_mode():
            expected = actor(TensorDict({"policy": obs}, batch_size=[1])).numpy()
        np.testing.assert_allclose(policy.act(env.core, 0), np.clip(expected, -1, 1), rtol=0,
                                   atol=8 * np.finfo(np.float32).eps)

    def test_observation_mismatch_is_a_clear_error(self, trained: tuple[Path, object]) -> None:
        env = h2h_racing.parallel_env(track="oval", num_cars=2, opponent_slots=3)
        env.reset(seed=0)
        with pytest.raises(ValueError, match="opponent_slots=2"):
            TrainedPolicy(trained[0]).reset(env.core)

    def test_not_a_policy_file(self, tmp_path: Path) -> None:
        bad = tmp_path / "x.pt"
        torch.save({"hello": 1}, bad)
        with pytest.raises(ValueError, match="not an h2h-racing policy"):
            TrainedPolicy(bad)

    def test_trained_policy_races_in_the_env(self, trained: tuple[Path, object]) -> None:
        from h2h_racing.match import run_race

        result = run_race("oval", [str(trained[0]), "pure_pursuit"], laps=1, seed=0,
                          max_cycles=150)
        assert {row["agent"] for row in result.rows} == {"car_0", "car_1"}


EVAL_CONFIG = dataclasses.replace(SMALL, num_cars=2, learners=1, opponent="pure_pursuit",
                                  eval_every=1, eval_episodes=2, eval_race_seconds=3.0)


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A run of EVAL_CONFIG (an evaluation after each of its 2 iterations). A module-scoped
    function, not a class-scoped method: pytest 9 deprecates those (PytestRemovedIn10Warning,
    an error in this module)."""
    out = tmp_path_factory.mktemp("eval_run")
    train(EVAL_CONFIG, iterations=2, out=out)
    return out


class TestEvaluationDuringTraining:
    """Every eval_every iterations: Eval/ figures in the tensorboard log and a race recording."""

    def test_each_evaluation_records_a_race_of_the_learner_and_its_opponent(
            self, run: Path) -> None:
        rr = pytest.importorskip("rerun")
        assert sorted(p.name for p in (run / "eval").iterdir()) == ["iter_1.rrd", "iter_2.rrd"]
        path = run / "eval" / "iter_2.rrd"
        paths = set(map(str, rr.chunk.RrdReader(path).store().schema().entity_paths()))
        assert {"/map/cars/car_0/box", "/map/cars/car_1/box", "/events"} <= paths
        texts = [text for chunk in rr.chunk.RrdReader(path).stream()
                 if chunk.entity_path == "/events" and not chunk.is_static
                 for text in chunk.to_record_batch().column("TextLog:text").to_pylist()]
        results = next(t[0] for t in texts if t[0].startswith("[results]"))
        # The results table names car 0 after the evaluated iteration, car 1 its opponent.
        assert "car_0 (iter_2)" in results and "car_1 (pure_pursuit)" in results

    def test_figures_in_the_log_match_an_evaluation_of_the_saved_policy(
            self, run: Path) -> None:
        pytest.importorskip("tensorboard")
        from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

        from h2h_racing.training.evaluate import evaluate

        log = EventAccumulator(str(run))
        log.Reload()
        scalars = {tag: {e.step: e.value for e in log.Scalars(tag)}
                   for tag in log.Tags()["scalars"] if tag.startswith("Eval/")}
        for tag in ("lap_completion", "off_tracks", "collisions", "race_finished",
                    "race_position"):
            assert sorted(scalars[f"Eval/{tag}"]) == [1, 2], tag
        # The evaluation after iteration 2 drove the final actor, which policy.pt holds: the
        # same attempts (same start points and seed) give the same figures.
        final = evaluate(str(run / "policy.pt"), "oval", episodes=2, seed=SMALL.seed)
        assert scalars["Eval/lap_completion"][2] == pytest.approx(final.lap_completion)
        assert scalars["Eval/off_tracks"][2] == final.off_tracks
        assert scalars["Eval/collisions"][2] == final.collisions
        assert scalars["Eval/race_position"][2] in (1.0, 2.0)

    def test_no_evaluation_before_eval_every_iterations(
            self, trained: tuple[Path, object]) -> None:
        # SMALL evaluates every 50 iterations and trained 2.
        assert not (trained[0].parent / "eval").exists()

    def test_bad_eval_settings_rejected(self) -> None:
        with pytest.raises(ValueError, match="eval_every must be an int >= 0"):
            TrainConfig(eval_every=-1)
        with pytest.raises(ValueError, match="eval_episodes"):
            TrainConfig(eval_episodes=0)


class TestConfig:
    """TrainConfig gives a fresh rsl-rl dict each time (rsl-rl mutates the one it gets)."""

    def test_fresh_dict_every_call(self) -> None:
        a, b = SMALL.rsl_rl_dict(), SMALL.rsl_rl_dict()
        assert a == b and a is not b and a["actor"] is not b["actor"]

    def test_camera_config_uses_cnn(self) -> None:
        cfg = dataclasses.replace(SMALL, observations="camera").rsl_rl_dict()
        assert cfg["actor"]["class_name"] == "CNNModel"
        assert cfg["obs_groups"]["actor"] == ["policy", "camera"]

    def test_bad_values_rejected(self) -> None:
        with pytest.raises(ValueError, match="observations"):
            TrainConfig(observations="lidar")

    def test_several_opponents_share_the_copies(self) -> None:
        from h2h_racing.training.vec_env import PoolOpponent

        config = dataclasses.replace(SMALL, num_cars=2, learners=1, num_envs=5,
                                     opponent="pure_pursuit, blocker")
        env = config.make_env()
        assert isinstance(env.opponent, PoolOpponent)
        # Copy e races opponent e mod 2: pure_pursuit, blocker, pure_pursuit, ...
        names = [env.opponent.names[k] for k in env.opponent.assignment]
        assert names == ["pure_pursuit", "blocker", "pure_pursuit", "blocker", "pure_pursuit"]
        assert config.opponents() == ["pure_pursuit", "blocker"]

    def test_from_toml_fills_nested_tables(self, tmp_path: Path) -> None:
        path = tmp_path / "train.toml"
        path.write_text('track = "procedural"\nnum_envs = 64\nhidden_dims = [64, 64]\n'
                        '[imitation]\nteacher = "racing_line"\n'
                        '[procedural]\nlength = [15.0, 30.0]\n'
                        '[distill]\nlearning_rate = 0.0003\n[reward]\ncrash = -10.0\n'
                        '[ppo]\ngamma = 0.99\n')
        config = TrainConfig.from_toml(path)
        assert config.track == "procedural" and config.scripted_teacher
        assert config.procedural.length == (15.0, 30.0) and config.hidden_dims == (64, 64)
        assert config.procedural.every == 10
        assert config.distill.learning_rate == 0.0003 and config.distill.num_learning_epochs == 1
        assert config.reward.crash == -10.0 and config.reward.progress == 1.0
        assert config.ppo.gamma == 0.99

    def test_flat_keys_name_their_table_and_removed_options_say_why(self, tmp_path: Path) -> None:
        path = tmp_path / "train.toml"
        path.write_text('track = "procedural"\ntrack_every = 2\nprocedural_tight_share = 0.3\n')
        with pytest.raises(ValueError) as err:
            TrainConfig.from_toml(path)
        assert str(err.value) == (f"{path}: procedural_tight_share, track_every moved into "
                                  "tables: procedural_tight_share is now [procedural] "
                                  "tight_share; track_every is now [procedural] every")
        path.write_text('track = "procedural"\nvalidation_tracks = 4\n')
        with pytest.raises(ValueError, match="validation_tracks was removed: held-out"):
            TrainConfig.from_toml(path)
        path.write_text('[procedural]\nevery = 0\n')
        with pytest.raises(ValueError, match=rf"^{path}: \[procedural\] every must be an "
                                             r"integer >= 1"):
            TrainConfig.from_toml(path)

    def test_from_dict_refuses_unknown_keys_and_bad_values(self) -> None:
        with pytest.raises(ValueError, match=r"x.toml: unknown keys \['tracks'\]; allowed"):
            TrainConfig.from_dict({"tracks": "oval"}, source="x.toml")
        with pytest.raises(ValueError, match=r"\[reward\] unknown keys \['grip'\]"):
            TrainConfig.from_dict({"reward": {"grip": 1.0}})
        with pytest.raises(ValueError, match="'ppo' must be a table"):
            TrainConfig.from_dict({"ppo": 3})
        with pytest.raises(ValueError, match="x.toml: TrainConfig.observations must be one of"):
            TrainConfig.from_dict({"observations": "lidar"}, source="x.toml")


class TestCommands:
    """``h2h-racing train`` and ``h2h-racing evaluate`` from the command line."""

    def test_train_then_evaluate(self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        from h2h_racing.cli.command import main

        out = tmp_path / "run"
        assert main(["train", "--track", "oval", "--iterations", "3", "--envs", "8",
                     "--eval-every", "1", "--out", str(out)]) == 0
        assert (out / "policy.pt").is_file() and (out / "policy.onnx").is_file()
        assert sorted(p.name for p in (out / "eval").iterdir()) == [
            "iter_1.rrd", "iter_2.rrd", "iter_3.rrd"]
        # One tensorboard event file for the run, though learn() ran once per evaluation
        # (each call would open a new one).
        assert len(list(out.glob("events.out.tfevents.*"))) == 1
        # rsl-rl saves model_0 (save_interval 50) and a checkpoint at the end of each learn()
        # call (model_0, model_1, model_2): the run keeps model_0 and its latest, model_2.
        assert sorted(p.name for p in out.glob("model_*.pt")) == ["model_0.pt", "model_2.pt"]
        capsys.readouterr()
        assert main(["evaluate", "--policy", str(out / "policy.pt"), "--track", "oval",
                     "--episodes", "3"]) == 0
        table = capsys.readouterr().out
        # One line for the policy (named by the path it was given, so that two runs' policies
        # never share a label) and one for the racing-line baseline.
        rows = [line.split()[0] for line in table.splitlines()[2:]]
        assert rows == [str(out / "policy.pt"), "racing_line"]


class TestInit:
    """TrainConfig.init starts the actor from a policy file (fine-tuning)."""

    def test_actor_starts_with_the_policy_weights(self, trained: tuple[Path, object]) -> None:
        runner = train(dataclasses.replace(SMALL, init=str(trained[0]), seed=5), iterations=0)
        saved = torch.load(trained[0], weights_only=True)["actor_state_dict"]
        actor = runner.alg.get_policy().state_dict()
        assert all(torch.equal(saved[k], actor[k]) for k in saved)

    def test_actor_of_another_size_is_a_clear_error(self, trained: tuple[Path, object]) -> None:
        config = dataclasses.replace(SMALL, init=str(trained[0]), hidden_dims=(32, 32))
        with pytest.raises(ValueError, match="does not fit the actor being trained"):
            train(config, iterations=0)


class TestImitationPPO:
    """[imitation] coef: PPO plus a behaviour-cloning step towards a scripted
    driver (the env's expert group)."""

    CONFIG = dataclasses.replace(SMALL, imitation=ImitationConfig(driver="racing_line", coef=5.0))

    def test_config_picks_the_algorithm_and_the_expert(self) -> None:
        algorithm = self.CONFIG.rsl_rl_dict()["algorithm"]
        assert algorithm["class_name"] == "h2h_racing.training.ppo:ImitationPPO"
        assert algorithm["imitation_coef"] == 5.0
        assert self.CONFIG.make_env().expert.name == "racing_line"
        # Without the term: PPO (or BoundedStdPPO with max_std), and no expert group.
        assert SMALL.rsl_rl_dict()["algorithm"]["class_name"] == "PPO"
        assert "expert" not in SMALL.make_env().get_observations().keys()

    def test_imitation_step_brings_the_actor_towards_the_driver(self) -> None:
        runner = train(self.CONFIG, iterations=1)
        alg = runner.alg
        obs = alg.storage.observations.flatten(0, 1)

        def error() -> float:
            with torch.inference_mode():
                return float((alg.get_policy()(obs) - obs["expert"]).pow(2).mean())

        # The step uses PPO's optimizer at PPO's learning rate, which the KL schedule of this
        # tiny run has adapted down (to ~4e-5); set it back to 1e-3. Each pass is then 4 Adam
        # steps of ~1e-3 on the squared error over the same rollout: after 25 passes the
        # error to the racing line's actions must have fallen by half.
        for group in alg.optimizer.param_groups:
            group["lr"] = 1e-3
        before = error()
        losses = [alg.imitate() for _ in range(25)]
        assert error() < 0.5 * before
        assert losses[-1] < losses[0]

    def test_a_zero_weight_leaves_the_actor_alone(self) -> None:
        # A term set to 0 on a running learner: even a zero loss would move the weights
        # through Adam's momentum from the PPO steps before, so no step is taken.
        runner = train(self.CONFIG, iterations=1)
        runner.alg.imitation_coef = 0.0
        before = [p.detach().clone() for p in runner.alg.get_policy().parameters()]
        assert runner.alg.imitate() == 0.0
        after = list(runner.alg.get_policy().parameters())
        assert all(torch.equal(a, b) for a, b in zip(before, after))

    def test_bad_settings_rejected(self) -> None:
        with pytest.raises(ValueError, match="name it in driver"):
            ImitationConfig(coef=1.0)
        with pytest.raises(ValueError, match=r"\[imitation\] driver must be one of"):
            ImitationConfig(driver="random")
        with pytest.raises(ValueError, match=r"\[imitation\] coef must be a number >= 0"):
            ImitationConfig(driver="racing_line", coef=-1.0)
        with pytest.raises(ValueError, match="leave teacher unset"):
            ImitationConfig(driver="racing_line", coef=5.0, teacher="racing_line")

    def test_driver_and_teacher_take_settings(self) -> None:
        paced = ImitationConfig(driver="racing_line:grip_factor=0.7", coef=1.0)
        expert = paced.expert()
        assert (expert.grip_factor, expert.name) == (0.7, "racing_line:grip_factor=0.7")
        teacher = ImitationConfig(teacher="blocker:lane=outer", options={"cruise_speed": 2.0})
        assert teacher.scripted_teacher and teacher.expert().lane == "outer"
        assert teacher.expert().cruise_speed == 2.0
        with pytest.raises(ValueError, match=r"^\[imitation\] teacher: pure_pursuit: "
                                             r"cruise_speed must be a number in \(0, 4\], "
                                             r"got '9'$"):
            ImitationConfig(teacher="pure_pursuit:cruise_speed=9")
        with pytest.raises(ValueError, match=r"^\[imitation\] teacher: league_racer: a trained "
                                             r"policy takes no settings"):
            ImitationConfig(teacher="league_racer:grip_factor=0.7")
        with pytest.raises(ValueError, match=r"\[imitation\] driver must be one of"):
            ImitationConfig(driver="random", coef=1.0)
        with pytest.raises(ValueError, match="grip_factor given both in the spec"):
            ImitationConfig(teacher="racing_line:grip_factor=0.7", options={"grip_factor": 0.8})


class TestMaxStd:
    """TrainConfig.max_std holds the policy's std at or below the bound after every update."""

    # An entropy bonus of 1 outweighs the small surrogate of a 2-iteration run: it widens the
    # Gaussian at every update. Adam moves a parameter by about the learning rate (1e-3) per
    # step, 16 steps an iteration (4 epochs x 4 mini-batches): 0.3 -> about 0.33 unbounded.
    GREEDY = dataclasses.replace(SMALL, init_std=0.3,
                                 ppo=dataclasses.replace(SMALL.ppo, entropy_coef=1.0))
    BOUND = 0.305

    @staticmethod
    def std(runner: object) -> torch.Tensor:
        return runner.alg.get_policy().distribution.std_param.detach()  # type: ignore[attr-defined]

    def test_unbounded_std_grows(self) -> None:
        assert bool((self.std(train(self.GREEDY, iterations=2)) > self.BOUND).all())

    def test_bounded_std_ends_on_the_bound(self) -> None:
        runner = train(dataclasses.replace(self.GREEDY, max_std=self.BOUND), iterations=2)
        # Projected, not merely clamped when sampling: the parameter itself is on the bound,
        # where the gradient still flows (past a clamp it is zero: the std could never shrink).
        assert torch.allclose(self.std(runner), torch.full((2,), self.BOUND))

    def test_init_std_above_the_bound_starts_on_it(self) -> None:
        runner = train(dataclasses.replace(SMALL, init_std=0.5, max_std=0.2), iterations=0)
        assert torch.allclose(self.std(runner), torch.full((2,), 0.2))

    def test_init_policy_std_is_projected(self, trained: tuple[Path, object]) -> None:
        saved = torch.load(trained[0], weights_only=True)["actor_state_dict"]
        assert bool((saved["distribution.std_param"] > 0.1).all())
        runner = train(dataclasses.replace(SMALL, init=str(trained[0]), max_std=0.1),
                       iterations=0)
        assert torch.allclose(self.std(runner), torch.full((2,), 0.1))
        # The rest of the actor is the init policy's.
        actor = runner.alg.get_policy().state_dict()
        assert torch.equal(actor["mlp.0.weight"], saved["mlp.0.weight"])

    def test_bad_bound_rejected(self) -> None:
        for bad in (0.0, -1.0, "0.5"):
            with pytest.raises(ValueError, match="max_std"):
                dataclasses.replace(SMALL, max_std=bad)

    def test_cli_flag(self, tmp_path: Path) -> None:
        from h2h_racing.cli.command import main

        out = tmp_path / "run"
        assert main(["train", "--track", "oval", "--iterations", "1", "--envs", "8",
                     "--eval-every", "0", "--max-std", "0.25", "--out", str(out)]) == 0
        payload = torch.load(out / "policy.pt", weights_only=True)
        assert float(payload["actor_state_dict"]["distribution.std_param"].max()) <= 0.25


class TestShippedPolicies:
    """Policies shipped under policies/trained/ load by name and drive."""

    @pytest.mark.parametrize("name", sorted(shipped_policies()))
    def test_shipped_policy_finishes_a_lap_of_the_default_track(self, name: str) -> None:
        from h2h_racing.training.evaluate import evaluate

        result = evaluate(name, "speedway", episodes=2)
        assert result.lap_completion == 1.0
        # The cards report laps of 8.5-9.7 s; the racing-line driver's is about 8.6 s
        # (policies/README.md), so 11 s is 1.28 x the racing line's.
        assert result.mean_lap_time < 11.0

    def test_camera_racer_reads_deepracers_head_to_head_sensors_and_passes(self) -> None:
        from h2h_racing.training.evaluate import head_to_head

        payload = torch.load(shipped_policies()["camera_racer"], weights_only=True)
        assert payload["observations"] == "camera_lidar"
        assert list(payload["obs_groups"]) == ["camera", "lidar", "motion"]
        camera, lidar = payload["env_config"]["camera"], payload["env_config"]["lidar"]
        assert (camera["width"], camera["height"]) == (32, 24)
        assert (lidar["beams"], lidar["fov_deg"], lidar["max_range"]) == (64, 300.0, 1.0)
        # Its card: 10 of 10 races won from behind against pure_pursuit on speedway (seed 7),
        # passing it, with no crash caused; 4 two-lap races from behind here.
        result = head_to_head("camera_racer", "pure_pursuit", "speedway", races=4, laps=2,
                              seed=7, start="behind")
        assert result.wins_behind == 4
        assert result.overtakes[0] >= 4 and result.crashes[0] == 0

    def test_camera_generalist_drives_from_deepracers_camera_and_laps_technical(self) -> None:
        from h2h_racing.training.evaluate import evaluate

        payload = torch.load(shipped_policies()["camera_generalist"], weights_only=True)
        assert payload["observations"] == "camera_only"
        assert list(payload["obs_groups"]) == ["camera", "motion"]
        camera = payload["env_config"]["camera"]
        assert (camera["width"], camera["height"], camera["hfov_deg"]) == (64, 48, 120.0)
        # Its card: 20 of 20 one-lap attempts on technical, mean 7.19 s; the start points
        # k * L / 5 here are every 4th of the card's k * L / 20 (the attempts are deterministic).
        result = evaluate("camera_generalist", "technical", episodes=5)
        assert result.lap_completion == 1.0
        assert result.mean_lap_time == pytest.approx(7.19, abs=0.3)

    def test_obstacle_generalist_finishes_object_avoidance_and_passes_bots(self) -> None:
        from h2h_racing.match import run_race

        # Its card: 3 of 3 object-avoidance races on speedway without a crash; DeepRacer's 6
        # boxes at seed 1's places here.
        boxes = run_race("speedway", ["obstacle_generalist"], race_type="object_avoidance",
                         seed=1).rows[0]
        assert (boxes["finished"], boxes["laps"], boxes["crashes"]) == (True, 3, 0)
        # 3 bots at 0.75 m/s on oval (a 20 m lap), each starting ahead of the car by b < 1 lap.
        # In the race's total time T a bot ends at b + 0.75 T, the car at 3 laps: with
        # 0.75 T < 2 laps the car ends ahead of every bot it started behind, so it passed all.
        bots = run_race("oval", ["obstacle_generalist"], race_type="head_to_bot", seed=1)
        row, lap = bots.rows[0], load_track("oval").length
        assert (row["finished"], row["laps"], bots.bots) == (True, 3, 3)
        assert 0.75 * row["total_time"] < 2 * lap
        assert row["crashes"] <= 1

    @pytest.mark.parametrize("track", list_tracks())
    def test_generalist_laps_every_shipped_track(self, track: str) -> None:
        from h2h_racing.training.evaluate import evaluate

        # Its card: 40 of 40 attempts on each track; 5 of those start points here
        # (k * L / 5 are every 8th of the card's k * L / 40).
        assert evaluate("ppo_generalist", track, episodes=5).lap_completion == 1.0


class TestProcedural:
    """track="procedural" trains on a new random track every ``procedural.every``
    iterations."""

    def test_tracks_change_between_chunks(self) -> None:
        config = dataclasses.replace(SMALL, track="procedural",
                                     procedural=ProceduralTracks(every=1))
        runner = train(config, iterations=2)
        track = runner.env.track
        assert track.name.startswith("random-") and runner.env.core.track is track
        # Widths are drawn in the catalogue's range [0.76, 1.07] m.
        assert 0.76 <= float(track.width.min()) <= 1.07

    def test_evaluations_do_not_change_the_track_schedule(self, tmp_path: Path) -> None:
        from h2h_racing.training.tracks import random_training_track

        # Evaluating after every iteration splits training into 1-iteration chunks, but with
        # every=2 the 2 iterations still run on the first random track only.
        config = dataclasses.replace(SMALL, track="procedural",
                                     procedural=ProceduralTracks(every=2), eval_every=1,
                                     eval_episodes=1, eval_race_seconds=1.0)
        runner = train(config, iterations=2, out=tmp_path)
        first = random_training_track(np.random.default_rng(config.seed + 1))
        assert runner.env.track.name == first.name
        # Procedural runs are evaluated on the fixed start track.
        assert len(list((tmp_path / "eval").glob("iter_*.rrd"))) == 2

    def test_reversed_tracks_turn_the_other_way(self) -> None:
        from h2h_racing.training.tracks import random_training_track

        ccw = random_training_track(np.random.default_rng(7), reverse_share=0.0)
        cw = random_training_track(np.random.default_rng(7), reverse_share=1.0)
        # Same loop (the reversal is drawn after it), driven the other way: the start vertex
        # stays, the others run backwards, every curvature changes sign, so the tightest
        # left-hander (largest curvature) becomes the tightest right-hander.
        assert ccw.is_ccw and not cw.is_ccw and cw.name == f"{ccw.name}-cw"
        assert np.allclose(cw.centre, np.concatenate([ccw.centre[:1], ccw.centre[:0:-1]]))
        assert float(cw.curvature_vertex.min()) == pytest.approx(
            -float(ccw.curvature_vertex.max()), rel=1e-6)
        with pytest.raises(ValueError, match=r"\[procedural\] reverse_share must be in"):
            ProceduralTracks(reverse_share=1.5)
        with pytest.raises(ValueError, match=r"\[procedural\] chicanes must be"):
            ProceduralTracks(chicanes=(3, 1))

    def test_chicanes_reach_the_training_tracks(self) -> None:
        from h2h_racing.training.tracks import random_training_track
        from h2h_racing.track.generator import curvature

        # The same draws with and without chicanes: the chicane track turns right far
        # harder (its loop runs anticlockwise; the chicanes swerve both ways).
        plain = [random_training_track(np.random.default_rng(s)) for s in range(4)]
        wiggly = [random_training_track(np.random.default_rng(s), chicanes=(3, 3))
                  for s in range(4)]
        assert all(w.name != p.name for w, p in zip(wiggly, plain))
        assert (np.median([-curvature(w.centre).min() for w in wiggly])
                > 2 * np.median([-curvature(p.centre).min() for p in plain]))

    def test_tight_tracks_are_short_narrow_and_twisty(self) -> None:
        from h2h_racing.training.tracks import TIGHT_LENGTH, TIGHT_WIDTH, random_training_track

        plain = [random_training_track(np.random.default_rng(s)) for s in range(6)]
        tight = [random_training_track(np.random.default_rng(s), tight_share=1.0)
                 for s in range(6)]

        def twisty(track: object) -> float:
            # Share of the lap in corners under 1 m radius (|curvature| > 1 / m).
            return float((np.abs(track.curvature_vertex) > 1.0).mean())  # type: ignore[attr-defined]

        for track in tight:
            assert TIGHT_LENGTH[0] - 0.1 <= track.length <= TIGHT_LENGTH[1] + 0.1
            assert TIGHT_WIDTH[0] <= float(track.width.min()) <= TIGHT_WIDTH[1] + 1e-9
        assert min(twisty(t) for t in tight) > max(twisty(t) for t in plain)
        # A share of 0 draws nothing: the same tracks as without the option.
        assert [random_training_track(np.random.default_rng(s), tight_share=0.0).name
                for s in range(6)] == [t.name for t in plain]
        with pytest.raises(ValueError, match=r"\[procedural\] tight_share must be in"):
            ProceduralTracks(tight_share=-0.1)
        # The settings reach the draw: a share of 1 gives a tight track.
        drawn = ProceduralTracks(tight_share=1.0).draw(np.random.default_rng(0))
        assert drawn.name == tight[0].name

    def test_circuit_share_draws_circuits_of_tight_corners(self) -> None:
        from h2h_racing.training.tracks import TIGHT_WIDTH, random_training_track

        circuits = [random_training_track(np.random.default_rng(s), circuit_share=1.0,
                                          tight_share=1.0) for s in range(6)]
        for track in circuits:
            assert track.name.startswith("circuit-")
            assert TIGHT_WIDTH[0] <= float(track.width.min()) <= TIGHT_WIDTH[1] + 1e-9
            # Corners of 0.5-0.7 m radius on a 0.76-0.9 m wide track: the tightest radius
            # stays at or above 0.6 x the width (random_circuit's check).
            assert float(np.abs(track.curvature_vertex).max()) <= 1 / (0.6 * track.width.min())
        # A share of 0 draws nothing: the same tracks as without the option.
        assert ([random_training_track(np.random.default_rng(s), circuit_share=0.0).name
                 for s in range(4)]
                == [random_training_track(np.random.default_rng(s)).name for s in range(4)])
        with pytest.raises(ValueError, match=r"\[procedural\] circuit_share must be in"):
            ProceduralTracks(circuit_share=1.5)
        drawn = ProceduralTracks(circuit_share=1.0).draw(np.random.default_rng(0))
        assert drawn.name.startswith("circuit-")

    def test_circuit_corners_choose_the_circuits_style(self) -> None:
        from h2h_racing.training.tracks import random_training_track

        drawn = ProceduralTracks(circuit_share=1.0, circuit_corners="bspline").draw(
            np.random.default_rng(0))
        assert "(bspline)" in drawn.description
        assert drawn.name == random_training_track(np.random.default_rng(0), circuit_share=1.0,
                                                   circuit_corners="bspline").name
        # The default is the arcs, drawn as before the option.
        assert ProceduralTracks().circuit_corners == ("arcs",)
        assert "(arcs)" in ProceduralTracks(circuit_share=1.0).draw(
            np.random.default_rng(0)).description
        # Several styles: one drawn per circuit, all of them over a few draws.
        both = ProceduralTracks(circuit_share=1.0, circuit_corners=("bspline", "hairpins"))
        rng = np.random.default_rng(1)
        kinds = {"(bspline)" in both.draw(rng).description for _ in range(8)}
        assert kinds == {True, False}
        with pytest.raises(ValueError, match=r"circuit_corners must be one or more of \['arcs', "
                                             r"'bspline', 'hairpins', 'long'\], got "
                                             r"\('round',\)"):
            ProceduralTracks(circuit_corners="round")

    def test_narrowest_lowers_every_width_range(self) -> None:
        from h2h_racing.training.tracks import TIGHT_WIDTH, random_training_track

        settings = dict(varying_share=0.5, tight_share=0.3, circuit_share=0.3)
        narrow = [random_training_track(np.random.default_rng(s), narrowest=0.6, **settings)
                  for s in range(16)]
        assert all(0.6 - 1e-9 <= float(t.width.min()) and float(t.width.max()) <= 1.07 + 1e-9
                   for t in narrow)
        # Uniform draws from [0.6, 1.07] (ordinary) or [0.6, 0.9] (tight, circuits): some of
        # 16 tracks fall below the catalogue's 0.76, which the default never does.
        assert any(float(t.width.min()) < 0.76 for t in narrow)
        assert all(float(random_training_track(np.random.default_rng(s), **settings).width.min())
                   >= 0.76 - 1e-9 for s in range(16))
        # Same draws otherwise: the same number of random numbers, so the same kinds of track.
        names = [random_training_track(np.random.default_rng(s), **settings).name.split("-")[0]
                 for s in range(16)]
        assert names == [t.name.split("-")[0] for t in narrow]
        assert ProceduralTracks(narrowest=0.6).narrowest == 0.6
        with pytest.raises(ValueError, match=rf"narrowest must be in \[0.5, {TIGHT_WIDTH[1]}\] m"):
            ProceduralTracks(narrowest=0.4)

    def test_the_route_options_leave_older_settings_drawing_the_same_tracks(self) -> None:
        from h2h_racing.training.tracks import random_training_track

        # Names (a hash of each track's geometry) drawn by the code before widest,
        # waypoint_gap and the "long" circuits existed, with every other option on.
        settings = dict(varying_share=0.5, tight_share=0.3, circuit_share=0.3,
                        reverse_share=0.5, chicanes=(1, 3), narrowest=0.6)
        before = ["random-4b65eadf", "random-02bd10e9-cw", "circuit-d6b3db39",
                  "circuit-17d467cf", "random-710ce4f6", "random-d3bf51cd-cw"]
        assert [random_training_track(np.random.default_rng(s), **settings).name
                for s in range(6)] == before
        assert [random_training_track(np.random.default_rng(s), circuit_share=1.0,
                                      circuit_corners=("bspline", "hairpins")).name
                for s in range(2)] == ["circuit-900a63e5", "circuit-038b6e01"]

    def test_widest_raises_the_ordinary_tracks_width(self) -> None:
        from h2h_racing.training.tracks import random_training_track

        wide = [random_training_track(np.random.default_rng(s), narrowest=0.6, widest=2.0,
                                      varying_share=0.5) for s in range(12)]
        assert all(0.6 - 1e-9 <= float(t.width.min()) and float(t.width.max()) <= 2.0 + 1e-9
                   for t in wide)
        # Uniform in [0.6, 2]: P(all 12 tracks under 1.07 m) = (0.47 / 1.4)^12, about 2e-6.
        assert any(float(t.width.max()) > 1.07 for t in wide)
        # A wide track keeps corners of 1.2 x its half-width (0.6 x its width).
        for track in wide:
            radius = 1 / float(np.abs(track.curvature_vertex).max())
            assert radius >= 0.6 * float(track.width.max()) * 0.98
        with pytest.raises(ValueError, match=r"widest must be in \[narrowest \(0.8\), 2.5\] m, "
                                             r"got 0.7"):
            ProceduralTracks(narrowest=0.8, widest=0.7)

    def test_long_circuits_turn_as_often_as_real_long_routes(self) -> None:
        from h2h_racing.training.tracks import LONG_WIDEST, random_training_track

        for seed in range(3):
            track = random_training_track(np.random.default_rng(seed), circuit_share=1.0,
                                          circuit_corners="long", narrowest=0.6)
            assert "circuit" in track.name and 0.6 - 1e-9 <= float(track.width.min())
            assert float(track.width.max()) <= LONG_WIDEST + 1e-9
            # 8-20 cells of 2.5-5 m: laps of 45-100 m over 60 draws (the docstring's range);
            # 10-30 % of the lap under 1.5 m radius is what the style is for.
            assert 35.0 <= track.length <= 110.0
            spans = np.diff(np.append(track.vertex_s, track.length))
            tight = float(np.sum(spans * (np.abs(track.curvature_vertex) > 1 / 1.5)))
            assert 0.05 <= tight / track.length <= 0.4

    def test_waypoint_gap_redraws_the_centre_line_through_spaced_waypoints(self) -> None:
        from h2h_racing.track.generator import random_track
        from h2h_racing.training.tracks import resample

        spec = random_track(np.random.default_rng(3), width=1.0)
        widths = (spec.width_left, spec.width_right)
        centre, (left, _) = resample(np.random.default_rng(0), spec.centre, widths, (0.2, 0.6))
        closed = np.vstack([centre, centre[:1]])
        gaps = np.linalg.norm(np.diff(closed, axis=0), axis=1)
        # Chords of a smooth curve are a little shorter than its arcs; the closing gap is the
        # remainder of the lap, at least half the smaller gap drawn (>= 0.1 m).
        assert 0.19 <= gaps[:-1].min() and gaps[:-1].max() <= 0.6 + 1e-9
        assert gaps[-1] >= 0.1 - 1e-9
        # The waypoints lie on the 5 cm line: each within a sagitta (gap^2 / 8R, well under
        # 1 mm at 5 cm over R >= 0.6 m) of its nearest fine vertex pair.
        fine = np.asarray(spec.centre)
        nearest = np.min(np.linalg.norm(centre[:, None] - fine[None], axis=2), axis=1)
        assert nearest.max() <= 0.05
        assert np.allclose(left, 0.5)
        # Through ProceduralTracks: every track's waypoints are 0.3-0.5 m apart but for the
        # closing one, or (rarely, a fold on a tight corner 5 times over) its 5 cm line.
        rng = np.random.default_rng(1)
        spaced = ProceduralTracks(waypoint_gap=(0.3, 0.5), tight_share=0.5)
        for _ in range(4):
            points = np.asarray(spaced.draw(rng).centre)
            gaps = np.linalg.norm(np.diff(points, axis=0), axis=1)
            assert gaps.max() <= 0.5 + 1e-9 and (gaps.min() >= 0.28 or gaps.max() < 0.06)
        with pytest.raises(ValueError, match=r"waypoint_gap must be \(low, high\) with 0.02 <= "
                                             r"low <= high <= 1 m, got \(0.5, 0.3\)"):
            ProceduralTracks(waypoint_gap=(0.5, 0.3))

    def test_hairpin_circuits_bring_legs_as_close_as_technicals(self) -> None:
        from h2h_racing.track.metrics import min_clearance
        from h2h_racing.training.tracks import HAIRPIN_CELL, random_training_track

        # Cells of 1.26-1.6 m: two legs one cell apart are 1.26-1.6 m apart centre to centre,
        # 0.36-0.84 m at the borders of a 0.76-0.9 m track (technical's bay: 0.5 m). A corner
        # is capped at half a side, so a one-cell bay's end is a semicircle of 0.63-0.8 m.
        for seed in range(4):
            track = random_training_track(np.random.default_rng(seed), circuit_share=1.0,
                                          circuit_corners="hairpins")
            width = float(track.width.min())
            gap = min_clearance(np.asarray(track.centre)[::2], exclude_arc=3 * width) - width
            assert 0.25 <= gap <= HAIRPIN_CELL[1] - width + 1e-6
            assert float(np.abs(track.curvature_vertex).max()) <= 1 / (0.6 * width)

    def test_set_track_restarts_every_copy(self) -> None:
        from h2h_racing.training.vec_env import RacingVecEnv

        env = RacingVecEnv(SMALL.env_config(), num_envs=3)
        for _ in range(5):
            env.step(torch.zeros(3, 2))
        env.set_track(load_track("kidney"))
        assert env.core.track.name == "kidney" and all(env.core.steps == 0)
        assert env.get_observations()["policy"].shape == (3, 33)


def test_train_cli_rules_and_reward(tmp_path: Path) -> None:
    """``--rules race --reward ...`` reach the TrainConfig saved in policy.pt."""
    from h2h_racing.cli.command import main

    out = tmp_path / "run"
    assert main(["train", "--track", "oval", "--iterations", "1", "--envs", "4", "--no-onnx",
                 "--eval-every", "0", "--rules", "race", "--reward", "crash=-10,time=-0.05",
                 "--out", str(out)]) == 0
    saved = torch.load(out / "policy.pt", weights_only=True)["train_config"]
    assert saved["rules"] == "race"
    # Named terms change, the others keep RewardConfig's defaults (progress 1, off track -5).
    assert saved["reward"] == {**saved["reward"], "crash": -10.0, "time": -0.05,
                               "progress": 1.0, "off_track": -5.0}
    with pytest.raises(SystemExit, match="TERM one of progress, speed"):
        main(["train", "--reward", "grip=2", "--out", str(tmp_path / "x")])
    with pytest.raises(SystemExit, match="must be a number"):
        main(["train", "--reward", "crash=lots", "--out", str(tmp_path / "x")])


def test_train_cli_config_file_and_overriding_flags(tmp_path: Path) -> None:
    """``--config`` gives the fields, flags given on the command line override them."""
    from h2h_racing.cli.command import main

    path = tmp_path / "train.toml"
    path.write_text('track = "kidney"\nnum_envs = 4\neval_every = 0\nseed = 3\n'
                    '[procedural]\ntight_share = 0.25\n[reward]\ncrash = -10.0\ntime = -0.1\n')
    out = tmp_path / "run"
    assert main(["train", "--config", str(path), "--track", "oval", "--reward", "time=-0.05",
                 "--iterations", "1", "--no-onnx", "--out", str(out)]) == 0
    saved = torch.load(out / "policy.pt", weights_only=True)["train_config"]
    assert saved["track"] == "oval" and saved["num_envs"] == 4 and saved["seed"] == 3
    assert saved["procedural"]["tight_share"] == 0.25
    # --reward changes the named term over the file's table; the file's crash stays.
    assert saved["reward"]["time"] == -0.05 and saved["reward"]["crash"] == -10.0
    with pytest.raises(SystemExit, match="no such file"):
        main(["train", "--config", str(tmp_path / "nope.toml"), "--out", str(out)])
    path.write_text("num_envs = [")
    with pytest.raises(SystemExit, match="not valid TOML"):
        main(["train", "--config", str(path), "--out", str(out)])


def test_train_cli_with_deepracer_inputs(tmp_path: Path) -> None:
    """``h2h-racing train --reward-function --model-metadata --simtrace`` on a route file."""
    from h2h_racing.cli.command import main

    examples = Path(__file__).resolve().parents[2] / "examples" / "deepracer"
    out = tmp_path / "run"
    assert main(["train", "--track", "oval", "--iterations", "1", "--envs", "4",
                 "--reward-function", str(examples / "follow_centre_line.py"),
                 "--model-metadata", str(examples / "model_metadata.json"),
                 "--simtrace", "2", "--no-onnx", "--out", str(out)]) == 0
    payload = torch.load(out / "policy.pt", weights_only=True)
    # The example's five actions: steering -30, -15, 0, 15, 30 deg at 0.6 m/s.
    assert payload["env_config"]["action_type"] == "discrete"
    assert [a[0] for a in payload["env_config"]["discrete_actions"]] == [-30, -15, 0, 15, 30]
    trace = out / "simtrace" / "car_0" / "1" / "training-simtrace" / "0-iteration.csv"
    rows = [line.split(",") for line in trace.read_text().splitlines()[1:]]
    # Step rows carry a discrete index in 0..4 and the list's speed, 0.6 m/s.
    steps = [r for r in rows if r[15] != "prepare"]
    assert steps and {r[7] for r in steps} <= {"0", "1", "2", "3", "4"}
    assert {float(r[6]) for r in steps} == {0.6}


def test_deepracer_inputs_are_checked(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="reward_function: .* is not a file"):
        TrainConfig(reward_function=str(tmp_path / "missing.py"))
    with pytest.raises(ValueError, match="need one track"):
        TrainConfig(track="procedural", simtrace_envs=1)
    with pytest.raises(ValueError, match="simtrace_envs must be an int in"):
        TrainConfig(simtrace_envs=11)
