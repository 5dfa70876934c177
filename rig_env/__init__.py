"""rig_env: simulation and control-law sandbox for the Bristol 5-DOF wind-tunnel manoeuvre rig."""

from rig_env.params import JOINTS, PARAM_NAMES, SERVOS, SURFACES, ParameterError, RigParams, param_batch

__all__ = ["JOINTS", "PARAM_NAMES", "SERVOS", "SURFACES", "ParameterError", "RigParams", "param_batch"]
