"""Self-play league training: AlphaStar's league, scaled down to one small machine.

Learners (``main``, ``main_exploiter``, ``league_exploiter``) are rsl-rl PPO runners, each on
its own batched ``RacingVecEnv`` with one learner car and one opponent car per env copy. A
*round* is:

1. **Matchmaking**: for each learner, the opponent of each env copy is drawn by its role's rule
   (``league.pfsp.choose_opponents``: prioritised fictitious self-play over the decayed payoff
   table, pure self-play against the learner's own frozen copy of the round's start, the
   current main). Scripted drivers stay in the pool as fixed anchors.
2. **Training**: every learner runs ``[training] iterations_per_round`` PPO iterations on the
   round's track (in parallel on the backend's workers) and saves
   ``learners/<name>/latest.pt`` and its runner state.
3. **Evaluation**: each learner races every pool member (and the other learners) in 2-car races
   under race rules, both seat orders on the same seeds; every race is a stored match, and
   each pair of seat orders (legs) updates the payoff table as one result that the grid does
   not decide (``league.racecraft``: a player that won both legs wins, a split goes to the
   lower aggregate time). With ``[main_restore] margin`` set, a main agent whose record
   against the anchors falls that far below its best gets its best state back (the exploit
   step of population-based training, the main's own past as the population); with
   ``finish_on_best`` the run also ends with each main at its best-record state.
4. **Snapshots**: a learner whose worst decayed win rate against the pool exceeds the
   ``[snapshots] threshold`` after ``min_rounds`` rounds (forced after ``max_rounds``) is
   frozen into a new player; the main exploiter then restarts from the initial weights, a
   league exploiter does so with probability 0.25 (AlphaStar's rules).
5. **Ratings**: each new snapshot plays placement races against every frozen player (anchors
   and earlier snapshots); a Bradley-Terry fit over all placement races (scored as pairs of
   legs, as the payoff table), anchored to
   ``racing_line`` at 1000, is appended to the rating history at the league's step count.

Everything lives in the league folder: ``league.sqlite`` (players, matches, ratings), the
learners' state, the snapshots and ``league.log`` (the round lines, ``league.display``).
Killing the run at any moment and starting it again continues from the last finished round:
matches are keyed by round, so none is counted twice.

A run ends at its time budget (``minutes`` of league time over all runs, stored in the league
file; or of this run with ``this_run``), within one training iteration or one race job of it,
or at the round cap, or when a ``StopSwitch`` (Ctrl-C) asks it to stop: learners stop after
the iteration they are running and keep it, race jobs still running are dropped. What was done
of the round is kept, and the next run resumes that round where it stopped.
"""

from __future__ import annotations

import dataclasses
import shutil
import sys
import time
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from h2h_racing.league.backends import JobsStopped
from h2h_racing.league.config import DEFAULT_MAX_ROUNDS, LeagueConfig, LearnerSpec
from h2h_racing.league.display import LeagueDisplay, minutes_text
from h2h_racing.league.learners import (TrainJob, atomic, discard_pending, install_pending,
                                       read_progress, train_round)
from h2h_racing.league.main_restore import KeepsBest, round_of
from h2h_racing.league.stopping import StopSwitch
from h2h_racing.league.store import LeagueStore, Player, file_sha256, player_for
from h2h_racing.league.tournament import PAIR_ORDERS, Job, make_job, run_job
from h2h_racing.common.progress import Mode

ELAPSED = "elapsed_seconds"
"""Meta key of the league's time so far over all its runs [s] (the budget's clock)."""
STOP_FILE = "stop-requested"
"""File in the league folder that asks the learners' workers to stop (``StopSwitch``)."""


class RoundStopped(Exception):
    """The round stopped part-way (budget or stop request); its one argument is the phase."""


# ------------------------------------------------------------------ the league (driver)


class League(KeepsBest):
    """A league run in ``folder`` (see the module docstring).

    Args:
        config: The league.
        folder: Where the store, learners and snapshots live; an existing league folder of
            the same name is continued.
        backend: Where learner rounds and matches run (``league.backends``); None: in process.
        out: Progress display stream (None: stderr): a line per round (standings, timings)
            and the run's progress line (``league.display``).
        progress: ``"auto"`` (a redrawn line on a terminal, a line per tenth of the budget
            elsewhere) or ``"off"`` (the round lines only).
        this_run: Count ``minutes`` from this run's start, not over the league's runs.
        stop: Checked at the run's safe points; its file stops the training workers.
    """

    def __init__(self, config: LeagueConfig, folder: str | Path, backend: Any | None = None,
                 out: TextIO | None = None, progress: Mode = "auto", this_run: bool = False,
                 stop: StopSwitch | None = None) -> None:
        from h2h_racing.league.backends import InProcessBackend

        self.config = config
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.store = LeagueStore(self.folder / "league.sqlite", name=config.name)
        stored = self.store.meta().get("league_name")
        if stored is not None and stored != config.name:
            raise ValueError(f"{self.folder} holds league {stored!r}, not {config.name!r}; "
                             f"give another folder")
        from h2h_racing.league.table import RATING_ANCHOR

        self.store.set_metas({"league_name": config.name, RATING_ANCHOR: config.rating_anchor})
        self.backend = backend or InProcessBackend()
        self.out = out or sys.stderr
        self.stop = stop or StopSwitch()
        used = float(self.store.meta().get(ELAPSED, "0"))
        self.display = LeagueDisplay(config.name, self.folder,
                                     60.0 * config.minutes + (used if this_run else 0.0), used,
                                     config.max_rounds, config.max_rounds != DEFAULT_MAX_ROUNDS,
                                     mode=progress, stream=self.out)
        self.ended = ""
        """How the last ``run`` ended: ``rounds``, ``budget`` or ``stopped`` (or ``""``)."""
        self.kept = ""
        """What a stopped run kept of the round it stopped in (a clause; ``""`` if none)."""
        self._trained: dict[str, int] = {}
        """Iterations each learner trained in the running round (this run)."""
        self._races = [0, 0]
        """Races stored and asked for in the running phase."""
        self.rng = np.random.default_rng(config.seed)
        self.timings: dict[str, float] = {}
        """Seconds spent in each phase of the last round (train, evaluate, place)."""
        for anchor in config.anchors:
            self.store.add_player(player_for(anchor))
        for spec in config.learners:
            self.store.add_player(Player(name=spec.name, kind="learner", role=spec.role,
                                         checkpoint=str(self._latest(spec.name))))
            if config.init is not None and not self._latest(spec.name).exists():
                self._latest(spec.name).parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(player_for(config.init).checkpoint or config.init,
                                self._latest(spec.name))

    # ---- paths and pool

    def _latest(self, learner: str) -> Path:
        return self.folder / "learners" / learner / "latest.pt"

    def snapshots(self) -> list[Player]:
        """Frozen learner snapshots, oldest first."""
        return self.store.players(kind="snapshot")

    def _driver_spec(self, name: str) -> str:
        """What ``make_driver`` builds player ``name`` from."""
        player = self.store.player(name)
        if player is None:
            raise KeyError(name)
        return player.checkpoint or name

    def _opponents(self, spec: LearnerSpec, pool: list[Any], mains: list[str],
                   payoff: Any) -> list[str]:
        """The opponent of each env copy of ``spec``: ``[matchmaking] anchor_share`` of the
        copies against an anchor drawn by ``anchor_weighting``, the rest by the role's
        matchmaking rule, in random order."""
        from h2h_racing.league.pfsp import choose_opponents, pfsp_weights

        cfg = self.config
        fixed = int(round(cfg.matchmaking.anchor_share * cfg.training.num_envs))
        weights = None
        if cfg.matchmaking.anchor_weighting != "uniform":
            weights = pfsp_weights(payoff.win_rates(spec.name, list(cfg.anchors)),
                                   cfg.matchmaking.anchor_weighting)
        names = [str(name) for name in self.rng.choice(list(cfg.anchors), size=fixed,
                                                       p=weights)]
        names += choose_opponents(self.rng, spec.name, spec.role, pool, mains, payoff,
                                  cfg.training.num_envs - fixed)
        return [names[i] for i in self.rng.permutation(len(names))]

    def _pool(self) -> list[Any]:
        from h2h_racing.league.pfsp import PoolEntry

        pool = [PoolEntry(name=a, role="scripted", parent=None) for a in self.config.anchors]
        pool += [PoolEntry(name=s.name, role=s.role or "main", parent=s.parent)
                 for s in self.snapshots()]
        return pool

    # ---- state kept in the store

    def _round(self) -> int:
        return int(self.store.meta().get("round", "0"))

    def _learner_meta(self, learner: str, key: str, default: float = 0.0) -> float:
        return float(self.store.meta().get(f"{learner}.{key}", str(default)))

    def _payoff(self) -> Any:
        from h2h_racing.league.pfsp import Payoff

        return Payoff.from_races(self._paired("eval"), decay=self.config.matchmaking.payoff_decay)

    def _paired(self, kind: str) -> list[dict[str, float]]:
        """Results of the stored ``kind`` races, both legs of a start point (one from each
        grid slot) scored as one result so the grid does not decide it
        (``league.racecraft``)."""
        from h2h_racing.league.racecraft import paired_races

        return paired_races(self.store.matches(context=self._context(kind))).races

    def _context(self, kind: str) -> str:
        return f"league:{self.config.name}:{kind}"

    # ---- the loop

    def run(self) -> str:
        """Run rounds until the time budget or the round cap is spent or ``stop`` asks for a
        stop (see the module docstring); return how it ended (``ended``)."""
        cfg = self.config
        first = self._round()
        display = self.display
        display.started = time.monotonic()  # the budget's clock runs from here
        minutes = display.budget / 60.0
        used = display.used / 60.0
        if first >= cfg.max_rounds:
            self._say(f"all {cfg.max_rounds} rounds (max_rounds) of {self.folder} are played: "
                      f"nothing to train")
            return self._end("rounds")
        if display.left() <= 0:
            self._say(f"its {minutes_text(minutes)}-minute budget is spent ({used:.1f} min over "
                      f"{first} rounds in {self.folder}): nothing to train; give a larger "
                      f"--minutes for the league's time in all, or --this-run for more "
                      f"minutes now")
            return self._end("budget")
        meta = self.store.meta()
        resumed = first or display.used or any(f"{spec.name}.trained_round" in meta
                                              for spec in cfg.learners)
        verb = f"resuming at round {first + 1}" if resumed else "starting"
        self._say(f"{verb} in {self.folder}: {used:.1f} of {minutes_text(minutes)} min used, "
                  f"{display.left() / 60:.1f} left; log in {display.log_path}")
        display.phase(first, "starting", None, rounds_done=first)
        display.start()
        ended = "rounds"
        try:
            for round_index in range(first, cfg.max_rounds):
                try:
                    if self._stopping():
                        raise RoundStopped("")  # before the round: nothing of it to keep
                    self.round(round_index)
                except RoundStopped as stopped:
                    self.kept = self._kept(round_index, stopped.args[0])
                    ended = "stopped" if self.stop.requested else "budget"
                    break
                finally:
                    self._save_clock()
                self.store.set_meta("round", str(round_index + 1))
                self._show(round_index, display.elapsed() / 60.0)
        finally:
            display.close(ended != "stopped", self._round(),
                          "budget spent" if ended == "budget" else "done")
        return self._end(ended)

    def _end(self, ended: str) -> str:
        """Finish a run that ``ended`` so (a stopped one is left as it is, to be resumed)."""
        self.ended = ended
        if ended != "stopped" and self.config.main_restore.finish_on_best:
            for spec in self.config.learners:
                if spec.role == "main":
                    self._finish_on_best(spec.name)
        return ended

    def _stopping(self) -> bool:
        """Whether the run must stop at this safe point: a stop request or the budget."""
        return self.stop.requested or self.display.left() <= 0

    def _save_clock(self) -> None:
        self.store.set_meta(ELAPSED, repr(self.display.elapsed()))

    def _kept(self, round_index: int, phase: str) -> str:
        """What is kept of round ``round_index``, stopped in ``phase`` ("" before it)."""
        full = self.config.training.iterations_per_round
        trained = ", ".join(f"{name} {done}/{full}" for name, done in self._trained.items())
        if phase == "train":
            kept = f"its training ({trained} iterations)" if trained else "no training"
        else:
            kept = f"its training and {self._races[0]} of {self._races[1]} {phase} races"
        return f"round {round_index + 1} stopped in its {phase} phase: kept {kept}" if phase \
            else ""

    def _say(self, text: str) -> None:
        """A line on the display and in the log, after the league's name."""
        self.display.say(f"[league {self.config.name}] {text}")

    def round(self, round_index: int) -> None:
        """One round: matchmaking, training, evaluation, snapshots, ratings."""
        from h2h_racing.league.pfsp import resets_on_snapshot, should_snapshot

        cfg = self.config
        track = cfg.tracks[round_index % len(cfg.tracks)]
        payoff = self._payoff()
        pool = self._pool()
        mains = [s.name for s in cfg.learners if s.role == "main"]
        jobs = []
        for spec in cfg.learners:
            discard_pending(self._latest(spec.name).parent,
                            int(self._learner_meta(spec.name, "trained_round", -1)))
        self._trained = {}
        for k, spec in enumerate(cfg.learners):
            if self._learner_meta(spec.name, "trained_round", -1) >= round_index:
                continue  # trained before a restart
            names = self._opponents(spec, pool, mains, payoff)
            specs = tuple(self._opponent_spec(name) for name in names)
            reset = bool(self._learner_meta(spec.name, "reset", 0.0))
            jobs.append(TrainJob(learner=spec.name, role=spec.role,
                                 folder=str(self._latest(spec.name).parent), config=cfg,
                                 round=round_index, track=track, opponents=specs, reset=reset,
                                 seed=cfg.seed + 1000 * round_index + k,
                                 reload=bool(self._learner_meta(spec.name, "reload", 0.0)),
                                 stop_file=str((self.folder / STOP_FILE).resolve()),
                                 deadline=time.time() + self.display.left()))
        folders = [Path(job.folder) for job in jobs]
        total = len(jobs) * cfg.training.iterations_per_round
        self.display.phase(round_index, "train", lambda: (
            sum(read_progress(f, round_index) for f in folders), total), "iterations")
        clock = time.perf_counter()
        for job, stats in self.backend.map(train_round, jobs):
            name = job.learner
            if not stats.get("iterations", 1):
                continue  # stopped before its first iteration: the round is not its yet
            self._trained[name] = int(stats.get("iterations", cfg.training.iterations_per_round))
            self.store.set_metas({
                f"{name}.steps": str(int(self._learner_meta(name, "steps") + stats["steps"])),
                f"{name}.reset": "0",
                f"{name}.reload": "0",
                f"{name}.trained_round": str(round_index),
                f"{name}.rounds_since_snapshot":
                    str(int(self._learner_meta(name, "rounds_since_snapshot")) + 1)})
            # Recorded: now the round's state is the learner's (a kill before this line is
            # settled by discard_pending at the next start).
            install_pending(self._latest(name).parent, round_index)
        self.timings["train"] = time.perf_counter() - clock
        if self._stopping() or len(self._trained) < len(jobs):
            raise RoundStopped("train")
        clock = time.perf_counter()
        self._evaluate(round_index, track)
        self.timings["evaluate"] = time.perf_counter() - clock
        if cfg.main_restore.margin is not None:
            for name in mains:
                self._keep_best(name, round_index)
        clock = time.perf_counter()
        payoff = self._payoff()
        for spec in cfg.learners:
            # AlphaStar judges a main exploiter against the mains, the others against the
            # whole pool.
            judged = mains if spec.role == "main_exploiter" else [p.name for p in pool]
            since = int(self._learner_meta(spec.name, "rounds_since_snapshot"))
            if should_snapshot(since >= cfg.snapshots.min_rounds,
                               since >= cfg.snapshots.max_rounds,
                               payoff.win_rates(spec.name, judged), cfg.snapshots.threshold):
                self._snapshot(spec, reset=resets_on_snapshot(self.rng, spec.role))
        self._place(round_index)
        self.timings["place"] = time.perf_counter() - clock

    def _opponent_spec(self, name: str) -> str:
        """Driver spec of a matchmaking choice (a learner's name means its latest weights)."""
        if any(s.name == name for s in self.config.learners):
            latest = self._latest(name)
            if latest.exists():
                return str(latest)
            return self.config.rating_anchor
        return self._driver_spec(name)

    def _jobs(self, kind: str, round_index: int | None, pairs: list[tuple[str, str]],
              track: str, races: int) -> list[Job]:
        """2-car jobs of ``pairs`` (both seat orders) not yet stored (for this round)."""
        context = self._context(kind)
        prefix = context if round_index is None else f"{context}:round={round_index}"
        done = self.store.done_keys(prefix + ":")
        # Evaluation races start at new points every round; placement races at fixed ones.
        seed = self.config.seed + (0 if round_index is None else 7919 * (round_index + 1))
        jobs = [make_job(track, (a, b), {a: self._opponent_spec(a), b: self._opponent_spec(b)},
                         PAIR_ORDERS, range(races), prefix, done, laps=self.config.races.laps,
                         seed=seed, context=context) for a, b in pairs]
        return [job for job in jobs if job is not None]

    def _evaluate(self, round_index: int, track: str) -> None:
        """Each learner against the anchors, the most recent snapshots and the other
        learners."""
        cfg = self.config
        snapshots = [s.name for s in self.snapshots()]
        recent = cfg.races.eval_recent
        opponents = list(cfg.anchors) + (snapshots[-recent:] if recent else [])
        learners = [s.name for s in cfg.learners]
        pairs = [(learner, other) for learner in learners for other in opponents]
        pairs += [(a, b) for i, a in enumerate(learners) for b in learners[i + 1:]]
        self._play(self._jobs("eval", round_index, pairs, track, cfg.races.eval_races),
                   round_index, "evaluate")

    def _play(self, jobs: list[Job], round_index: int, phase: str) -> None:
        """Run ``jobs`` and store their races; ``RoundStopped`` when the run must stop (the
        races of the jobs still running are dropped, and run when the round resumes)."""
        self._races = [0, sum(len(job.keys) for job in jobs)]
        self.display.phase(round_index, phase, lambda: (self._races[0], self._races[1]),
                           "races")
        try:
            for _job_done, records in self.backend.map(run_job, jobs, stop=self._stopping):
                for record in records:
                    self.store.record_match(record)
                self._races[0] += len(records)
                self.display.draw()
        except JobsStopped:
            raise RoundStopped(phase) from None

    def _snapshot(self, spec: LearnerSpec, reset: bool) -> None:
        """Freeze ``spec``'s latest weights into a new player (placed by ``_place``)."""
        count = sum(1 for s in self.snapshots() if s.parent == spec.name)
        name = f"{spec.name}_v{count + 1}"
        path = self.folder / "snapshots" / f"{name}.pt"
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic(lambda p: shutil.copyfile(self._latest(spec.name), p), path)
        steps = int(self._learner_meta(spec.name, "steps"))
        # The snapshot and its learner's counters in one transaction: a kill between two
        # writes left the snapshot without the reset counter, and the resumed round froze
        # the same weights again as main_v2.
        self.store.add_player(Player(name=name, kind="snapshot", role=spec.role,
                                     parent=spec.name, checkpoint=str(path),
                                     checkpoint_sha256=file_sha256(path),
                                     training_steps=steps),
                              metas={f"{spec.name}.rounds_since_snapshot": "0",
                                     f"{spec.name}.reset": "1" if reset else "0"})

    def _place(self, round_index: int) -> None:
        """Placement races that are not stored yet: the anchors against each other, and every
        snapshot against every older frozen player (anchors and earlier snapshots); then refit
        the ratings."""
        anchors = list(self.config.anchors)
        pairs = [(a, b) for i, a in enumerate(anchors) for b in anchors[i + 1:]]
        older = list(anchors)
        for snapshot in self.snapshots():
            pairs += [(snapshot.name, other) for other in older]
            older.append(snapshot.name)
        jobs = [job for track in self.config.rating_tracks
                for job in self._jobs("placement", None, pairs, track,
                                      self.config.races.placement_races)]
        if jobs:
            self._play(jobs, round_index, "place")
            self._rate()

    def league_steps(self) -> int:
        """Agent steps trained by all learners together."""
        return int(sum(self._learner_meta(s.name, "steps") for s in self.config.learners))

    def _rate(self) -> None:
        from h2h_racing.league.ratings import standings

        races = self._paired("placement")
        if not races:
            return
        rows = standings(races, anchor=self.config.rating_anchor, n_boot=100,
                         rng=np.random.default_rng(self.config.seed))
        self.store.record_ratings("bradley_terry", {r.player: r.rating for r in rows},
                                  {r.player: (r.low, r.high) for r in rows},
                                  training_steps=self.league_steps(), matches=len(races))

    def standings(self) -> list[Any]:
        """Current standings of the frozen players (placement races)."""
        from h2h_racing.league.ratings import standings

        races = self._paired("placement")
        return standings(races, anchor=self.config.rating_anchor, n_boot=100,
                         rng=np.random.default_rng(self.config.seed)) if races else []

    def _show(self, round_index: int, minutes: float) -> None:
        """The round's line: the top of the league's table (``league.table``; without its
        intervals) and where the time went."""
        from h2h_racing.league.table import table_rows

        rows = table_rows(self.store, n_boot=0)[0][:3]
        top = ", ".join(f"{r.player} {r.rating:.0f}" for r in rows) or "-"
        self._say(
            f"round {round_index + 1}  {minutes:5.1f} min  "
            f"{self.league_steps() / 1e6:6.2f} M steps  snapshots {len(self.snapshots())}  "
            f"top: {top}  (train {self.timings.get('train', 0):.0f} s, evaluate "
            f"{self.timings.get('evaluate', 0):.0f} s, place {self.timings.get('place', 0):.0f} s)")
        self._show_racecraft(round_index)

    def _show_racecraft(self, round_index: int) -> None:
        """Each learner's record against the anchors in the round's evaluation races, by
        grid slot (``league.racecraft``)."""
        from h2h_racing.league.racecraft import racecraft_records

        context = self._context("eval")
        matches = [m for m in self.store.matches(context=context)
                   if round_of(m.key, context) == round_index]
        for spec in self.config.learners:
            record = racecraft_records(matches, spec.name, self.config.anchors).get("all")
            if record is not None:
                record = dataclasses.replace(record, opponent="the anchors")
                self.display.say(f"  {record.line()}")

    def close(self) -> None:
        """Release the store and the backend; race jobs a stop or the budget left running are
        ended, not waited for (after a finished run none are)."""
        self.store.close()
        self.backend.close(now=True)
