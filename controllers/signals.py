"""``Signals``: the observation vector turned back into physical signals, found by name (batched).

Laws see only the observation (:class:`controllers.base.LoopSpec` names its entries).  The sensor
entries' normalisations are those of :mod:`rig_env.envs.sensors`; the task entries' are those the
tasks document (:data:`REF_SCALES`); an entry a law does not know is ignored, and a joint without a
reference is held at zero.

| attribute | shape | unit | from |
|---|---|---|---|
| ``phi`` | (n,) | rad, (-pi, pi] | ``atan2(sin_rig_roll, cos_rig_roll)`` |
| ``angle[j]`` | (n,) | rad | ``<j>_angle`` x 30 deg, or atan2 of ``sin_<j>``/``cos_<j>`` |
| ``rate[j]`` | (n,) | rad/s | ``<j>_rate`` x ``RATE_SCALE[j]`` (the sensor's filtered estimate) |
| ``airspeed`` | (n,) | m/s | ``airspeed`` x 40 |
| ``surfaces`` | (n, 3) | normalised (1 = 40 deg) | aileron, elevator, rudder unmixed from ``flap1..4`` |
| ``error[j]`` | (n,) | rad | reference - measured angle of rig joint ``j``: ``roll_error`` (x 45 deg, unwrapped) for
  rig_roll, ``<j>_error`` for rig_pitch / rig_yaw; ``-angle`` when the task gives none (hold at zero) |
| ``rate_ref[j]`` | (n,) | rad/s | ``roll_rate_ref`` / ``<j>_rate_ref``; zeros when the task gives none |

Scales of task entries: the task class's ``ref_scales`` mapping (label -> unit per normalised
value) when it has one, else :data:`REF_SCALES`.  A task entry named like a reference whose scale is
unknown is ignored with a warning.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from controllers.base import LoopSpec, UnsupportedTask
from rig_env.envs import TASKS
from rig_env.envs.sensors import AIRSPEED_SCALE, ANGLE_SCALE, FLAP_SCALE, RATE_SCALE, UNLIMITED
from rig_env.physics.aero import MIX_ELEVATOR, MIX_RUDDER

REF_SCALES = {
    "roll_error": math.radians(45.0),
    "roll_rate_ref": 12.0,
    "roll_rate_error": 12.0,
    "roll_ref": math.radians(90.0),
}
"""Units per normalised task entry (rad or rad/s), as the task docstrings in ``rig_env.envs.tasks`` state."""

TRACKED = ("rig_roll", "rig_pitch", "rig_yaw")
_ERROR_LABEL = {"rig_roll": "roll_error", "rig_pitch": "rig_pitch_error", "rig_yaw": "rig_yaw_error"}
_RATE_REF_LABEL = {"rig_roll": "roll_rate_ref", "rig_pitch": "rig_pitch_rate_ref", "rig_yaw": "rig_yaw_rate_ref"}
_UNMIX = np.array([[0.25] * 4, [0.25 * m for m in MIX_ELEVATOR], [0.25 * m for m in MIX_RUDDER]])


class Signals:
    """Parser built once per law from its :class:`LoopSpec`; :meth:`__call__` fills the attributes."""

    def __init__(self, spec: LoopSpec) -> None:
        if "rig_roll" not in spec.free_dofs:
            raise UnsupportedTask(f"free_dofs = {list(spec.free_dofs)}: this law's roll loops need rig_roll free")
        self.spec = spec
        ix = spec.index
        self._angle: dict[str, tuple[int, ...]] = {}
        for j in spec.free_dofs:
            self._angle[j] = (ix(f"sin_{j}"), ix(f"cos_{j}")) if j in UNLIMITED else (ix(f"{j}_angle"),)
        self._rate = {j: ix(f"{j}_rate") for j in spec.free_dofs}
        self._flaps = [ix(f"flap{k}") for k in range(1, 5)]
        self._air = ix("airspeed")
        labels = set(spec.obs_labels)
        task = TASKS.get(spec.task)
        scales = {**REF_SCALES, **dict(getattr(task, "ref_scales", {}) or {})}
        self._err: dict[str, tuple[int, float]] = {}
        self._rref: dict[str, tuple[int, float]] = {}
        for j in TRACKED:
            for table, label in ((self._err, _ERROR_LABEL[j]), (self._rref, _RATE_REF_LABEL[j])):
                if label in labels and j in spec.free_dofs:
                    if label in scales:
                        table[j] = (ix(label), float(scales[label]))
                    else:
                        warnings.warn(f"task {spec.task!r}: observation entry {label!r} has no known scale; ignored", stacklevel=2)
        self.has_rate_ref = "rig_roll" in self._rref

    def __call__(self, obs: np.ndarray) -> "Signals":
        o = obs
        self.angle = {}
        for j, cols in self._angle.items():
            self.angle[j] = np.arctan2(o[:, cols[0]], o[:, cols[1]]) if len(cols) == 2 else o[:, cols[0]] * ANGLE_SCALE
        self.phi = self.angle["rig_roll"]
        self.rate = {j: o[:, c] * RATE_SCALE[j] for j, c in self._rate.items()}
        self.airspeed = o[:, self._air] * AIRSPEED_SCALE
        self.surfaces = (o[:, self._flaps] * FLAP_SCALE / math.radians(self.spec.action_scale_deg)) @ _UNMIX.T
        n = o.shape[0]
        self.error = {j: (o[:, self._err[j][0]] * self._err[j][1] if j in self._err else -self.angle[j])
                      for j in TRACKED if j in self.angle}
        self.rate_ref = {j: (o[:, self._rref[j][0]] * self._rref[j][1] if j in self._rref else np.zeros(n))
                         for j in TRACKED if j in self.angle}
        self.roll_error, self.roll_rate_ref = self.error["rig_roll"], self.rate_ref["rig_roll"]
        return self
