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

Rendering: ``RigSB3VecEnv(n, render_mode="rgb_array")``: ``get_images()`` is the list of the batch's
frames ((448, 1024, 3) uint8 each, :mod:`rig_env.envs.render`), ``render()`` SB3's tiling of them, so
``VecVideoRecorder`` records (``metadata["render_fps"]`` is the control rate: real time).  With
``render_mode="human"`` ``render()`` shows environment 0 in the batch's window.  ``get_attr("spec")`` is
the ``EnvSpec`` that ``gymnasium.make`` would build for one environment of the batch (id, keyword
overrides, ``max_episode_steps``).  :func:`as_sb3_vec_env` turns what a user holds into what SB3 takes,
and names this adapter when it gets a Gymnasium ``VectorEnv`` that SB3 would refuse.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Sequence

import gymnasium as gym
import numpy as np
from gymnasium.envs.registration import EnvSpec
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvObs, VecEnvStepReturn

from rig_env.envs.config import RigEnvConfig
from rig_env.envs.vector_env import RigVectorEnv, _autoreset_mode, action_array


class RigSB3VecEnv(VecEnv):
    """``RigSB3VecEnv(num_envs, config=None, render_mode=None, **fields)`` or ``RigSB3VecEnv.wrap(vector_env)``.

    ``fields``: :class:`rig_env.envs.config.RigEnvConfig` fields; ``render_mode`` None, "rgb_array" or
    "human".  The batch is always same-step (SB3's protocol); a wrapped ``RigVectorEnv`` must be too, and
    ``autoreset_mode`` among the fields anything but same-step is a ``ValueError``.  Actions are
    ``(num_envs, n_actions)`` (an array of that size in another shape is reshaped to it); anything else, or
    strings or complex numbers, is a ``ValueError`` naming the expected shape.
    """

    def __init__(
        self,
        num_envs: int = 1,
        config: RigEnvConfig | None = None,
        *,
        vec: RigVectorEnv | None = None,
        render_mode: str | None = None,
        **fields: Any,
    ) -> None:
        mode = vec.metadata["autoreset_mode"] if vec is not None else _autoreset_mode(fields.get("autoreset_mode", AutoresetMode.SAME_STEP))
        if mode is not AutoresetMode.SAME_STEP:
            raise ValueError("RigSB3VecEnv: the RigVectorEnv must use same-step autoreset (SB3's protocol), not next-step")
        self.vec = vec if vec is not None else RigVectorEnv(num_envs, config, render_mode=render_mode, **fields)
        super().__init__(self.vec.num_envs, self.vec.single_observation_space, self.vec.single_action_space)
        self.metadata = {**self.metadata, "render_fps": self.vec.metadata["render_fps"]}  # VecVideoRecorder's frame rate
        self._actions: Any = None

    @classmethod
    def wrap(cls, vec: RigVectorEnv) -> "RigSB3VecEnv":
        """The adapter over an existing same-step ``RigVectorEnv`` (its arrays, no copy)."""
        if not isinstance(vec, RigVectorEnv):
            raise TypeError(_not_a_rig_batch(vec))
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
        self._actions = actions  # checked by step_wait (ValueError naming the expected shape)

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("step_async must be called before step_wait")
        actions, self._actions = self._actions, None
        a = action_array(actions, (self.num_envs, len(self.vec.action_names)), self.vec.action_names, exact=False)
        obs, rew, term, trunc, infos = self.vec.step(a)
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
        """The batch's attribute, once per index (one shared batch); ``"spec"``: each environment's ``EnvSpec``."""
        value = env_spec(self.vec) if attr_name == "spec" else getattr(self.vec, attr_name)
        return [value] * len(self._idx(indices))

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        if len(self._idx(indices)) != self.num_envs:
            raise ValueError("RigSB3VecEnv: attributes are shared by the batch; set them for all environments")
        setattr(self.vec, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **method_kwargs: Any) -> list[Any]:
        raise NotImplementedError(f"RigSB3VecEnv has no per-environment objects to call {method_name!r} on; use .vec")

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        return [False] * len(self._idx(indices))

    def get_images(self) -> Sequence[np.ndarray | None]:
        """rgb_array: the (448, 1024, 3) uint8 frame of every environment; otherwise Nones (SB3's convention)."""
        if self.render_mode != "rgb_array":
            return [None] * self.num_envs
        frames = self.vec.render()
        return [frames[i] for i in range(self.num_envs)]

    def render(self, mode: str | None = None) -> np.ndarray | None:
        """rgb_array: the batch's frames tiled (SB3's ``VecEnv.render``); human: show environment 0, None."""
        if self.render_mode == "human" and mode in (None, "human"):
            self.vec.render()
            return None
        return super().render(mode)


def env_spec(vec: RigVectorEnv) -> EnvSpec:
    """The ``EnvSpec`` ``gymnasium.make`` gives one environment of ``vec``: the task's registered id (the
    generic ``rig_env/ManoeuvreRig-v0`` for a task without one), keyword arguments the task and the
    configuration fields that differ from the defaults, ``max_episode_steps`` the batch's episode length,
    control steps; ``gymnasium.make(spec)`` builds that environment."""
    import gymnasium

    from rig_env.envs.registration import ENV_IDS, register_envs

    register_envs()
    cfg, default = vec.config, RigEnvConfig()
    kwargs = {f.name: getattr(cfg, f.name) for f in dataclasses.fields(cfg) if getattr(cfg, f.name) != getattr(default, f.name)}
    if cfg.rate_filter_derived:  # derived from the control rate: so it is again
        kwargs.pop("rate_filter_hz", None)
    env_id = next((i for i, kw in ENV_IDS.items() if kw.get("task") == cfg.task), "rig_env/ManoeuvreRig-v0")
    kwargs = {**ENV_IDS[env_id], "task": cfg.task, **kwargs}  # as gymnasium.make records them: the id's, then the overrides
    if vec.render_mode is not None:
        kwargs["render_mode"] = vec.render_mode
    return dataclasses.replace(gymnasium.spec(env_id), kwargs=kwargs, max_episode_steps=vec.max_steps)


def _not_a_rig_batch(env: Any) -> str:
    return (
        f"{type(env).__name__} is a Gymnasium VectorEnv, which stable-baselines3 does not accept; "
        "use rig_env.envs.sb3.RigSB3VecEnv(num_envs, task=..., ...) (the same batch behind SB3's VecEnv protocol) "
        "or RigSB3VecEnv.wrap(rig_vector_env) for an existing same-step RigVectorEnv (unwrapped: SB3 has its own "
        "VecNormalize, VecVideoRecorder, ...)"
    )


def as_sb3_vec_env(env: Any) -> VecEnv | gym.Env:
    """What SB3 takes for ``env``: an SB3 ``VecEnv`` or a ``gymnasium.Env`` unchanged, a ``RigVectorEnv`` as
    :class:`RigSB3VecEnv` over it; any other Gymnasium ``VectorEnv`` (e.g. a ``RigVectorEnv`` inside
    Gymnasium vector wrappers, or a ``SyncVectorEnv``) is a ``TypeError`` naming :class:`RigSB3VecEnv`."""
    if isinstance(env, (VecEnv, gym.Env)):
        return env
    if isinstance(env, RigVectorEnv):
        return RigSB3VecEnv.wrap(env)
    if isinstance(env, gym.vector.VectorEnv):
        raise TypeError(_not_a_rig_batch(env))
    raise TypeError(f"{type(env).__name__}: expected an SB3 VecEnv, a gymnasium.Env or a RigVectorEnv")


