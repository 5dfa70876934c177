"""``FlightRecord``: one recorded run of the rig, in the units the model integrates.

A record is what a test on the rig (or a simulation of one) leaves behind: the configuration (which
joints were free, at what angle the locked ones were held), the sample times, the free joints' angles
(and their rates where a sensor measured them), the control-surface deflections and the tunnel speed.

| field | shape | unit / meaning |
|---|---|---|
| t | (n_t,) | s, strictly increasing, finite |
| free_dofs | tuple of names | the free joints (``rig_env.JOINTS`` names), in JOINTS order once built |
| q | (n_t, n_free) | rad, angles of the free joints, columns in ``free_dofs`` order |
| qd | (n_t, n_free) or None | rad/s, measured rates (None: not measured) |
| surfaces | {name: (n_t,)} | deg, ``rig_env.SURFACES`` names; absent surfaces are held at zero |
| surface_kind | str | ``"commanded"``: what the loop sent (the model's servos act on it); ``"actual"``: the deflections themselves (measured, or passed through a servo model beforehand; the model's servos are bypassed) |
| airspeed | float or (n_t,) | m/s, tunnel speed (a constant or the measured series), in [0, 60] |
| locked | {joint: rad} or None | angles of locked joints (None: zeros) |
| setup | {dotted parameter name: value} | parameters of this run's set-up that differ from the rig's (a friction test's springs and masses, an added mass), in the parameter file's units |
| name | str | a label for reports and error messages |

Construction checks every field and raises :class:`RecordError` naming the field and what is allowed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from rig_env.params import JOINTS, SURFACES

SURFACE_KINDS = ("commanded", "actual")
AIRSPEED_RANGE = (0.0, 60.0)  # m/s, as simulate() allows


class RecordError(ValueError):
    """A record that cannot be used: the message names the field and what is allowed."""


def _float_array(name: str, a: object, ndim: int) -> np.ndarray:
    try:
        arr = np.array(a, dtype=np.float64)
    except (TypeError, ValueError):
        raise RecordError(f"{name}: must be numbers, got {type(a).__name__}") from None
    if arr.ndim != ndim:
        raise RecordError(f"{name}: expected a {ndim}-D array, got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        first = np.argwhere(bad)[0]
        raise RecordError(f"{name}: {int(bad.sum())} non-finite value(s), the first at index {tuple(int(i) for i in first)}")
    return arr


@dataclass(frozen=True, eq=False)
class FlightRecord:
    """One recorded run (see the module docstring for the fields and their units)."""

    t: np.ndarray
    free_dofs: tuple[str, ...]
    q: np.ndarray
    surfaces: Mapping[str, np.ndarray] = field(default_factory=dict)
    airspeed: float | np.ndarray = 20.0
    locked: Mapping[str, float] | None = None
    qd: np.ndarray | None = None
    surface_kind: str = "commanded"
    setup: Mapping[str, float] = field(default_factory=dict)
    name: str = "record"

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        t = _float_array(f"{self.name}: t", self.t, 1)
        if t.size < 2:
            raise RecordError(f"{self.name}: t needs at least 2 samples, got {t.size}")
        dt = np.diff(t)
        if np.any(dt <= 0.0):
            k = int(np.argmax(dt <= 0.0))
            raise RecordError(f"{self.name}: t must be strictly increasing; t[{k + 1}] = {t[k + 1]} s follows t[{k}] = {t[k]} s")
        set_(self, "t", t)
        n_t = t.size
        free = (self.free_dofs,) if isinstance(self.free_dofs, str) else tuple(self.free_dofs)
        unknown = [j for j in free if j not in JOINTS]
        if unknown or not free or len(set(free)) != len(free):
            raise RecordError(f"{self.name}: free_dofs = {list(free)}: give one or more distinct joints of {list(JOINTS)}")
        order = sorted(range(len(free)), key=lambda k: JOINTS.index(free[k]))
        set_(self, "free_dofs", tuple(free[k] for k in order))
        for label in ("q", "qd"):
            v = getattr(self, label)
            if v is None:
                continue
            a = _float_array(f"{self.name}: {label}", np.reshape(v, (n_t, -1)) if np.ndim(v) == 1 else v, 2)
            if a.shape != (n_t, len(free)):
                raise RecordError(f"{self.name}: {label} has shape {a.shape}; expected (n_t, n_free) = ({n_t}, {len(free)})")
            set_(self, label, a[:, order])
        if self.q is None:
            raise RecordError(f"{self.name}: q (the free joints' angles, rad) is required")
        surf: dict[str, np.ndarray] = {}
        for s, v in dict(self.surfaces or {}).items():
            if s not in SURFACES:
                raise RecordError(f"{self.name}: surfaces: unknown surface {s!r}; valid names: {list(SURFACES)}")
            a = _float_array(f"{self.name}: surfaces[{s!r}]", v, 1)
            if a.size != n_t:
                raise RecordError(f"{self.name}: surfaces[{s!r}] has {a.size} samples; t has {n_t}")
            surf[s] = a
        set_(self, "surfaces", surf)
        if self.surface_kind not in SURFACE_KINDS:
            raise RecordError(f"{self.name}: surface_kind = {self.surface_kind!r}; allowed: {', '.join(SURFACE_KINDS)}")
        lo, hi = AIRSPEED_RANGE
        if np.ndim(self.airspeed) == 0:
            v = float(self.airspeed)  # type: ignore[arg-type]
            if not (math.isfinite(v) and lo <= v <= hi):
                raise RecordError(f"{self.name}: airspeed = {v} m/s is outside the allowed range [{lo}, {hi}] m/s")
            set_(self, "airspeed", v)
        else:
            a = _float_array(f"{self.name}: airspeed", self.airspeed, 1)
            if a.size != n_t:
                raise RecordError(f"{self.name}: airspeed has {a.size} samples; t has {n_t}")
            if a.min() < lo or a.max() > hi:
                raise RecordError(f"{self.name}: airspeed {a.min():.3g}..{a.max():.3g} m/s is outside the allowed range [{lo}, {hi}] m/s")
            set_(self, "airspeed", a)
        locked = dict(self.locked or {})
        for j, v in locked.items():
            if j not in JOINTS:
                raise RecordError(f"{self.name}: locked: unknown joint {j!r}; valid names: {list(JOINTS)}")
            if j in self.free_dofs:
                raise RecordError(f"{self.name}: locked: {j!r} is also a free joint")
            if not math.isfinite(float(v)):
                raise RecordError(f"{self.name}: locked[{j!r}] must be finite")
            locked[j] = float(v)
        set_(self, "locked", locked)
        from rig_env.params import PARAM_INDEX

        setup = {}
        for k, v in dict(self.setup or {}).items():
            if k not in PARAM_INDEX:
                raise RecordError(f"{self.name}: setup: unknown parameter {k!r}; valid names: rig_env.PARAM_NAMES")
            if not math.isfinite(float(v)):
                raise RecordError(f"{self.name}: setup[{k!r}] must be finite")
            setup[k] = float(v)
        set_(self, "setup", setup)

    # ------------------------------------------------------------------ views
    @property
    def n_t(self) -> int:
        """Number of samples."""
        return int(self.t.size)

    @property
    def duration(self) -> float:
        """t[-1] - t[0], s."""
        return float(self.t[-1] - self.t[0])

    @property
    def dt(self) -> float:
        """Median sample interval, s."""
        return float(np.median(np.diff(self.t)))

    def airspeed_series(self) -> np.ndarray:
        """(n_t,) tunnel speed, m/s."""
        return np.broadcast_to(np.asarray(self.airspeed, dtype=np.float64), (self.n_t,)).copy()

    def surface_array(self, names: Sequence[str] = SURFACES) -> np.ndarray:
        """(n_t, len(names)) deflections, deg (absent surfaces: zeros)."""
        out = np.zeros((self.n_t, len(names)))
        for k, s in enumerate(names):
            if s in self.surfaces:
                out[:, k] = self.surfaces[s]
        return out

    def locked_angles(self) -> np.ndarray:
        """(5,) angles of all joints at which the locked ones are held, rad (free joints: 0)."""
        out = np.zeros(5)
        for j, v in self.locked.items():  # type: ignore[union-attr]
            out[JOINTS.index(j)] = v
        return out
