"""Gymnasium environments of the manoeuvre rig; importing this package registers them (when gymnasium is imported).

| id | task | max_episode_steps (80 Hz) | entry_point | vector_entry_point |
|---|---|---|---|---|
| ``rig_env/VelocityVectorRoll-v0`` | velocity_vector_roll | 640 (8 s) | RigEnv | RigVectorEnv |
| ``rig_env/BankToBank-v0`` | bank_to_bank | 1360 (17 s) | RigEnv | RigVectorEnv |
| ``rig_env/PullUpPushOver-v0`` | pull_up_push_over | 640 (8 s) | RigEnv | RigVectorEnv |
| ``rig_env/ForcedOscillation-v0`` | forced_oscillation (``task_options={"axis": "sway_yaw"}`` for sway-yaw) | 800 (10 s) | RigEnv | RigVectorEnv |
| ``rig_env/FreeFlightEmulation-v0`` | free_flight_emulation | 480 (6 s) | RigEnv | RigVectorEnv |
| ``rig_env/DepartureRecovery-v0`` | departure_recovery | 640 (8 s) | RigEnv | RigVectorEnv |
| ``rig_env/ManoeuvreRig-v0`` | any, by the ``task`` argument | 1360 (the longest task's) | RigEnv | RigVectorEnv |

The tasks, their observation entries, rewards and success criteria: :mod:`rig_env.envs.tasks`.
Every id accepts the :class:`RigEnvConfig` fields as keyword arguments, e.g.
``gymnasium.make("rig_env/ManoeuvreRig-v0", task="bank_to_bank", free_dofs=("rig_roll",), airspeed=18.0)``
or ``gymnasium.make_vec("rig_env/VelocityVectorRoll-v0", num_envs=1024, vectorization_mode="vector_entry_point")``.
``make_vec(..., autoreset_mode=AutoresetMode.NEXT_STEP)`` gives the batch Gymnasium's next-step
autoreset (its vector observation wrappers need it); same-step is the default.
SB3: :class:`rig_env.envs.sb3.RigSB3VecEnv` (imported lazily; stable-baselines3 is optional);
:func:`rig_env.envs.sb3.as_sb3_vec_env` points a Gymnasium ``VectorEnv`` at it.

Importing this package imports neither gymnasium nor numba: the classes below are imported at their
first use (PEP 562), so that :mod:`rig_env.envs.observation` (the observation builder the rig's
real-time loop shares with the environments) comes without them.  The ids are registered by
:mod:`rig_env.envs.registration` as soon as gymnasium is imported.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from rig_env.envs.registration import ENV_IDS, register_envs, register_when_imported
from rig_env.importhook import lazy_attributes

if TYPE_CHECKING:
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

_LAZY = {
    "RigEnvConfig": "rig_env.envs.config",
    "RigEnv": "rig_env.envs.env",
    "RigVectorEnv": "rig_env.envs.vector_env",
    **dict.fromkeys(
        ("TASKS", "BankToBank", "DepartureRecovery", "ForcedOscillation", "FreeFlightEmulation", "PullUpPushOver", "Task",
         "VelocityVectorRoll"),
        "rig_env.envs.tasks",
    ),
}


__getattr__, __dir__ = lazy_attributes('rig_env.envs', _LAZY, globals())


register_when_imported()

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
