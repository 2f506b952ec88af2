"""``training.tracks._retried``: a random track that finds no valid loop is drawn again, up to
``DRAW_CALLS`` calls, before the run stops (issue 36's step 5: seed 2 of ppo_generalist/routes
stopped after 871 iterations when five calls in a row failed)."""

from __future__ import annotations

import pytest

from h2h_racing.training import tracks


def failing(times: int) -> tuple[list[int], object]:
    """A draw that raises ``RuntimeError`` (as ``random_track`` does) ``times`` times, then
    returns "track"; the list counts the calls."""
    calls: list[int] = []

    def draw() -> str:
        calls.append(1)
        if len(calls) <= times:
            raise RuntimeError(f"no valid loop (call {len(calls)})")
        return "track"

    return calls, draw


def test_five_failures_in_a_row_no_longer_stop_the_run():
    # The old code made five calls and raised the fifth failure.
    calls, draw = failing(5)
    assert tracks._retried(draw) == "track"
    assert len(calls) == 6


def test_a_first_success_is_one_call():
    calls, draw = failing(0)
    assert tracks._retried(draw) == "track"
    assert len(calls) == 1


def test_the_last_calls_failure_is_raised_after_draw_calls():
    calls, draw = failing(10 ** 6)
    with pytest.raises(RuntimeError, match=f"call {tracks.DRAW_CALLS}\\)"):
        tracks._retried(draw)
    assert len(calls) == tracks.DRAW_CALLS == 20
