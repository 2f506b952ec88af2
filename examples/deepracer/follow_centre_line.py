"""Follow the centre line: reward bands of distance from the centre (DeepRacer style)."""


def reward_function(params):
    width = params["track_width"]
    distance = params["distance_from_center"]
    # Three bands: 10 %, 25 % and 50 % of the track width from the centre line.
    if distance <= 0.1 * width:
        reward = 1.0
    elif distance <= 0.25 * width:
        reward = 0.5
    elif distance <= 0.5 * width:
        reward = 0.1
    else:
        reward = 1e-3
    return float(reward)
