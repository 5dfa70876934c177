"""The gymnasium ids of the rig environments, registered with string entry points only.

:func:`register_envs` imports gymnasium and nothing else of this project (the entry points
``rig_env.envs.env:RigEnv`` and ``rig_env.envs.vector_env:RigVectorEnv`` are imported by
``gymnasium.make`` / ``make_vec``).  :func:`register_when_imported` (called by ``import rig_env`` and
``import rig_env.envs``) registers at once when gymnasium is already imported, else right after
gymnasium's own import (:func:`rig_env.importhook.when_imported`), so both
``import gymnasium; import rig_env`` and ``import rig_env; import gymnasium`` give the ids, and
``import rig_env`` alone imports no gymnasium.
"""

from __future__ import annotations

from rig_env.importhook import when_imported

ENV_IDS: dict[str, dict[str, str]] = {
    "rig_env/VelocityVectorRoll-v0": {"task": "velocity_vector_roll"},
    "rig_env/BankToBank-v0": {"task": "bank_to_bank"},
    "rig_env/PullUpPushOver-v0": {"task": "pull_up_push_over"},
    "rig_env/ForcedOscillation-v0": {"task": "forced_oscillation"},
    "rig_env/FreeFlightEmulation-v0": {"task": "free_flight_emulation"},
    "rig_env/DepartureRecovery-v0": {"task": "departure_recovery"},
    "rig_env/ManoeuvreRig-v0": {},
}

MAX_EPISODE_STEPS: dict[str, int] = {
    "rig_env/VelocityVectorRoll-v0": 640,  # 8 s at the default 80 Hz control rate
    "rig_env/BankToBank-v0": 1360,  # 17 s
    "rig_env/PullUpPushOver-v0": 640,  # 8 s
    "rig_env/ForcedOscillation-v0": 800,  # 10 s
    "rig_env/FreeFlightEmulation-v0": 480,  # 6 s
    "rig_env/DepartureRecovery-v0": 640,  # 8 s
    "rig_env/ManoeuvreRig-v0": 1360,  # the longest task's, so no task chosen by keyword is cut short
}
"""Each id's ``spec.max_episode_steps``: the task's own time limit (``default_episode_seconds`` x the default
control rate, control steps), so ``gymnasium.make``'s ``TimeLimit`` ends an episode at the same step as the
environment itself (once, with the episode's metrics in ``info``) and ``make_vec`` caps the batch there too.
With ``episode_seconds`` or ``control_rate`` changed through ``make``, pass ``max_episode_steps`` to match
(or -1 for none: the environment still ends its episodes)."""

_armed = False


def register_envs() -> None:
    """Register the ids above with gymnasium (imports it; idempotent)."""
    import gymnasium

    for env_id, kwargs in ENV_IDS.items():
        if env_id in gymnasium.registry:
            continue
        gymnasium.register(
            id=env_id,
            entry_point="rig_env.envs.env:RigEnv",
            vector_entry_point="rig_env.envs.vector_env:RigVectorEnv",
            kwargs=dict(kwargs),
            max_episode_steps=MAX_EPISODE_STEPS[env_id],
            disable_env_checker=False,
        )


def register_when_imported() -> None:
    """:func:`register_envs` now if gymnasium is imported, else right after its import (idempotent)."""
    global _armed
    if not _armed:
        _armed = True
        when_imported("gymnasium", register_envs)


__all__ = ["ENV_IDS", "MAX_EPISODE_STEPS", "register_envs", "register_when_imported"]
