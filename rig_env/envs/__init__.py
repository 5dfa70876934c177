"""Gymnasium environments of the manoeuvre rig; importing this module registers them.

| id | task | entry_point | vector_entry_point |
|---|---|---|---|
| ``rig_env/VelocityVectorRoll-v0`` | velocity_vector_roll | RigEnv | RigVectorEnv |
| ``rig_env/BankToBank-v0`` | bank_to_bank | RigEnv | RigVectorEnv |
| ``rig_env/PullUpPushOver-v0`` | pull_up_push_over | RigEnv | RigVectorEnv |
| ``rig_env/ForcedOscillation-v0`` | forced_oscillation (``task_options={"axis": "sway_yaw"}`` for sway-yaw) | RigEnv | RigVectorEnv |
| ``rig_env/FreeFlightEmulation-v0`` | free_flight_emulation | RigEnv | RigVectorEnv |
| ``rig_env/DepartureRecovery-v0`` | departure_recovery | RigEnv | RigVectorEnv |
| ``rig_env/ManoeuvreRig-v0`` | any, by the ``task`` argument | RigEnv | RigVectorEnv |

The tasks, their observation entries, rewards and success criteria: :mod:`rig_env.envs.tasks`.
Every id accepts the :class:`RigEnvConfig` fields as keyword arguments, e.g.
``gymnasium.make("rig_env/ManoeuvreRig-v0", task="bank_to_bank", free_dofs=("rig_roll",), airspeed=18.0)``
or ``gymnasium.make_vec("rig_env/VelocityVectorRoll-v0", num_envs=1024, vectorization_mode="vector_entry_point")``.
SB3: :class:`rig_env.envs.sb3.RigSB3VecEnv` (imported lazily; stable-baselines3 is optional).
"""

from __future__ import annotations

import gymnasium

from rig_env.envs.config import RigEnvConfig
from rig_env.envs.env import RigEnv
from rig_env.envs.tasks import (
    TASKS,
    BankToBank,
    DepartureRecovery,
    ForcedOscillation,
    FreeFlightEmulation,
    PullUpPushOver,
    Task,
    VelocityVectorRoll,
)
from rig_env.envs.vector_env import RigVectorEnv

ENV_IDS: dict[str, dict[str, str]] = {
    "rig_env/VelocityVectorRoll-v0": {"task": "velocity_vector_roll"},
    "rig_env/BankToBank-v0": {"task": "bank_to_bank"},
    "rig_env/PullUpPushOver-v0": {"task": "pull_up_push_over"},
    "rig_env/ForcedOscillation-v0": {"task": "forced_oscillation"},
    "rig_env/FreeFlightEmulation-v0": {"task": "free_flight_emulation"},
    "rig_env/DepartureRecovery-v0": {"task": "departure_recovery"},
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

__all__ = [
    "ENV_IDS",
    "TASKS",
    "BankToBank",
    "DepartureRecovery",
    "ForcedOscillation",
    "FreeFlightEmulation",
    "PullUpPushOver",
    "RigEnv",
    "RigEnvConfig",
    "RigVectorEnv",
    "Task",
    "VelocityVectorRoll",
    "register_envs",
]
