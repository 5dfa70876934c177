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
| ``roll_error`` | (n,) | rad | ``roll_error`` x 45 deg (reference - measured), unwrapped |
| ``roll_rate_ref`` | (n,) or None | rad/s | ``roll_rate_ref`` x 12 |
"""

from __future__ import annotations

import math

import numpy as np

from controllers.base import LoopSpec
from rig_env.envs.sensors import AIRSPEED_SCALE, ANGLE_SCALE, FLAP_SCALE, RATE_SCALE, UNLIMITED
from rig_env.physics.aero import MIX_ELEVATOR, MIX_RUDDER

REF_SCALES = {
    "roll_error": math.radians(45.0),
    "roll_rate_ref": 12.0,
    "roll_rate_error": 12.0,
    "roll_ref": math.radians(90.0),
}
"""Units per normalised task entry (rad or rad/s), as the task docstrings in ``rig_env.envs.tasks`` state."""

_UNMIX = np.array([[0.25] * 4, [0.25 * m for m in MIX_ELEVATOR], [0.25 * m for m in MIX_RUDDER]])


class Signals:
    """Parser built once per law from its :class:`LoopSpec`; :meth:`__call__` fills the attributes."""

    def __init__(self, spec: LoopSpec) -> None:
        if "rig_roll" not in spec.free_dofs:
            raise ValueError(f"free_dofs = {list(spec.free_dofs)}: the compensator laws need rig_roll free")
        self.spec = spec
        ix = spec.index
        self._angle: dict[str, tuple[int, ...]] = {}
        for j in spec.free_dofs:
            self._angle[j] = (ix(f"sin_{j}"), ix(f"cos_{j}")) if j in UNLIMITED else (ix(f"{j}_angle"),)
        self._rate = {j: ix(f"{j}_rate") for j in spec.free_dofs}
        self._flaps = [ix(f"flap{k}") for k in range(1, 5)]
        self._air = ix("airspeed")
        labels = set(spec.obs_labels)
        self._roll_error = ix("roll_error") if "roll_error" in labels else None
        self._roll_rate_ref = ix("roll_rate_ref") if "roll_rate_ref" in labels else None
        self.has_rate_ref = self._roll_rate_ref is not None

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
        self.roll_error = o[:, self._roll_error] * REF_SCALES["roll_error"] if self._roll_error is not None else -self.phi
        self.roll_rate_ref = o[:, self._roll_rate_ref] * REF_SCALES["roll_rate_ref"] if self.has_rate_ref else np.zeros(n)
        return self
