"""Head-to-bot: stay on track, drive fast, and pass the bot cars in the other lane.

DeepRacer's params give every bot: objects_location (x, y), objects_left_of_center,
objects_speed (the bots' speed) and objects_heading (radians); closest_objects is
[the object just behind, the object just ahead] along the track.
"""

import math


def reward_function(params):
    if params["is_offtrack"] or params["is_crashed"]:
        return 1e-3
    width = params["track_width"]
    on_track = params["all_wheels_on_track"] and params["distance_from_center"] <= 0.5 * width
    reward = 1.0 if on_track else 0.1
    # Speed, while the way ahead is clear.
    reward += 0.5 * params["speed"]
    objects = params["objects_location"]
    if not objects:
        return float(reward)
    x, y = params["x"], params["y"]
    behind, ahead = params["closest_objects"]
    for index, weight in ((ahead, 1.0), (behind, 0.5)):
        ox, oy = objects[index]
        gap = math.hypot(x - ox, y - oy)
        same_lane = params["objects_left_of_center"][index] == params["is_left_of_center"]
        if same_lane and gap < 1.0:
            # Closing in on a bot in our lane: change lanes before reaching it.
            reward *= 1.0 - 0.8 * weight * (1.0 - gap)
        elif not same_lane and gap < 0.6 and index == ahead:
            # Beside a bot in the other lane: passing it.
            reward += 0.5
    return float(max(reward, 1e-3))
