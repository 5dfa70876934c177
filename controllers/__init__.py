"""Control laws of the compensator, grouped by phase.

| package | phase | imports |
|---|---|---|
| :mod:`controllers.laws` | the laws as they run (what deploys) | numpy |
| :mod:`controllers.design` | their design: trim/linearise, tuning, LQR synthesis, RL training and export | rig_env, python-control, scipy, torch |
| :mod:`controllers.evaluation` | closed-loop evaluation, the comparison, its report | the environments, laws, designs |
| :mod:`controllers.deploy` | the law as data, the real-time loop, the simulated rig | numpy (the loop); the rest for export |

This package imports only :mod:`controllers.laws`; :func:`make_controller` loads the designs when called.
"""

from __future__ import annotations

from typing import Any

from controllers.laws import LAWS, Controller, LoopSpec, UnsupportedTask, law_for, register

CONTROLLERS = LAWS


def make_controller(kind: str, spec: LoopSpec, num_envs: int = 1, **options: Any) -> Controller:
    """:func:`controllers.design.make_controller`: the law of ``kind`` for ``spec``, designed and built."""
    from controllers.design import make_controller as make

    return make(kind, spec, num_envs, **options)


__all__ = ["CONTROLLERS", "LAWS", "Controller", "LoopSpec", "UnsupportedTask", "law_for", "make_controller", "register"]
