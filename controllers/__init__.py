"""Control laws of the compensator behind one interface (:mod:`controllers.base`).

Importing this package registers the built-in laws in ``controllers.base.CONTROLLERS``.
"""

from controllers.base import CONTROLLERS, Controller, LoopSpec, make_controller, register

__all__ = ["CONTROLLERS", "Controller", "LoopSpec", "make_controller", "register"]
