"""Control laws of the compensator behind one interface (:mod:`controllers.base`).

Importing this package registers the built-in laws in ``controllers.base.CONTROLLERS``: ``"pid"``
(:mod:`controllers.pid`), ``"lqr"`` (:mod:`controllers.lqr`), each followed by its heave/sway law
for the tasks with rig_roll locked (:mod:`controllers.heave_sway`; for free-flight emulation the
model-following LQR of :mod:`controllers.emulation` comes first), and the learned policies of
:mod:`controllers.rl` (``"ppo"``, ``"sac"``).  Every runtime here imports numpy only; the designs
(python-control, the numba model) live in the ``*_design`` modules and load when a law is designed.
"""

from controllers.base import CONTROLLERS, Controller, LoopSpec, UnsupportedTask, make_controller, register
from controllers import pid  # noqa: E402,F401  (registers "pid": the roll-axis cascade)
from controllers import lqr  # noqa: E402,F401  (registers "lqr": the scheduled roll-axis LQR)
from controllers import emulation  # noqa: E402,F401  (after the roll laws: the model-following "lqr" of free-flight emulation)
from controllers import heave_sway  # noqa: E402,F401  (after the roll laws: the heave/sway "pid" and "lqr")
from controllers import rl  # noqa: E402,F401  (registers "ppo" and "sac": shipped policies, numpy runtime)

__all__ = ["CONTROLLERS", "Controller", "LoopSpec", "UnsupportedTask", "make_controller", "register"]
