"""Keeping a main agent's best state (``[main_restore]``, ``LeagueConfig.main_restore``): the
exploit step of population-based training with the main's own past as the population.

After each round's evaluation races, a main's *record* is its worst clean win rate from behind
against the anchors over the last ``window`` rounds. A record better than the best so far saves
the main's state as ``learners/<main>/best/``; a record ``margin`` below the best puts that
state back (the next round rebuilds the learner from it). With ``finish_on_best`` a run that
ends (budget or round cap) leaves each main at its best-record state.

``KeepsBest`` holds these steps as methods of ``League`` (``league.selfplay``), whose store,
config and learner folders they use.
"""

from __future__ import annotations

from typing import Any

from h2h_racing.league.learners import copy_state


def round_of(key: str, context: str) -> int:
    """The round of an evaluation match key ``<context>:round=<r>:...`` (``League._jobs``)."""
    head = f"{context}:round="
    if not key.startswith(head):
        raise ValueError(f"match key {key!r} is not a round's evaluation key ({head}<r>:...)")
    return int(key[len(head):].split(":", 1)[0])


class KeepsBest:
    """``League``'s steps that keep and put back a main's best state (see the module
    docstring); a mixin: ``League`` provides ``config``, ``store``, ``_latest``,
    ``_learner_meta``, ``_context``, ``_round`` and ``_say``."""

    config: Any
    store: Any

    def record(self, learner: str, round_index: int) -> float | None:
        """``learner``'s worst *clean win rate from behind* against the anchors in the
        evaluation races of rounds ``round_index - window + 1`` to ``round_index``
        (``[main_restore] window``): over the races it started behind an anchor, the share it
        won without causing a crash. None if it did not start behind every anchor in them.

        Races from the front are left out because the grid decides them (the front car wins
        unless passed), and a win by contact does not count: issue 20's targets are wins from
        behind with few crashes caused, and this is the record that picks the state."""
        from h2h_racing.league.racecraft import racecraft_records

        first = round_index - self.config.main_restore.window + 1
        context = self._context("eval")
        anchors = list(self.config.anchors)
        window = [m for m in self.store.matches(context=context)
                  if first <= round_of(m.key, context) <= round_index]
        records = racecraft_records(window, learner, anchors)
        if any(a not in records or records[a].races_behind == 0 for a in anchors):
            return None
        return min(records[a].clean_wins_behind / records[a].races_behind for a in anchors)

    def _keep_best(self, learner: str, round_index: int) -> None:
        """Save ``learner``'s state when its record is the best so far; put the best state
        back when its record is more than ``[main_restore] margin`` below the best
        (``LeagueConfig.main_restore``). Files first, then the store: a run killed in
        between repeats the same copies when it resumes the round."""
        cfg = self.config
        window = cfg.main_restore.window
        if round_index < self._learner_meta(learner, "judge_from", window - 1):
            return
        record = self.record(learner, round_index)
        if record is None:
            return
        folder = self._latest(learner).parent
        best = self._learner_meta(learner, "best_record", -1.0)
        if record > best:
            copy_state(folder, folder / "best")
            self.store.set_metas({f"{learner}.best_record": repr(record),
                                  f"{learner}.best_round": str(round_index)})
        elif record < best - cfg.main_restore.margin:
            restores = int(self._learner_meta(learner, "restores")) + 1
            self._put_back_best(learner, round_index, {f"{learner}.restores": str(restores)})
            best_round = int(self._learner_meta(learner, "best_round"))
            self._say(
                f"round {round_index + 1}: {learner}'s record against the "
                f"anchors {record:.2f} < best {best:.2f} - {cfg.main_restore.margin}: restored "
                f"its state after round {best_round + 1}")

    def _put_back_best(self, learner: str, round_index: int,
                       metas: dict[str, str] | None = None) -> None:
        """Copy ``learner``'s best state over its latest after round ``round_index`` and
        store ``metas`` with the reload: the next round rebuilds the learner from there, and
        its next record is judged on a full window of races after it."""
        folder = self._latest(learner).parent
        copy_state(folder / "best", folder)
        self.store.set_metas({
            **(metas or {}), f"{learner}.reload": "1",
            f"{learner}.judge_from": str(round_index + self.config.main_restore.window)})

    def _finish_on_best(self, learner: str) -> None:
        """Leave ``learner`` at its best-record state at the end of a run
        (``[main_restore] finish_on_best``); nothing if it is there already or no record
        was ever made."""
        meta = self.store.meta()
        last = self._round() - 1
        if f"{learner}.best_round" not in meta or int(meta[f"{learner}.best_round"]) == last:
            return
        self._put_back_best(learner, last)
        best_round = int(meta[f"{learner}.best_round"])
        self._say(
            f"finished {learner} on its best record "
            f"({float(meta[f'{learner}.best_record']):.2f}): its state after round "
            f"{best_round + 1}, not round {last + 1}")
