"""h2h-racing: multi-agent head-to-head racing for reinforcement learning.

>>> import h2h_racing
>>> env = h2h_racing.parallel_env(track="oval", num_cars=2)
>>> obs, infos = env.reset(seed=0)
>>> sorted(obs)
['car_0', 'car_1']
"""

from gymnasium.envs.registration import register as _register_gymnasium_env
from gymnasium.envs.registration import registry as _gymnasium_registry

from h2h_racing.config.env import CarParams, EnvConfig, RaceRules, RewardConfig
from h2h_racing.sim.core import RaceCore
from h2h_racing.envs.parallel import RacingEnv, env, parallel_env
from h2h_racing.track.shape import Track
from h2h_racing.track.io import load_track

__version__ = "0.1.0"

# The single-agent Gymnasium view: gymnasium.make("h2h_racing/Race-v0", ...). The entry point
# is a string, so gymnasium imports h2h_racing.envs.single_agent only when the env is made.
if "h2h_racing/Race-v0" not in _gymnasium_registry:
    _register_gymnasium_env(id="h2h_racing/Race-v0",
                            entry_point="h2h_racing.envs.single_agent:SingleAgentRaceEnv")

__all__ = [
    "CarParams",
    "EnvConfig",
    "RaceCore",
    "RaceRules",
    "RacingEnv",
    "RewardConfig",
    "Track",
    "env",
    "load_track",
    "parallel_env",
]
