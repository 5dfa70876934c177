"""``Signals``: the observation vector turned back into physical signals, found by name (batched).

Laws see only the observation (:class:`controllers.laws.base.LoopSpec` names its entries).  The sensor
entries' normalisations are those of :mod:`rig_env.envs.sensors`; the task entries' are those the
task class declares by name (``Task.ref_scales``); an entry a law does not know is ignored, and a
joint without a reference is held at zero.

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
value).  A task entry named like a reference whose scale the task does not declare is ignored with a
warning.

Runtime and design are apart: :func:`controllers.design.signals.signal_scales` reads every scale above from ``rig_env`` (the
sensors, the mixer, the task) into :class:`SignalScales`, plain numbers; :class:`Signals` parses with
numpy alone from those numbers, so a deployed law stores them (:meth:`SignalScales.to_data`) and
parses exactly as in simulation without importing ``rig_env``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from controllers.laws.base import LoopSpec, UnsupportedTask

TRACKED = ("rig_roll", "rig_pitch", "rig_yaw")
_ERROR_LABEL = {"rig_roll": "roll_error", "rig_pitch": "rig_pitch_error", "rig_yaw": "rig_yaw_error"}
_RATE_REF_LABEL = {"rig_roll": "roll_rate_ref", "rig_pitch": "rig_pitch_rate_ref", "rig_yaw": "rig_yaw_rate_ref"}


@dataclass(frozen=True)
class SignalScales:
    """The observation's normalisation for one :class:`LoopSpec`, as plain numbers.

    | field | shape | unit |
    |---|---|---|
    | angle_scale | scalar | rad per ``<j>_angle`` unit |
    | rate_scale | (n_free,) | rad/s per ``<j>_rate`` unit, ``spec.free_dofs`` order |
    | airspeed_scale | scalar | m/s per ``airspeed`` unit |
    | flap_scale | scalar | rad per ``flapk`` unit |
    | unmix | (3, 4) | (aileron, elevator, rudder) from flaps 1-4 |
    | unlimited | names | free joints observed as sin/cos |
    | ref_labels, ref_scales | names, (k,) | task entries the laws read and their units (rad, rad/s) |
    """

    angle_scale: float
    rate_scale: np.ndarray
    airspeed_scale: float
    flap_scale: float
    unmix: np.ndarray
    unlimited: tuple[str, ...]
    ref_labels: tuple[str, ...]
    ref_scales: np.ndarray

    def to_data(self) -> dict[str, Any]:
        """Artefact entries (``sig_*``): arrays and JSON scalars / lists."""
        return {"sig_angle_scale": float(self.angle_scale), "sig_rate_scale": np.array(self.rate_scale, dtype=np.float64),
                "sig_airspeed_scale": float(self.airspeed_scale), "sig_flap_scale": float(self.flap_scale),
                "sig_unmix": np.array(self.unmix, dtype=np.float64), "sig_unlimited": list(self.unlimited),
                "sig_ref_labels": list(self.ref_labels), "sig_ref_scales": np.array(self.ref_scales, dtype=np.float64)}

    @classmethod
    def from_data(cls, d: Mapping[str, Any], spec: LoopSpec) -> SignalScales:
        """Inverse of :meth:`to_data`; a ValueError names a missing, mis-shaped or non-finite entry."""
        missing = [k for k in ("sig_angle_scale", "sig_rate_scale", "sig_airspeed_scale", "sig_flap_scale", "sig_unmix",
                               "sig_unlimited", "sig_ref_labels", "sig_ref_scales") if k not in d]
        if missing:
            raise ValueError(f"signal scales: missing {missing}")
        names = {k: d[k] for k in ("sig_unlimited", "sig_ref_labels")}
        for k, v in names.items():
            if not isinstance(v, (list, tuple)) or not all(isinstance(x, str) for x in v):
                raise ValueError(f"{k}: must be a list of names")
        k = len(names["sig_ref_labels"])
        sc = cls(_scalar(d, "sig_angle_scale"), table_array(d, "sig_rate_scale", (len(spec.free_dofs),)), _scalar(d, "sig_airspeed_scale"),
                 _scalar(d, "sig_flap_scale"), table_array(d, "sig_unmix", (3, 4)), tuple(names["sig_unlimited"]),
                 tuple(names["sig_ref_labels"]), table_array(d, "sig_ref_scales", (k,)))
        unknown = [x for x in sc.ref_labels if x not in spec.obs_labels]
        if unknown or any(j not in spec.free_dofs for j in sc.unlimited):
            raise ValueError(f"signal scales: entries {unknown or list(sc.unlimited)} do not match the spec's observation / free joints")
        return sc


def _scalar(d: Mapping[str, Any], k: str) -> float:
    v = d[k]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise ValueError(f"{k} = {v!r}: must be a finite number > 0")
    return float(v)


def real_array(where: str, v: Any, allowed: str = "") -> np.ndarray:
    """``v`` as a float64 array, or a ValueError naming ``where`` (and ``allowed``, what to give instead).  Checked
    before the float conversion: complex numbers lost their imaginary part with only a ComplexWarning, strings were
    parsed ("2" -> 2.0), and ragged lists raised numpy's own message without the entry's name."""
    try:
        raw = np.asarray(v)
    except (ValueError, TypeError):
        raw = None
    if raw is None or raw.dtype.kind not in "biuf":
        what = "a ragged nesting" if raw is None else f"dtype {raw.dtype}"
        raise ValueError(f"{where} = {type(v).__name__} of {what}: must be real numbers{'; allowed ' + allowed if allowed else ''}")
    return np.asarray(raw, dtype=np.float64)


def table_array(d: Mapping[str, Any], k: str, shape: tuple[int | None, ...] | None = None, owner: str = "") -> np.ndarray:
    """Entry ``k`` of a law's plain-data tables as a finite float64 array of ``shape`` (None: any shape; a
    None entry: any length along that axis); ValueError naming ``owner: k`` otherwise."""
    where = f"{owner}: {k}" if owner else k
    a = real_array(where, d[k])
    if shape is not None and (a.ndim != len(shape) or any(n is not None and m != n for m, n in zip(a.shape, shape))):
        raise ValueError(f"{where}: expected shape {tuple('m' if n is None else n for n in shape)}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{where}: non-finite value(s)")
    return a




def roll_reason(spec: LoopSpec) -> str | None:
    """None when rig_roll is free, else why a law with roll loops cannot fly ``spec`` (its ``supports``)."""
    return None if "rig_roll" in spec.free_dofs else f"free_dofs = {list(spec.free_dofs)}: this law's roll loops need rig_roll free"


def require_roll(spec: LoopSpec) -> None:
    """UnsupportedTask unless rig_roll is free: the compensator laws' roll loops need it (checked before any design)."""
    why = roll_reason(spec)
    if why:
        raise UnsupportedTask(why)


class Signals:
    """Parser built once per law from its :class:`LoopSpec` and :class:`SignalScales`
    (:func:`controllers.design.signals.signal_scales` reads them at design time); :meth:`__call__` fills
    the attributes.  Numpy only."""

    def __init__(self, spec: LoopSpec, scales: SignalScales) -> None:
        require_roll(spec)
        self.spec = spec
        self.scales = sc = scales
        ix = spec.index
        self._angle: dict[str, tuple[int, ...]] = {}
        for j in spec.free_dofs:
            self._angle[j] = (ix(f"sin_{j}"), ix(f"cos_{j}")) if j in sc.unlimited else (ix(f"{j}_angle"),)
        self._rate = {j: (ix(f"{j}_rate"), float(sc.rate_scale[k])) for k, j in enumerate(spec.free_dofs)}
        self._flaps = [ix(f"flap{k}") for k in range(1, 5)]
        self._air = ix("airspeed")
        ref = dict(zip(sc.ref_labels, (float(x) for x in sc.ref_scales)))
        self._err: dict[str, tuple[int, float]] = {}
        self._rref: dict[str, tuple[int, float]] = {}
        for j in TRACKED:
            for table, label in ((self._err, _ERROR_LABEL[j]), (self._rref, _RATE_REF_LABEL[j])):
                if label in ref and j in spec.free_dofs:
                    table[j] = (ix(label), ref[label])
        self.has_rate_ref = "rig_roll" in self._rref

    def __call__(self, obs: np.ndarray) -> Signals:
        o, sc = obs, self.scales
        self.angle = {}
        for j, cols in self._angle.items():
            self.angle[j] = np.arctan2(o[:, cols[0]], o[:, cols[1]]) if len(cols) == 2 else o[:, cols[0]] * sc.angle_scale
        self.phi = self.angle["rig_roll"]
        self.rate = {j: o[:, c] * scale for j, (c, scale) in self._rate.items()}
        self.airspeed = o[:, self._air] * sc.airspeed_scale
        self.surfaces = (o[:, self._flaps] * sc.flap_scale / math.radians(self.spec.action_scale_deg)) @ sc.unmix.T
        n = o.shape[0]
        self.error = {j: (o[:, self._err[j][0]] * self._err[j][1] if j in self._err else -self.angle[j])
                      for j in TRACKED if j in self.angle}
        self.rate_ref = {j: (o[:, self._rref[j][0]] * self._rref[j][1] if j in self._rref else np.zeros(n))
                         for j in TRACKED if j in self.angle}
        self.roll_error, self.roll_rate_ref = self.error["rig_roll"], self.rate_ref["rig_roll"]
        return self
