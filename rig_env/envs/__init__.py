"""Gymnasium environments of the manoeuvre rig; importing this module registers them.

| id | task | entry_point | vector_entry_point |
|---|---|---|---|
| ``rig_env/VelocityVectorRoll-v0`` | velocity_vector_roll | RigEnv | RigVectorEnv |
| ``rig_env/BankToBank-v0`` | bank_to_bank | RigEnv | RigVectorEnv |
| ``rig_env/ManoeuvreRig-v0`` | any, by the ``task`` argument | RigEnv | RigVectorEnv |

Every id accepts the :class:`RigEnvConfig` fields as keyword arguments, e.g.
``gymnasium.make("rig_env/ManoeuvreRig-v0", task="bank_to_bank", free_dofs=("rig_roll",), airspeed=18.0)``
or ``gymnasium.make_vec("rig_env/VelocityVectorRoll-v0", num_envs=1024, vectorization_mode="vector_entry_point")``.
SB3: :class:`rig_env.envs.sb3.RigSB3VecEnv` (imported lazily; stable-baselines3 is optional).
"""

from __future__ import annotations

import gymnasium

from rig_env.envs.config import RigEnvConfig
from rig_env.envs.env import RigEnv
from rig_env.envs.tasks import TASKS, BankToBank, Task, VelocityVectorRoll
from rig_env.envs.vector_env import RigVectorEnv

ENV_IDS: dict[str, dict[str, str]] = {
    "rig_env/VelocityVectorRoll-v0": {"task": "velocity_vector_roll"},
    "rig_env/BankToBank-v0": {"task": "bank_to_bank"},
    "rig_env/ManoeuvreRig-v0": {},
}


def register_envs() -> None:
    """Register the ids above (idempotent)."""
    for env_id, kwargs in ENV_IDS.items():
        if env_id in gymnasium.registry:
            continue
        gymnasium.register(
            id=env_id,
            entry_point="rig_env.envs.env:RigEnv",
            vector_entry_point="rig_env.envs.vector_env:RigVectorEnv",
            kwargs=dict(kwargs),
            disable_env_checker=False,
        )


register_envs()

__all__ = ["ENV_IDS", "TASKS", "BankToBank", "RigEnv", "RigEnvConfig", "RigVectorEnv", "Task", "VelocityVectorRoll", "register_envs"]
