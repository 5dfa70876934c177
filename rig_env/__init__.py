"""rig_env: simulation and control-law sandbox for the Bristol 5-DOF wind-tunnel manoeuvre rig.

Public API: ``JOINTS``, ``SURFACES``, ``SERVOS``, ``RigParams``, ``param_batch``, ``simulate``,
``to_mjcf``, ``trim``, ``linearize``, ``continuation``, ``continuation_sweep``.  See README.md and docs/MODEL.md.

Importing this package is light (numpy and the parameters): ``simulate``, ``SimResult``, ``trim``,
``linearize``, ``to_mjcf``, ``continuation`` and ``continuation_sweep`` are the functions of :mod:`rig_env.simulate`,
:mod:`rig_env.linear`, :mod:`rig_env.mjcf`, :mod:`rig_env.bifurcation.rig` and :mod:`rig_env.bifurcation.sweep`, imported at their first use (PEP 562), so that the rig's real-time loop, which
needs only the observation builder, never imports numba.  The gymnasium ids ``rig_env/*`` are
registered as soon as gymnasium is imported, before or after this package
(:mod:`rig_env.envs.registration`); numba's set-up for the kernels runs as soon as numba is imported
(:func:`rig_env.physics.jit.setup_numba`).
"""

from __future__ import annotations

import sys
import types
from typing import TYPE_CHECKING, Any

from rig_env import importhook as _importhook
from rig_env.importhook import lazy_attributes
from rig_env.envs import registration as _registration
from rig_env.params import JOINTS, PARAM_NAMES, SERVOS, SURFACES, ParameterError, RigParams, param_batch
from rig_env.physics import jit as _jit

__version__ = "0.1.0"
"""The package version (pyproject.toml's); ``rig --version`` prefers the installed distribution's metadata."""

if TYPE_CHECKING:
    from rig_env.bifurcation.rig import continuation
    from rig_env.bifurcation.sweep import continuation_sweep
    from rig_env.linear import linearize, trim
    from rig_env.mjcf import to_mjcf
    from rig_env.simulate import SimResult, simulate

_LAZY = {
    "simulate": "rig_env.simulate",
    "SimResult": "rig_env.simulate",
    "trim": "rig_env.linear",
    "linearize": "rig_env.linear",
    "to_mjcf": "rig_env.mjcf",
    "continuation": "rig_env.bifurcation.rig",
    "continuation_sweep": "rig_env.bifurcation.sweep",
}


__getattr__, __dir__ = lazy_attributes('rig_env', _LAZY, globals())


class _Package(types.ModuleType):
    """This package's module type: the import system's ``rig_env.simulate = <module>`` (done when the
    submodule is first imported, by anyone) binds the function ``simulate`` instead, as the eager
    ``from rig_env.simulate import simulate`` of old did; ``import rig_env.simulate`` still puts the
    module in ``sys.modules``."""

    def __setattr__(self, name: str, value: Any) -> None:
        if name == "simulate" and isinstance(value, types.ModuleType) and hasattr(value, "simulate"):
            value = value.simulate
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package

__all__ = [
    "__version__",
    "JOINTS",
    "PARAM_NAMES",
    "SERVOS",
    "SURFACES",
    "ParameterError",
    "RigParams",
    "SimResult",
    "continuation",
    "continuation_sweep",
    "linearize",
    "param_batch",
    "simulate",
    "to_mjcf",
    "trim",
]

_importhook.when_imported("numba", _jit.setup_numba)
_registration.register_when_imported()
