"""Stateful: reward progress made since the previous call (module-level state).

The module remembers the last progress and step, so it must be loaded once per car.
"""

last_progress = 0.0
last_steps = 0.0


def reward_function(params):
    global last_progress, last_steps
    steps = params["steps"]
    progress = params["progress"]
    if steps <= last_steps or steps == 1.0:
        # A new episode: forget the previous one.
        last_progress = 0.0
    gained = progress - last_progress
    last_progress = progress
    last_steps = steps
    if params["is_offtrack"] or params["is_crashed"]:
        return 1e-3
    return float(max(gained, 0.0) + 1e-3)
