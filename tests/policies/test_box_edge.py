"""racing_line's ``box_edge``: where the clearance does not fit beside a box, how near the
border the car's centre goes (step 9 of obstacle_generalist, issue 36)."""

from __future__ import annotations


import numpy as np
import pytest

from h2h_racing.policies import make_driver, race_core
from h2h_racing.policies.obstacles import avoid_obstacles
from h2h_racing.track.shape import Track

from conftest import stadium_track


def narrow_stadium() -> Track:
    """6 m straights and left-hand semicircles of radius 1 m, 0.3 m half-width (a 0.6 m track,
    the generator's narrowest)."""
    return stadium_track(1.0, 6.0, 0.3, name="narrow_stadium")


@pytest.mark.parametrize(("edge", "expected"), [(None, 0.27), (0.03, 0.27), (0.0, 0.30),
                                                (-0.03, 0.33)])
def test_the_border_bounds_the_target_beside_a_box_by_hand(edge: float | None,
                                                          expected: float) -> None:
    # A box on the right lane in the middle of the bottom straight (3 m in: no curvature, no
    # box ends sticking out, no coarse waypoint). The clearance wants the car's centre
    # w/2 + car width/2 + clearance = 0.2 + 0.09805 + 0.2 m left of the box's centre line, at
    # d_box + 0.498 > 0.3 m, past the left border: the target is clipped to the border less
    # the edge: 0.3 - 0.03 = 0.27 m by default (obstacles.EDGE), 0.30 m at edge 0, 0.33 m at
    # -0.03 (the centre 3 cm outside the border, the inner wheels 5 cm inside it).
    track = narrow_stadium()
    core = race_core(track, 1, race_type="object_avoidance",
                     obstacle_positions=((3.0 / track.length, -1),))
    s_box, d_box = core.obstacle_s[0, 0], core.obstacle_d[0, 0]
    assert abs(s_box - 3.0) < 0.01 and d_box < 0.0
    assert d_box + 0.2 + 0.09805 + 0.2 > 0.33
    margins = {} if edge is None else {"edge": edge}
    core.s[0, 0] = s_box
    core.d[0, 0] = expected  # already on its side: no move-across limit
    out, _ = avoid_obstacles(core, 0, core.s[:, 0] + 0.6, np.array([0.0]), np.array([2.0]),
                             clearance=0.2, **margins)
    assert out[0] == pytest.approx(expected, abs=1e-9)


def test_box_edge_reaches_the_avoidance_only_when_given() -> None:
    # Left out, the teacher passes nothing new to avoid_obstacles: its default (EDGE) holds,
    # so the shipped teachers drive as before.
    assert "edge" not in make_driver("racing_line", box_clearance=0.2).box_margins
    assert make_driver("racing_line", box_edge=0.0).box_margins["edge"] == 0.0
    assert make_driver("racing_line", box_edge=-0.08).box_margins["edge"] == -0.08
    # As a spec (evaluate --policy, [imitation] options): the same, range checked.
    assert make_driver("racing_line:box_edge=-0.03").box_margins["edge"] == -0.03
    with pytest.raises(ValueError, match=r"box_edge must be a number in \[-0.08, 0.2\], got '0.3'"):
        make_driver("racing_line:box_edge=0.3")


@pytest.mark.parametrize("bad", [-0.09, 0.25])
def test_box_edge_out_of_range_is_refused(bad: float) -> None:
    with pytest.raises(ValueError, match=r"box_edge must be in \[-0.08, 0.2\] m.*got "
                                         + str(bad)):
        make_driver("racing_line", box_edge=bad)
