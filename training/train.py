"""The training loop: rsl-rl PPO (or imitation of a teacher) on the batched core.

``train`` runs a ``TrainConfig`` (``h2h_racing.training.config``) with rsl-rl's tensorboard
logs and checkpoints in the output folder, then writes ``policy.pt``
(``h2h_racing.training.policy_file``). Every ``eval_every`` iterations it evaluates the current
actor (``evaluate_during_training``): figures into the tensorboard log under ``Eval/`` and a
rerun recording of a race to ``<out>/eval/iter_<n>.rrd``.

With ``[imitation] teacher`` it imitates a teacher with rsl-rl's ``Distillation`` instead
(DAgger: the student drives, the teacher labels the states it reaches): a state policy
distilled into a camera policy, or a scripted driver (``racing_line``) whose actions the env
computes in the learner's place (``h2h_racing.training.teachers``).
"""

from __future__ import annotations

import importlib.util
import os
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")  # rsl-rl imports GitPython

from h2h_racing.common.extras import missing_extra  # noqa: E402

try:
    import torch  # noqa: E402
except ImportError as _error:
    raise missing_extra("train", "training", _error) from None

import numpy as np  # noqa: E402

from h2h_racing.training.camera_network import use_channels_last  # noqa: E402
from h2h_racing.training.config import PROCEDURAL, TrainConfig  # noqa: E402
from h2h_racing.training.curves import (  # noqa: E402
    REWARD_FUNCTION_TERM, CurveWriter, plot_curves, seconds_at)
from h2h_racing.training.device import check_device_available  # noqa: E402
from h2h_racing.training.interrupt import StopRequest, TrainingInterrupted  # noqa: E402
from h2h_racing.training.policy_file import (  # noqa: E402
    load_actor, load_init, load_checkpoint, policy_payload, save_policy)
from h2h_racing.training.run_folder import RunFolderError, check_out, checkpoints  # noqa: E402
from h2h_racing.training.teachers import load_teacher  # noqa: E402
from h2h_racing.training.train_progress import (  # noqa: E402
    Budget, IterationHook, StopTraining, TrainDisplay, quiet)
from h2h_racing.common.progress import Mode  # noqa: E402


def train(config: TrainConfig, iterations: int, out: str | Path | None = None,
          minutes: float | None = None, progress: Mode = "off", verbose: bool = False,
          resume: bool = False, overwrite: bool = False,
          stop: StopRequest | None = None) -> Any:
    """Train with PPO (or distil ``config.imitation.teacher``); return the rsl-rl runner.

    Args:
        config: What to train.
        iterations: The run's PPO iterations (each ``num_envs * num_steps_per_env`` samples),
            a resumed run's earlier ones included.
        out: Folder for rsl-rl's logs and checkpoints, ``curves.csv`` and ``curves.png``
            (``training.curves``), the evaluation recordings (``eval/iter_<n>.rrd``, see
            ``evaluate_during_training``), the final ``policy.pt`` and, with
            ``config.simtrace_envs``, DeepRacer logs in ``out/simtrace/<car>`` (with
            DeepRacer's evaluation episodes between iterations,
            ``config.simtrace_eval_trials``); None keeps nothing on disk and skips the
            evaluations. A folder that holds anything is refused unless ``resume`` or
            ``overwrite`` (``training.run_folder.check_out``).
        minutes: The run's wall-clock budget, setup and evaluations included (a resumed run's
            earlier time too): it stops after the iteration past which the next would end
            beyond it.
        progress: ``"auto"``: a progress line on stderr (``train_progress.TrainDisplay``:
            iterations of the run, samples/s, mean reward, lap completion, ETA); ``"off"``:
            none.
        verbose: Print rsl-rl's model summaries and its block of figures after every
            iteration (with the run's totals) instead.
        resume: Continue the run in ``out`` from its latest checkpoint (weights-only), its
            curves and its time budget.
        overwrite: Delete the run in ``out`` first (its checkpoints, logs, curves, policy).
        stop: Takes Ctrl-C over while training runs (``training.interrupt``): after the
            current iteration the run saves a checkpoint and ``policy.pt`` and raises
            ``TrainingInterrupted``. None makes one with a plain line for a second Ctrl-C.

    Raises:
        RunFolderError: ``out`` does not suit the run (see ``out``).
        TrainingInterrupted: A Ctrl-C stopped the run (after saving).
    """
    out = None if out is None else Path(out)
    checkpoint = None if out is None else check_out(out, resume=resume, overwrite=overwrite)
    done = 0 if checkpoint is None else checkpoints(out)[-1][0] + 1  # type: ignore[arg-type]
    spent = 0.0 if checkpoint is None else seconds_at(out / "curves.csv", done)  # type: ignore
    budget = Budget(minutes, spent)
    if checkpoint is not None and (done >= iterations or budget.spent_all()):
        used = (f"{done} of --iterations {iterations}" if done >= iterations
                else f"{spent / 60:.1f} of --minutes {minutes:g}")
        raise RunFolderError(f"--resume: the run in {out} already trained {used}; give a larger "
                             f"--iterations or --minutes (both count the whole run) to train on")
    if checkpoint is not None and config.simtrace_envs:
        raise RunFolderError("--resume cannot go on with DeepRacer simtrace logs (their "
                             "iteration files would restart at 0 over the old ones): resume "
                             "without --simtrace, or start again with --overwrite")
    # Before any work: a run asked for a GPU this machine lacks fails here, not after the env.
    check_device_available(config.device)
    torch.manual_seed(config.seed + done)
    torch.set_num_threads(config.torch_threads)
    display = TrainDisplay(iterations, budget, mode=progress, verbose=verbose, first=done)
    display.starting(f"building {config.num_envs} env copies, compiling kernels on a first run")
    # The env runs on the CPU whatever the learner's device (rsl-rl moves the observations).
    env = config.make_env(simtrace=None if out is None else out / "simtrace")
    with quiet(verbose):
        runner = make_runner(config, env, None if out is None else str(out))
    if checkpoint is not None:
        load_checkpoint(runner, checkpoint)
        display.clear()
        print(f"resuming at iteration {done} of {iterations} from {checkpoint}"
              + (f" ({spent / 60:.1f} of {minutes:g} minutes used)" if minutes else ""),
              flush=True)
    runner.current_learning_iteration = done
    if getattr(env, "simtrace", None) is not None and config.simtrace_eval_trials:
        # DeepRacer's evaluation episodes between the simtrace's iterations.
        from h2h_racing.training.simtrace_eval import SimtraceEvaluations

        evaluations = SimtraceEvaluations.for_run(config, env, runner)  # type: ignore[arg-type]
        env.evaluations = evaluations  # type: ignore[union-attr]
    terms = reward_terms(config)
    curves = None if out is None else CurveWriter(out / "curves.csv", terms,
                                                  keep=done if checkpoint else None)
    stop = stop if stop is not None else StopRequest()
    procedural = config.track == PROCEDURAL
    eval_every = config.eval_every if out is not None else 0
    listeners: list[Any] = [display]
    if curves is not None:
        listeners.append(lambda figures: _add_row(curves, figures, eval_every))
    hook = IterationHook(runner, iterations, terms, config.reward_function is not None, budget,
                         listeners, stop=lambda: stop.requested, planned=display.planned)
    tracks = _track_draws(config, env, done) if procedural else None
    save_interval = runner.cfg["save_interval"]
    # The latest checkpoint not on the save interval, deleted when a newer one is written.
    extra = checkpoint if checkpoint is not None and (done - 1) % save_interval else None
    display.starting("collecting the first rollout (compiling kernels on a first run)")
    with stop.installed():
        try:
            while done < iterations and hook.stopping is None and not stop.requested:
                # Each learn() call stops where the track changes or an evaluation is due.
                step = iterations - done
                if procedural:
                    every = config.procedural.every
                    if done % every == 0:
                        _set_tracks(config, env, tracks)
                    step = min(step, every - done % every)
                if eval_every:
                    step = min(step, eval_every - done % eval_every)
                stopped = False
                try:
                    with quiet(verbose):
                        runner.learn(step)
                except StopTraining:
                    stopped = True
                last = runner.current_learning_iteration  # index of the last iteration trained
                if stopped and out is not None:  # learn() saves only when it runs to its end
                    runner.save(str(out / f"model_{last}.pt"))
                # learn() saves a checkpoint when it ends: keep only the latest of those (and
                # every save_interval one), or a run of short learn() calls fills the disk.
                latest = out / f"model_{last}.pt" if out else None
                if extra is not None and extra != latest:
                    extra.unlink(missing_ok=True)
                extra = latest if last % save_interval else None
                # rsl-rl's learn() re-runs the last iteration index on the next call (its G3
                # gotcha): the runner's counter is the iterations done.
                done = runner.current_learning_iteration = last + 1
                # Each learn() also opens a new tensorboard event file (and never closes the
                # last): keep the first writer for the whole run.
                runner.logger.init_logging_writer = _keep_writer
                if (eval_every and done % eval_every == 0 and hook.stopping is None
                        and not stop.requested):
                    display.phase(f"evaluating iteration {done}: {config.eval_episodes} lap "
                                  f"attempts and a race")
                    figures = evaluate_during_training(runner, config, out, done,  # type: ignore
                                                       before_print=display.clear)
                    if curves is not None:
                        curves.add_evaluation(done, figures)
                    if budget.after_pause() and done < iterations:
                        hook.stopping = "budget"
        except BaseException:
            # A run that fails part-way (drawing a track, in an evaluation) still writes
            # the row of its last iteration, which its latest checkpoint may hold: resumed,
            # the run goes on from that row's clock instead of restarting it at 0.
            if curves is not None:
                curves.flush()
            raise
        # Still inside: a second Ctrl-C while saving stops at once (StopRequest).
        interrupted = stop.requested or hook.stopping == "interrupted"
        env.close()
        if runner.logger.writer is not None:
            runner.logger.writer.close()
        policy, plotted = None, None
        if out is not None:
            display.phase(f"saving {out / 'policy.pt'} and the curves")
            if curves is not None:
                curves.flush()
            training = {"iterations": done, "seconds": budget.elapsed()}
            policy = save_policy(runner, config, out / "policy.pt", training=training)
            plotted = plot_curves(out / "curves.csv", out / "curves.png")
        # 100 % once all of training's work is done (the CLI's export shows as its own line).
        display.finish("interrupted (Ctrl-C)" if interrupted else
                       "time budget reached" if hook.stopping == "budget" else "done",
                       complete=not interrupted)
        if plotted is not None:
            print(plotted, flush=True)
    if interrupted:
        latest_checkpoint = None if out is None else out / f"model_{done - 1}.pt"
        raise TrainingInterrupted(done, latest_checkpoint, policy)
    return runner


def _add_row(curves: CurveWriter, figures: Any, eval_every: int) -> None:
    """Add an iteration's row to ``curves.csv``, written at once unless an evaluation is due
    after it (which joins the row and writes it): so every checkpoint's iteration has its row on
    disk, and a run killed after a checkpoint resumes with its curves and clock."""
    curves.add_iteration(figures.row())
    if not (eval_every and figures.done % eval_every == 0):
        curves.flush()


def reward_terms(config: TrainConfig) -> tuple[str, ...]:
    """The ``reward/<term>`` columns of ``config``'s reward in use: the built-in reward's terms
    with a non-zero weight, or the DeepRacer reward file's one (``training.curves``)."""
    import dataclasses

    from h2h_racing.sim.rewards import TERMS

    if config.reward_function is not None:
        return (REWARD_FUNCTION_TERM,)
    weights = dataclasses.asdict(config.reward)
    return tuple(f"reward/{term}" for term in TERMS if weights.get(term, 0.0) != 0.0)


def _track_draws(config: TrainConfig, env: Any, done: int) -> np.random.Generator:
    """The random-track generator of a procedural run, past the draws of the ``done``
    iterations already trained; a resumed run mid-way through a track's iterations gets that
    track back."""
    tracks = np.random.default_rng(config.seed + 1)
    every = config.procedural.every
    drawn: list[Any] = []
    for _ in range(done // every + (1 if done % every else 0)):
        drawn = [config.procedural.draw(tracks) for _ in range(config.procedural.tracks)]
    if done % every:
        _apply_tracks(env, drawn)
    return tracks


def _set_tracks(config: TrainConfig, env: Any, tracks: np.random.Generator) -> None:
    """Draw the next random tracks of a procedural run and put the env on them."""
    _apply_tracks(env, [config.procedural.draw(tracks) for _ in range(config.procedural.tracks)])


def _apply_tracks(env: Any, drawn: list[Any]) -> None:
    env.set_tracks(drawn)


def make_runner(config: TrainConfig, env: Any, log_dir: str | None = None) -> Any:
    """The rsl-rl runner of ``config`` on ``env`` (PPO, or distillation of a teacher), on
    ``config.device``, with the ``init`` policy's weights loaded and, with
    ``config.channels_last``, its networks' weights channels-last (``train`` uses it, and
    ``benchmarks/bench_train.py`` times what it builds)."""
    from rsl_rl.runners import DistillationRunner, OnPolicyRunner

    device = config.device
    if config.imitation.teacher is None:
        runner = OnPolicyRunner(env, config.rsl_rl_dict(), log_dir=log_dir, device=device)
    elif config.scripted_teacher:
        runner = DistillationRunner(env, config.rsl_rl_dict(), log_dir=log_dir, device=device)
        runner.alg.teacher_loaded = True  # the env's expert group: no weights to load
    else:
        teacher = load_teacher(config)
        runner = DistillationRunner(env, config.rsl_rl_dict(teacher), log_dir=log_dir,
                                    device=device)
        # The teacher is the policy file's actor: same model config, so its weights (and its
        # observation normaliser's statistics) load strictly.
        load_actor(runner.alg.teacher, teacher, f"teacher {config.imitation.teacher!r}")
        runner.alg.teacher_loaded = True
    if config.init is not None:
        load_init(runner, config.init, fresh_slots=config.init_fresh_slots)
    if config.channels_last:
        for name in ("actor", "critic", "student"):
            if getattr(runner.alg, name, None) is not None:
                use_channels_last(getattr(runner.alg, name))
    return runner


def _keep_writer() -> None:
    """Stands in for rsl-rl's ``Logger.init_logging_writer`` after the first ``learn()``."""


def evaluate_during_training(runner: Any, config: TrainConfig, out: str | Path,
                             iteration: int,
                             before_print: Callable[[], None] | None = None) -> dict[str, float]:
    """Evaluate the runner's current actor, log the figures and record a race.

    The actor becomes a ``TrainedPolicy`` straight from memory (no file). On the evaluation
    track (``config.env_config().track``; ``speedway`` for procedural runs) it makes
    ``config.eval_episodes`` one-lap attempts (``training.evaluate.evaluate``: training rules,
    start points spread round the lap), then races one lap as car 0 (in race rules) against
    the training opponent, or against itself in self-play, or alone (with ``[race]``'s boxes
    and bots; the lap attempts have none), with the race's grid
    drawn from ``config.seed`` so that every evaluation of a run races the same start. The
    race is recorded to ``<out>/eval/iter_<iteration>.rrd`` when rerun-sdk is installed (a
    warning says so otherwise).

    Figures go to rsl-rl's tensorboard log at step ``iteration`` (iterations completed):
    ``Eval/lap_completion`` (fraction of attempts), ``Eval/mean_lap_time`` and
    ``Eval/best_lap_time`` [s] (only when a lap was completed), ``Eval/off_tracks`` (attempts
    that ended off track) and ``Eval/collisions`` (contacts, over all attempts), and of the
    race ``Eval/race_finished`` (1 or 0) and ``Eval/race_position`` (1 = first).

    Args:
        runner: The rsl-rl ``OnPolicyRunner`` being trained.
        config: Its training config.
        out: The run's output folder.
        iteration: Iterations completed (names the recording and steps the log).
        before_print: Called before the figures' line is printed (takes a progress line off
            the terminal).

    Returns:
        The figures, keyed as logged without the ``Eval/`` prefix.
    """
    from h2h_racing.training.evaluate import evaluate
    from h2h_racing.match import run_race
    from h2h_racing.policies.trained import TrainedPolicy

    out = Path(out)
    payload = policy_payload(runner, config, training={"iterations": iteration})
    driver = TrainedPolicy.from_payload(payload, name=f"iter_{iteration}",
                                        source=f"{out} at iteration {iteration}")
    env_config = config.env_config()
    # The evaluation envs give the camera images the actor was trained on (and the recorded
    # reward terms are the ones it was trained with).
    env_fields = {"camera": env_config.camera, "reward": env_config.reward}
    figures = evaluate(driver, env_config.track, episodes=config.eval_episodes,
                       seed=config.seed, **env_fields)
    scalars = {"lap_completion": figures.lap_completion,
               "off_tracks": float(figures.off_tracks), "collisions": float(figures.collisions)}
    if np.isfinite(figures.mean_lap_time):
        scalars["mean_lap_time"] = figures.mean_lap_time
        scalars["best_lap_time"] = figures.best_lap_time

    learners = config.num_cars if config.learners is None else config.learners
    # With several opponents the recorded race is against the first.
    drivers = [driver] * learners + config.opponents()[:1] * (config.num_cars - learners)
    save = None
    if importlib.util.find_spec("rerun") is not None:
        save = out / "eval" / f"iter_{iteration}.rrd"
    else:
        warnings.warn("rerun-sdk is not installed, so the evaluation race is not recorded; "
                      "pip install 'h2h-racing[viz]' to record it", stacklevel=2)
    race = run_race(env_config.track, drivers,
                    race_type=env_config.race_type, laps=1, seed=config.seed, save=save,
                    max_cycles=max(1, round(config.eval_race_seconds / env_config.step_dt)),
                    **env_fields, **config.race.env_fields())
    mine = next(row for row in race.rows if row["agent"] == "car_0")
    scalars["race_finished"] = float(mine["finished"])
    scalars["race_position"] = float(mine["position"])

    writer = runner.logger.writer
    if writer is not None:
        for key, value in scalars.items():
            writer.add_scalar(f"Eval/{key}", value, iteration)
        writer.flush()
    if before_print is not None:
        before_print()
    lap = (f"{scalars['mean_lap_time']:.2f} s" if "mean_lap_time" in scalars else "-")
    print(f"eval at iteration {iteration}: laps {100 * figures.lap_completion:.0f} % of "
          f"{figures.episodes}, mean lap {lap}, off track {figures.off_tracks}, race "
          f"position {mine['position']}/{config.num_cars}" + (f" -> {save}" if save else ""))
    return scalars
