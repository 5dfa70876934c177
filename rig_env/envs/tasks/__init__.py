"""Manoeuvre tasks of Table 1 (AIAA 2009-5727), each a :class:`Task` chosen by name (``TASKS``).

| name | class | module | default free joints |
|---|---|---|---|
| velocity_vector_roll | VelocityVectorRoll | roll | rig_roll, model_pitch |
| bank_to_bank | BankToBank | roll | rig_roll, rig_yaw, model_pitch, model_yaw |
| pull_up_push_over | PullUpPushOver | longitudinal | rig_pitch, model_pitch |
| forced_oscillation | ForcedOscillation | oscillation | rig_pitch, model_pitch (``axis="sway_yaw"``: rig_yaw, model_yaw) |
| free_flight_emulation | FreeFlightEmulation | freeflight | rig_pitch, model_pitch |
| departure_recovery | DepartureRecovery | departure | rig_roll, rig_pitch, model_pitch, model_yaw |

The base class and the order in which the environment calls the hooks: :mod:`.base`.
"""

from __future__ import annotations

from rig_env.envs.tasks.base import Task
from rig_env.envs.tasks.departure import DepartureRecovery
from rig_env.envs.tasks.freeflight import FreeFlightEmulation, FreeHawkShortPeriod
from rig_env.envs.tasks.longitudinal import PullUpPushOver
from rig_env.envs.tasks.oscillation import ForcedOscillation
from rig_env.envs.tasks.roll import BankToBank, VelocityVectorRoll

TASKS: dict[str, type[Task]] = {
    cls.name: cls
    for cls in (VelocityVectorRoll, BankToBank, PullUpPushOver, ForcedOscillation, FreeFlightEmulation, DepartureRecovery)
}

__all__ = [
    "TASKS",
    "BankToBank",
    "DepartureRecovery",
    "ForcedOscillation",
    "FreeFlightEmulation",
    "FreeHawkShortPeriod",
    "PullUpPushOver",
    "Task",
    "VelocityVectorRoll",
]
