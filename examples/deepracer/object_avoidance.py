"""Object avoidance: stay on track and keep away from the next object in the same lane."""

import math


def reward_function(params):
    on_track = params["all_wheels_on_track"]
    width = params["track_width"]
    distance = params["distance_from_center"]
    reward_lane = 1.0 if on_track and distance <= 0.5 * width else 1e-3
    reward_avoid = 1.0
    objects = params["objects_location"]
    if objects:
        ahead = params["closest_objects"][1]
        ox, oy = objects[ahead]
        gap = math.hypot(params["x"] - ox, params["y"] - oy)
        same_lane = params["objects_left_of_center"][ahead] == params["is_left_of_center"]
        if same_lane:
            # Penalise closing in on an object in our lane: full penalty within 0.3 m.
            if gap < 0.3:
                reward_avoid = 1e-3
            elif gap < 0.5:
                reward_avoid *= 0.2
            elif gap < 0.8:
                reward_avoid *= 0.5
    return float(1.0 * reward_lane + 4.0 * reward_avoid)
