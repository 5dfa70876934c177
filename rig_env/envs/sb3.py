"""``RigSB3VecEnv``: a stable-baselines3 ``VecEnv`` directly over the arrays of one :class:`RigVectorEnv`.

SB3 does not accept a Gymnasium ``VectorEnv``; this adapter speaks SB3's protocol with no per-env
Python environments underneath.  Semantics are those of SB3's ``DummyVecEnv`` over ``RigEnv``:

| SB3 | here |
|---|---|
| ``seed(s)`` then ``reset()`` | ``RigVectorEnv.reset(seed=s)``: env ``i`` gets seed ``s + i`` (as DummyVecEnv does) |
| ``reset()`` without a seed | next episode of every env's stream |
| ``step_wait`` on a finished env | same-step reset; ``infos[i]["terminal_observation"]`` is the last observation |
| ``infos[i]["TimeLimit.truncated"]`` | ``truncated and not terminated``, present for every env |
| episode metrics | in ``infos[i]`` of the finishing step (keys of ``RigEnv``'s final info) |

Rewards are float32, dones bool, observations float32 ``(num_envs, obs_dim)``.
"""

from __future__ import annotations

from typing import Any, Sequence

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvObs, VecEnvStepReturn

from rig_env.envs.config import RigEnvConfig
from rig_env.envs.vector_env import RigVectorEnv


class RigSB3VecEnv(VecEnv):
    """``RigSB3VecEnv(num_envs, config=None, **fields)`` or ``RigSB3VecEnv.wrap(vector_env)``."""

    def __init__(self, num_envs: int = 1, config: RigEnvConfig | None = None, *, vec: RigVectorEnv | None = None, **fields: Any) -> None:
        self.vec = vec if vec is not None else RigVectorEnv(num_envs, config, **fields)
        super().__init__(self.vec.num_envs, self.vec.single_observation_space, self.vec.single_action_space)
        self._actions: np.ndarray | None = None

    @classmethod
    def wrap(cls, vec: RigVectorEnv) -> "RigSB3VecEnv":
        return cls(vec=vec)

    # ------------------------------------------------------------------ core protocol
    def reset(self) -> VecEnvObs:
        seeds = self._seeds
        seed = seeds[0]
        if seed is not None and any(s != seed + i for i, s in enumerate(seeds)):
            raise ValueError("RigSB3VecEnv: per-env seeds must be consecutive (use seed(s), which gives s + i)")
        opts = self._options[0] or None
        obs, _ = self.vec.reset(seed=seed, options=opts)
        self.reset_infos = [{} for _ in range(self.num_envs)]
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("step_async must be called before step_wait")
        obs, rew, term, trunc, infos = self.vec.step(self._actions.reshape(self.num_envs, -1))
        self._actions = None
        tl = trunc & ~term
        out: list[dict[str, Any]] = [{"TimeLimit.truncated": bool(tl[i])} for i in range(self.num_envs)]
        if infos:
            fi = infos["final_info"]
            keys = [k for k in fi if not k.startswith("_")]
            for i in np.flatnonzero(infos["_final_obs"]):
                out[i]["terminal_observation"] = infos["final_obs"][i]
                out[i].update({k: fi[k][i].item() for k in keys})
        return obs, rew.astype(np.float32), term | trunc, out

    def close(self) -> None:
        self.vec.close()

    # ------------------------------------------------------------------ attribute access (one shared batch)
    def _idx(self, indices: VecEnvIndices) -> list[int]:
        return list(self._get_indices(indices))

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        return [getattr(self.vec, attr_name)] * len(self._idx(indices))

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        if len(self._idx(indices)) != self.num_envs:
            raise ValueError("RigSB3VecEnv: attributes are shared by the batch; set them for all environments")
        setattr(self.vec, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **method_kwargs: Any) -> list[Any]:
        raise NotImplementedError(f"RigSB3VecEnv has no per-environment objects to call {method_name!r} on; use .vec")

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        return [False] * len(self._idx(indices))

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None] * self.num_envs


