"""racing_line's ``box_edge_room``: ``box_edge`` only beside the boxes with less room than it
(step 10 of obstacle_generalist, issue 36)."""

from __future__ import annotations

import numpy as np
import pytest

from h2h_racing.policies import make_driver, race_core
from h2h_racing.policies.obstacles import avoid_obstacles

from test_box_edge import narrow_stadium  # same folder (pytest puts it on the path)


@pytest.mark.parametrize(("edge_room", "expected"), [(None, 0.30), (0.26, 0.30), (0.24, 0.27),
                                                     (0.1, 0.27)])
def test_box_edge_holds_only_under_the_room_by_hand(edge_room: float | None,
                                                    expected: float) -> None:
    # The 0.6 m stadium of test_box_edge, a 0.4 m box on the right lane 3 m into the bottom
    # straight: the lane is at -0.15 m (half the 0.3 m half-width), the box's left side at
    # -0.15 + 0.2 = +0.05 m, the left border at +0.3 m: 0.25 m of room on the passing side.
    # The clearance (0.2 m) does not fit, so the border clip sets the target: at edge 0 the
    # border itself (0.30 m) where the edge holds (room 0.25 under edge_room 0.26, or no
    # edge_room), else EDGE's 0.3 - 0.03 = 0.27 m (edge_room 0.24 or 0.1: 0.25 is not under).
    track = narrow_stadium()
    core = race_core(track, 1, race_type="object_avoidance",
                     obstacle_positions=((3.0 / track.length, -1),))
    assert core.obstacle_d[0, 0] == pytest.approx(-0.15, abs=1e-6)
    core.s[0, 0] = core.obstacle_s[0, 0]
    core.d[0, 0] = expected  # already on its side: no move-across limit
    out, _ = avoid_obstacles(core, 0, core.s[:, 0] + 0.6, np.array([0.0]), np.array([2.0]),
                             clearance=0.2, edge=0.0, edge_room=edge_room)
    assert out[0] == pytest.approx(expected, abs=1e-9)


def test_box_edge_room_reaches_the_avoidance_only_when_given() -> None:
    assert "edge_room" not in make_driver("racing_line", box_edge=0.0).box_margins
    margins = make_driver("racing_line:box_edge=0:box_edge_room=0.24").box_margins
    assert margins["edge"] == 0.0 and margins["edge_room"] == 0.24
    # The shipped teachers' options (obstacle_generalist/imitate.toml) give neither.
    card = make_driver("racing_line", follow_gap=2.0, closing_speed=0.3, box_clearance=0.2,
                       box_speed_cap=1.8, box_bend_grip=0.35).box_margins
    assert card == {"clearance": 0.2, "speed_cap": 1.8, "bend_grip": 0.35}


def test_box_edge_room_without_box_edge_is_refused() -> None:
    with pytest.raises(ValueError, match=r"box_edge_room \(0.24 m\) limits where box_edge "
                                         r"holds, but box_edge is not given"):
        make_driver("racing_line", box_edge_room=0.24)


@pytest.mark.parametrize("bad", [0.0, 1.5])
def test_box_edge_room_out_of_range_is_refused(bad: float) -> None:
    with pytest.raises(ValueError, match=r"box_edge_room must be in \(0, 1\] m.*got "
                                         + str(bad)):
        make_driver("racing_line", box_edge=0.0, box_edge_room=bad)
    with pytest.raises(ValueError, match="box_edge_room must be a number in"):
        make_driver(f"racing_line:box_edge=0:box_edge_room={bad}")
