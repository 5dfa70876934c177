"""Control laws of the compensator behind one interface (:mod:`controllers.base`).

Importing this package registers the built-in laws in ``controllers.base.CONTROLLERS``: ``"pid"``
(:mod:`controllers.pid`), ``"lqr"`` (:mod:`controllers.lqr`) and the learned policies of
:mod:`controllers.rl` (``"ppo"``, ``"sac"``); :func:`load_all_laws` (called by ``make_controller``)
adds the heave/sway laws for the tasks with rig_roll locked (:mod:`controllers.heave_sway`).
"""

from controllers.base import CONTROLLERS, Controller, LoopSpec, UnsupportedTask, make_controller, register
from controllers import pid  # noqa: E402,F401  (registers "pid": the roll-axis cascade)
from controllers import lqr  # noqa: E402,F401  (registers "lqr": the scheduled roll-axis LQR)
from controllers import rl  # noqa: E402,F401  (registers "ppo" and "sac": shipped policies, numpy runtime)

# Laws whose module needs the design tools (python-control, the numba model) even at run time are
# registered on first use by make_controller, so that loading a deployed artefact (import controllers)
# stays numpy-only.
DESIGN_TIME_LAWS = ("controllers.heave_sway",)


def load_all_laws() -> None:
    """Import every law module (idempotent): the heave/sway laws register after the roll laws."""
    import importlib

    for name in DESIGN_TIME_LAWS:
        importlib.import_module(name)

__all__ = ["DESIGN_TIME_LAWS", "load_all_laws", "CONTROLLERS", "Controller", "LoopSpec", "UnsupportedTask", "make_controller", "register"]
