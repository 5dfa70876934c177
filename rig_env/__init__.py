"""rig_env: simulation and control-law sandbox for the Bristol 5-DOF wind-tunnel manoeuvre rig.

Public API: ``JOINTS``, ``SURFACES``, ``SERVOS``, ``RigParams``, ``param_batch``, ``simulate``,
``to_mjcf``, ``trim``, ``linearize``.  See README.md and docs/MODEL.md.
"""

from rig_env.params import JOINTS, PARAM_NAMES, SERVOS, SURFACES, ParameterError, RigParams, param_batch
from rig_env.simulate import SimResult, simulate


def to_mjcf(*args, **kwargs):  # noqa: D401 - thin lazy wrapper (keeps mujoco an optional import)
    """The mechanism as a MuJoCo MJCF string; see :func:`rig_env.mjcf.to_mjcf`."""
    from rig_env.mjcf import to_mjcf as _to_mjcf

    return _to_mjcf(*args, **kwargs)


def trim(*args, **kwargs):
    """Operating point; see :func:`rig_env.linear.trim`."""
    from rig_env.linear import trim as _trim

    return _trim(*args, **kwargs)


def linearize(*args, **kwargs):
    """python-control StateSpace about an operating point; see :func:`rig_env.linear.linearize`."""
    from rig_env.linear import linearize as _linearize

    return _linearize(*args, **kwargs)


__all__ = [
    "JOINTS",
    "PARAM_NAMES",
    "SERVOS",
    "SURFACES",
    "ParameterError",
    "RigParams",
    "SimResult",
    "linearize",
    "param_batch",
    "simulate",
    "to_mjcf",
    "trim",
]

import rig_env.envs  # noqa: E402,F401  (registers the rig_env/* gymnasium ids)
