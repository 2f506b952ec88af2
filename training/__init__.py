"""The training adapter: rsl-rl's VecEnv over the batched core, PPO and imitation training,
the policy file format, evaluation and export."""
