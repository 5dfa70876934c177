"""The ``rig`` command (:mod:`rig_cli.main`): simulate, draw, compare control laws, train RL laws.

It is the one place that imports both ``rig_env`` and ``controllers`` as a user would; neither of
them imports it.
"""

from rig_cli.main import main

__all__ = ["main"]
