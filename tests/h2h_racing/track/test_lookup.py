"""Arc-position differences wrapped to the nearer way round the lap (``track.lookup``)."""

from __future__ import annotations

import numpy as np

from h2h_racing.track.lookup import wrap_arc, wrap_arcs


def test_wrap_arcs_takes_the_nearer_way_round() -> None:
    # On a 10 m lap: 9.5 m ahead is 0.5 m behind, -9.5 m is 0.5 m ahead, 5 m (half a lap)
    # wraps to -5 (the interval is [-5, 5)), 23 m is 3 m ahead, -0.25 stays.
    delta = np.array([9.5, -9.5, 5.0, 23.0, -0.25, 0.0])
    want = np.array([-0.5, 0.5, -5.0, 3.0, -0.25, 0.0])
    np.testing.assert_allclose(wrap_arcs(delta, 10.0), want, atol=1e-12)
    # The compiled scalar form agrees, element by element.
    np.testing.assert_allclose([wrap_arc(x, 10.0) for x in delta], want, atol=1e-12)


def test_wrap_arcs_broadcasts_a_length_per_row() -> None:
    # Two copies on laps of 10 m and 4 m, the same differences: each row wraps by its own lap.
    delta = np.array([[3.0, 6.0], [3.0, 6.0]])
    lengths = np.array([[10.0], [4.0]])
    np.testing.assert_allclose(wrap_arcs(delta, lengths), [[3.0, -4.0], [-1.0, -2.0]],
                               atol=1e-12)
