"""Control laws of the compensator behind one interface (:mod:`controllers.base`).

Importing this package registers the built-in laws in ``controllers.base.CONTROLLERS``: ``"pid"``
(:mod:`controllers.pid`), ``"lqr"`` (:mod:`controllers.lqr`), each followed by its heave/sway law for
the tasks with rig_roll locked (:mod:`controllers.heave_sway`) and, when :mod:`controllers.rl` is
present, the learned policies it registers (``"ppo"``, ``"sac"``).
"""

import importlib.util

from controllers.base import CONTROLLERS, Controller, LoopSpec, UnsupportedTask, make_controller, register
from controllers import pid  # noqa: F401  (registers "pid")

if importlib.util.find_spec("controllers.lqr") is not None:
    from controllers import lqr  # noqa: F401  (registers "lqr")
from controllers import heave_sway  # noqa: F401,E402  (after the roll laws: registers the heave/sway "pid" and "lqr")
if importlib.util.find_spec("controllers.rl") is not None:
    from controllers import rl  # noqa: F401  (registers the RL kinds)

__all__ = ["CONTROLLERS", "Controller", "LoopSpec", "UnsupportedTask", "make_controller", "register"]
