"""Roll out random torques in the SagittalWalker-v0 Gymnasium environment, several at once.

    python examples/walker_rollout.py [--quick]
"""

import sys

import gymnasium
import numpy as np

import envs

num_envs, steps = (4, 20) if "--quick" in sys.argv else (64, 1000)

vec = gymnasium.make_vec(envs.ENV_ID, num_envs=num_envs, vectorization_mode="vector_entry_point")
obs, info = vec.reset(seed=0)
rng = np.random.default_rng(0)
returns, falls = np.zeros(num_envs), 0
for _ in range(steps):
    action = 0.1 * rng.standard_normal((num_envs, *vec.single_action_space.shape))
    obs, reward, terminated, truncated, info = vec.step(action.astype(np.float32))
    returns += reward
    falls += int(terminated.sum())
vec.close()
print(f"{num_envs} walkers × {steps} steps: mean return {returns.mean():.2f}, {falls} episodes ended by a fall")
