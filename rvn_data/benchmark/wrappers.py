"""Observation wrappers for `RVNEnv`."""
from __future__ import annotations

from collections import deque

import gymnasium as gym
import numpy as np
from gymnasium import spaces


class RGBFrameStack(gym.Wrapper):
    """Stack the last ``context`` RGB frames into ``rgb`` uint8 [C, H, W, 3], oldest first.

    At reset the first frame fills the stack (repeated); new goals within an episode do
    not clear it (the scene and pose carry on). Other observation keys pass through.
    """

    def __init__(self, env: gym.Env, context: int):
        super().__init__(env)
        if isinstance(context, bool) or not isinstance(context, int) or context < 1:
            raise ValueError(f"RGBFrameStack context={context!r} must be a positive integer")
        self.context = context
        rgb = env.observation_space["rgb"]
        low = np.repeat(rgb.low[None], context, axis=0)
        high = np.repeat(rgb.high[None], context, axis=0)
        self.observation_space = spaces.Dict(
            {**env.observation_space.spaces, "rgb": spaces.Box(low, high, dtype=rgb.dtype)})
        self._frames: deque = deque(maxlen=context)

    def _stacked(self, obs: dict) -> dict:
        return {**obs, "rgb": np.stack(self._frames, axis=0)}

    def reset(self, *, seed=None, options=None):
        obs, info = self.env.reset(seed=seed, options=options)
        self._frames.clear()
        for _ in range(self.context):
            self._frames.append(obs["rgb"])
        return self._stacked(obs), info

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._frames.append(obs["rgb"])
        return self._stacked(obs), reward, terminated, truncated, info
