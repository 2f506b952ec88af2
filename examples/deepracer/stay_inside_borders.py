"""Stay inside the borders: reward keeping all wheels on the track, away from the edge."""


def reward_function(params):
    reward = 1e-3
    margin = 0.5 * params["track_width"] - params["distance_from_center"]
    if params["all_wheels_on_track"] and margin >= 0.05:
        reward = 1.0
    return float(reward)
