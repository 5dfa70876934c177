"""What the laws' runtime parsers need from ``rig_env``, read at design time into plain numbers.

:func:`signal_scales` reads the observation's normalisation (sensors, mixer, the task's declared
reference scales) into :class:`controllers.laws.signals.SignalScales`; :func:`reference_constants`
reads the heave/sway reference parser's numbers (the task's driven joint, the sensor scales, the
task's entry scales, ``G0``, the oscillation's ramp time, the arm length) into
:class:`controllers.laws.references.ReferenceConstants`.  Every task number is read by name from the
task class (``ref_scales``, ``driven_joint``, ``T_RAMP``), none is copied here.  The laws store them
in their tables, so the runtime parses observations with numpy alone.
"""

from __future__ import annotations

import warnings

import numpy as np

from controllers.laws.base import LoopSpec, UnsupportedTask
from controllers.laws.references import TASKS as HEAVE_SWAY_TASKS
from controllers.laws.references import ENTRIES, ReferenceConstants, check_task
from controllers.laws.signals import _ERROR_LABEL, _RATE_REF_LABEL, TRACKED, SignalScales
from rig_env.params import RigParams


def signal_scales(spec: LoopSpec) -> SignalScales:
    """Read the scales of ``spec``'s observation from ``rig_env`` (design time; imports the environments)."""
    from rig_env.envs import TASKS
    from rig_env.envs.sensors import (
        AIRSPEED_SCALE,
        ANGLE_SCALE,
        FLAP_SCALE,
        RATE_SCALE,
        UNLIMITED,
    )
    from rig_env.physics.aero import MIX_ELEVATOR, MIX_RUDDER

    labels = set(spec.obs_labels)
    task = TASKS.get(spec.task)
    scales = dict(getattr(task, "ref_scales", {}) or {})
    ref: dict[str, float] = {}
    for j in TRACKED:
        for label in (_ERROR_LABEL[j], _RATE_REF_LABEL[j]):
            if label in labels and j in spec.free_dofs:
                if label in scales:
                    ref[label] = float(scales[label])
                else:
                    warnings.warn(f"task {spec.task!r}: observation entry {label!r} has no known scale; ignored", stacklevel=3)
    unmix = np.array([[0.25] * 4, [0.25 * m for m in MIX_ELEVATOR], [0.25 * m for m in MIX_RUDDER]])
    return SignalScales(float(ANGLE_SCALE), np.array([float(RATE_SCALE[j]) for j in spec.free_dofs]), float(AIRSPEED_SCALE),
                        float(FLAP_SCALE), unmix, tuple(j for j in spec.free_dofs if j in UNLIMITED), tuple(ref), np.array(list(ref.values())))


def driven_joint(spec: LoopSpec) -> str:
    """The rig joint the task drives; UnsupportedTask for other tasks or with rig_roll free (design time: reads the task)."""
    if spec.task not in HEAVE_SWAY_TASKS:
        raise UnsupportedTask(f"task {spec.task!r}: the heave/sway laws fly {list(HEAVE_SWAY_TASKS)}")
    from rig_env.envs import TASKS

    j = TASKS[spec.task].driven_joint(spec.task_options)
    if j is None:
        raise UnsupportedTask(f"task {spec.task!r} drives no rig joint")
    check_task(spec, j)
    return j


def reference_constants(spec: LoopSpec, params: RigParams) -> ReferenceConstants:
    """Read :class:`ReferenceConstants` for ``spec`` from ``rig_env`` and ``params`` (design time)."""
    from rig_env.envs import TASKS
    from rig_env.envs.sensors import AIRSPEED_SCALE, ANGLE_SCALE, RATE_SCALE
    from rig_env.envs.tasks.base import G0
    from rig_env.envs.tasks.oscillation import ForcedOscillation

    j = driven_joint(spec)
    declared = TASKS[spec.task].ref_scales
    return ReferenceConstants(j, float(ANGLE_SCALE), float(RATE_SCALE[j]), float(AIRSPEED_SCALE), float(G0),
                              float(ForcedOscillation.T_RAMP), float(params.geometry.arm_length),
                              {k: float(declared[k]) for k in ENTRIES[spec.task]})
