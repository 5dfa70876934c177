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
| locked | {joint: rad} or None | angles of locked joints (None: zeros), within +-2 pi rad |
| setup | {dotted parameter name: value} | parameters of this run's set-up that differ from the rig's (a friction test's springs and masses, an added mass), in the parameter file's units, each within its allowed range (``rig_env.RigParams.replace`` checks them on the default rig) |
| name | str | a label for reports and error messages; records fitted or reported together need distinct names (:func:`rig_env.sysid.checks.check_record_names`) |

Construction checks every field and raises :class:`RecordError` naming the field and what is allowed
(numbers: Python's or numpy's, not bools).
It accepts any strictly increasing time: a record built by hand (or by a simulation) on an irregular
grid is legitimate.  Files are different: a reader (:meth:`FlightRecord.read`) also applies
:func:`check_sampling`, since an interval much longer than the rest in a recorded file is nearly always
lost data (``allow_gaps=True`` accepts it).

Surfaces between samples: a ``"commanded"`` record's sample k is the command in force over ``[t_k,
t_k+1)`` (zero-order hold: ``rig_env.simulate`` evaluates its controls at the start of each control step
and holds them, and the loop's command answering frame k acts until the next one); an ``"actual"``
record's deflections are interpolated linearly (:meth:`FlightRecord.surface_schedules`).

Pre-processing returns new records: :meth:`~FlightRecord.resample`, :meth:`~FlightRecord.segment`,
:meth:`~FlightRecord.smooth`, :meth:`~FlightRecord.with_noise`; :meth:`~FlightRecord.from_sim` makes a
record of a ``rig_env.simulate`` result; :meth:`~FlightRecord.write` and :meth:`~FlightRecord.read`
are :mod:`rig_env.sysid.readers`.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Mapping, Sequence

import numpy as np

from rig_env.params import JOINTS, PARAM_INDEX, PARAM_NAMES, SURFACES, ParameterError, RigParams
from rig_env.params_io import did_you_mean
from rig_env.sysid.checks import GAP_FACTOR, MIN_RECORD_SAMPLES, RecordError, check_sampling, is_number  # noqa: F401  (re-exported)
from rig_env.sysid.smoothing import DEFAULT_ITERATIONS, DEFAULT_SPAN, lowess

if TYPE_CHECKING:
    from rig_env.simulate import Schedule, SimResult
    from rig_env.sysid.readers import ColumnMap

SURFACE_KINDS = ("commanded", "actual")
AIRSPEED_RANGE = (0.0, 60.0)  # m/s, as simulate() allows
MAX_UPSAMPLE = 2.0  # resample() refuses rates above this many times the record's own (median) rate
LOCKED_LIMIT = 2.0 * math.pi  # rad: a locked angle beyond +-2 pi is a unit mistake (degrees), as rig identify says
SMOOTH_CHANNELS = ("q", "qd", "surfaces", "airspeed")


def _float_array(name: str, a: object, ndim: int | tuple[int, ...]) -> np.ndarray:
    """``a`` as a float64 array of ``ndim`` dimensions (one of them), finite; RecordError naming ``name`` otherwise
    (real numbers only: not bools, complex numbers or strings)."""
    try:
        raw = np.asarray(a)
        ok = raw.dtype.kind in "iuf" or (raw.dtype.kind == "O" and all(is_number(x) for x in raw.flat))
        arr = np.array(raw, dtype=np.float64) if ok else None
    except (TypeError, ValueError):
        arr = None
    if arr is None:
        raise RecordError(f"{name}: must be real numbers, got {type(a).__name__}" + (f" of {raw.dtype}" if isinstance(a, np.ndarray) else ""))
    dims = (ndim,) if isinstance(ndim, int) else ndim
    if arr.ndim not in dims:
        raise RecordError(f"{name}: expected a {' or '.join(f'{d}-D' for d in dims)} array, got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        first = np.argwhere(bad)[0]
        raise RecordError(f"{name}: {int(bad.sum())} non-finite value(s), the first at index {tuple(int(i) for i in first)}")
    return arr


def _mapping(name: str, v: object) -> dict:
    """``v`` (a mapping, or None: empty) as a dict; RecordError naming ``name`` otherwise."""
    if v is None:
        return {}
    if not isinstance(v, Mapping):
        raise RecordError(f"{name}: must be a mapping {{name: value}}, got {type(v).__name__}")
    return dict(v)


def _scalar(v: object) -> object:
    """A 0-d numpy array's value (a numpy scalar), other values as they are."""
    return v[()] if isinstance(v, np.ndarray) and v.ndim == 0 else v


@functools.lru_cache(maxsize=1)
def _default_rig() -> RigParams:
    """The default rig, on which a record's ``setup`` is range-checked (once per process)."""
    return RigParams.default()


def _held_index(t: np.ndarray, tq: np.ndarray) -> np.ndarray:
    """Index of the sample in force at each query time (the latest t_k <= tq, within rounding), clipped to [0, n-1]."""
    tol = 1e-9 * max(1.0, float(np.max(np.abs(t))))
    return np.clip(np.searchsorted(t, tq + tol, side="right") - 1, 0, t.size - 1)


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
        if not isinstance(self.name, str):
            raise RecordError(f"name = {self.name!r}: must be a string (the record's label in reports and messages)")
        t = _float_array(f"{self.name}: t", self.t, 1)
        if t.size < 2:
            raise RecordError(f"{self.name}: t needs at least 2 samples, got {t.size}")
        dt = np.diff(t)
        if np.any(dt <= 0.0):
            k = int(np.argmax(dt <= 0.0))
            raise RecordError(f"{self.name}: t must be strictly increasing; t[{k + 1}] = {t[k + 1]} s follows t[{k}] = {t[k]} s")
        set_(self, "t", t)
        n_t = t.size
        fd = self.free_dofs
        free = (fd,) if isinstance(fd, str) else tuple(fd) if isinstance(fd, (Sequence, np.ndarray)) else None
        if free is None or not all(isinstance(j, str) and j in JOINTS for j in free) or not free or len(set(free)) != len(free):
            raise RecordError(f"{self.name}: free_dofs = {list(free) if free is not None else fd!r}: give one or more distinct joints "
                              f"of {list(JOINTS)}")
        order = sorted(range(len(free)), key=lambda k: JOINTS.index(free[k]))
        set_(self, "free_dofs", tuple(free[k] for k in order))
        for label in ("q", "qd"):
            v = getattr(self, label)
            if v is None:
                continue
            a = _float_array(f"{self.name}: {label}", v, (1, 2))
            if a.ndim == 1:  # one free joint's series
                if a.size != n_t:
                    raise RecordError(f"{self.name}: {label} has {a.size} samples; t has {n_t} (a 1-D {label} is one free joint's series)")
                a = a[:, None]
            if a.shape != (n_t, len(free)):
                raise RecordError(f"{self.name}: {label} has shape {a.shape}; expected (n_t, n_free) = ({n_t}, {len(free)})")
            set_(self, label, a[:, order])
        if self.q is None:
            raise RecordError(f"{self.name}: q (the free joints' angles, rad) is required")
        surf: dict[str, np.ndarray] = {}
        for s, v in _mapping(f"{self.name}: surfaces", self.surfaces).items():
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
        air = _scalar(self.airspeed)
        if air is None or isinstance(air, (str, bytes, bool)) or np.ndim(air) == 0:  # type: ignore[arg-type]
            if not is_number(air):
                raise RecordError(f"{self.name}: airspeed = {air!r}: give the tunnel speed, m/s, as a number in [{lo}, {hi}] or a "
                                  f"series of n_t = {n_t} numbers")
            v = float(air)  # type: ignore[arg-type]
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
        locked = _mapping(f"{self.name}: locked", self.locked)
        for j, v in locked.items():
            if j not in JOINTS:
                raise RecordError(f"{self.name}: locked: unknown joint {j!r}; valid names: {list(JOINTS)}")
            if j in self.free_dofs:
                raise RecordError(f"{self.name}: locked: {j!r} is also a free joint")
            v = _scalar(v)
            if not (is_number(v) and math.isfinite(v) and abs(v) <= LOCKED_LIMIT):  # type: ignore[arg-type]
                raise RecordError(f"{self.name}: locked[{j!r}] = {v!r}: a locked angle must be a finite number within +-2 pi rad "
                                  "(+-360 deg); the angles are in rad")
            locked[j] = float(v)  # type: ignore[arg-type]
        set_(self, "locked", locked)
        setup = {}
        for k, v in _mapping(f"{self.name}: setup", self.setup).items():
            if not isinstance(k, str) or k not in PARAM_INDEX:
                hint = did_you_mean(k, PARAM_NAMES) if isinstance(k, str) else ""
                raise RecordError(f"{self.name}: setup: unknown parameter {k!r}{hint}; valid names: rig_env.PARAM_NAMES")
            v = _scalar(v)
            if not (is_number(v) and math.isfinite(v)):  # type: ignore[arg-type]
                raise RecordError(f"{self.name}: setup[{k!r}] = {v!r}: must be a finite number (the parameter file's units)")
            setup[k] = float(v)  # type: ignore[arg-type]
        if setup:
            try:  # each value within its allowed range, as the parameter file checks it
                _default_rig().replace(**setup)
            except ParameterError as e:
                raise RecordError(f"{self.name}: setup: {e}") from None
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

    def surface_schedules(self) -> dict[str, Callable[[float], float]]:
        """{surface: f(t s) -> deg}, the record's surfaces as ``rig_env.simulate`` controls.

        ``"commanded"``: zero-order hold (sample k over ``[t_k, t_k+1)``), so a record made by
        :meth:`from_sim` re-drives ``simulate`` with the very commands it was made from; ``"actual"``:
        linear interpolation.  Outside ``[t_0, t_-1]`` the end values hold.
        """
        t = self.t
        out: dict[str, Callable[[float], float]] = {}
        for s, v in self.surfaces.items():
            if self.surface_kind == "commanded":
                out[s] = lambda tq, v=v: float(v[_held_index(t, np.asarray(tq, dtype=np.float64))])
            else:
                out[s] = lambda tq, v=v: float(np.interp(tq, t, v))
        return out

    # ------------------------------------------------------------------ pre-processing
    def resample(self, rate_hz: float, *, allow_gaps: bool = False) -> FlightRecord:
        """The record on the uniform grid ``t_0 + k / rate_hz`` (k = 0, 1, ... while within the record).

        Angles, rates and an airspeed series: linear interpolation.  Surfaces: zero-order hold for a
        ``"commanded"`` record (the command in force at each new time), linear for ``"actual"``.  No
        anti-alias filter: :meth:`smooth` first when downsampling noisy data.  Upsampling is refused
        beyond ``MAX_UPSAMPLE`` (2) times the record's median rate (interpolated samples carry no new
        information and make the residuals of a fit correlated, which shrinks its error bounds
        falsely); the record is refused if it has gaps (:func:`check_sampling`) unless ``allow_gaps``,
        in which case the gaps are interpolated across.
        """
        rate = float(rate_hz) if is_number(rate_hz) else math.nan
        own = 1.0 / self.dt
        if not (math.isfinite(rate) and 0.0 < rate <= MAX_UPSAMPLE * own * (1.0 + 1e-9)):
            raise RecordError(f"{self.name}: resample: rate_hz = {rate_hz}; allowed (0, {MAX_UPSAMPLE * own:.6g}] Hz ({MAX_UPSAMPLE:g} x the "
                              f"record's {own:.6g} Hz)")
        check_sampling(self.t, self.name, allow_gaps)
        n = math.floor(self.duration * rate + 1e-6) + 1
        if n < 2:
            raise RecordError(f"{self.name}: resample: {rate} Hz gives {n} sample over the record's {self.duration:.6g} s")
        t = self.t[0] + np.arange(n) / rate
        t[-1] = min(t[-1], self.t[-1])

        def lin(a: np.ndarray) -> np.ndarray:
            return np.column_stack([np.interp(t, self.t, a[:, k]) for k in range(a.shape[1])])

        held = _held_index(self.t, t)
        surf = {s: (v[held] if self.surface_kind == "commanded" else np.interp(t, self.t, v)) for s, v in self.surfaces.items()}
        air = self.airspeed if np.ndim(self.airspeed) == 0 else np.interp(t, self.t, self.airspeed)  # type: ignore[arg-type]
        return dataclasses.replace(self, t=t, q=lin(self.q), qd=None if self.qd is None else lin(self.qd), surfaces=surf, airspeed=air)

    def segment(self, t_start: float, t_end: float, *, rebase: bool = False) -> FlightRecord:
        """The samples with ``t_start <= t <= t_end`` (s, the record's own times).

        Times stay absolute (a segment lines up with its parent and its siblings) unless ``rebase``
        (then they start at 0).  A window that is empty, reversed, reaches outside ``[t_0, t_-1]`` or
        holds fewer than 2 samples is an error.  The name gains ``[t_start:t_end]``.
        """
        a, b = (float(v) if is_number(v) else math.nan for v in (t_start, t_end))
        t = self.t
        tol = 1e-9 * max(1.0, float(np.max(np.abs(t))))
        if not (math.isfinite(a) and math.isfinite(b) and a < b):
            raise RecordError(f"{self.name}: segment: window [{t_start}, {t_end}] s; need finite t_start < t_end")
        if a < t[0] - tol or b > t[-1] + tol:
            raise RecordError(f"{self.name}: segment: window [{a:.6g}, {b:.6g}] s reaches outside the record's span [{t[0]:.6g}, {t[-1]:.6g}] s")
        keep = (t >= a - tol) & (t <= b + tol)
        if keep.sum() < 2:
            raise RecordError(f"{self.name}: segment: window [{a:.6g}, {b:.6g}] s holds {int(keep.sum())} sample(s); a record needs at least 2")
        tk = t[keep] - (t[keep][0] if rebase else 0.0)
        return dataclasses.replace(
            self, t=tk, q=self.q[keep], qd=None if self.qd is None else self.qd[keep],
            surfaces={s: v[keep] for s, v in self.surfaces.items()},
            airspeed=self.airspeed if np.ndim(self.airspeed) == 0 else self.airspeed[keep],  # type: ignore[index]
            name=f"{self.name}[{a:g}:{b:g}]",
        )

    def smooth(self, span: int = DEFAULT_SPAN, channels: Sequence[str] = ("q", "qd"), robust: bool = True,
               iterations: int = DEFAULT_ITERATIONS) -> FlightRecord:
        """The record with ``channels`` smoothed by robust LOWESS over ``span`` samples (:mod:`rig_env.sysid.smoothing`).

        channels: any of ``"q"``, ``"qd"`` (skipped when rates were not measured), ``"surfaces"``,
        ``"airspeed"`` (a series; a constant is left alone).  Each column is smoothed on its own, against t.
        """
        chans = (channels,) if isinstance(channels, str) else tuple(channels)
        bad = [c for c in chans if c not in SMOOTH_CHANNELS]
        if bad:
            raise RecordError(f"{self.name}: smooth: unknown channel(s) {bad}; allowed: {', '.join(SMOOTH_CHANNELS)}")

        def sm(a: np.ndarray) -> np.ndarray:
            try:
                return lowess(a, self.t, span, robust, iterations)
            except ValueError as e:
                raise RecordError(f"{self.name}: smooth: {e}") from None

        changes: dict[str, object] = {}
        if "q" in chans:
            changes["q"] = sm(self.q)
        if "qd" in chans and self.qd is not None:
            changes["qd"] = sm(self.qd)
        if "surfaces" in chans and self.surfaces:
            names = list(self.surfaces)
            S = sm(np.column_stack([self.surfaces[s] for s in names]))
            changes["surfaces"] = {s: S[:, k] for k, s in enumerate(names)}
        if "airspeed" in chans and np.ndim(self.airspeed) == 1:
            changes["airspeed"] = np.clip(sm(np.asarray(self.airspeed)), *AIRSPEED_RANGE)
        return dataclasses.replace(self, **changes)

    def with_noise(self, std_rad: float | Sequence[float], seed: int, std_rad_s: float | Sequence[float] | None = None) -> FlightRecord:
        """The record with white Gaussian measurement noise added to the angles (and the rates).

        std_rad: standard deviation, rad, one value or one per free joint (``free_dofs`` order);
        std_rad_s: the same for the rates, rad/s (the record must have rates).  seed: of
        ``numpy.random.default_rng`` (same seed, same noise).
        """
        rng = np.random.default_rng(seed)

        def std(label: str, v: float | Sequence[float]) -> np.ndarray:
            raw = np.asarray(v)
            a = raw.astype(np.float64) if raw.dtype.kind in "iuf" else np.full(raw.shape, np.nan)
            if a.ndim > 1 or (a.ndim == 1 and a.size != len(self.free_dofs)) or not np.all(np.isfinite(a)) or np.any(a < 0):
                raise RecordError(f"{self.name}: with_noise: {label} = {v!r}; one finite value >= 0 or one per free joint ({len(self.free_dofs)})")
            return np.broadcast_to(a, (len(self.free_dofs),))

        q = self.q + rng.standard_normal(self.q.shape) * std("std_rad", std_rad)
        qd = self.qd
        if std_rad_s is not None:
            if qd is None:
                raise RecordError(f"{self.name}: with_noise: std_rad_s given but the record has no rates")
            qd = qd + rng.standard_normal(qd.shape) * std("std_rad_s", std_rad_s)
        return dataclasses.replace(self, q=q, qd=qd)

    # ------------------------------------------------------------------ conversions
    @classmethod
    def from_sim(cls, result: SimResult, *, surfaces: Mapping[str, Schedule] | None = None, airspeed: Schedule = 20.0,
                 rates: bool = False, env: int | None = None, surface_kind: str = "commanded",
                 setup: Mapping[str, float] | None = None, name: str = "simulation") -> FlightRecord:
        """A record of a ``rig_env.simulate`` result.

        surfaces, airspeed: the ``controls`` and ``airspeed`` that drove the simulation (deg, m/s; any
        form ``simulate`` takes), sampled at the result's times as ``simulate`` held them: the value at
        ``t_k`` (evaluated there, as ``simulate`` does at the start of each control step) is sample k and
        acts over ``[t_k, t_k+1)``, the record's zero-order hold.  An airspeed given as a function of
        time becomes a series.  rates: keep the simulated rates as measured ones.  env: which
        environment of a batched result (required then).  surface_kind: ``"commanded"`` when the
        servos were simulated (``servo=True``), ``"actual"`` when ``simulate`` ran with ``servo=False``.
        The locked joints' angles come from the result.  setup: the parameter overrides of the run.
        """
        from rig_env.simulate import check_controls

        batched = np.ndim(result.q) == 3
        if batched:
            n_env = result.q.shape[0]
            if env is None or not (isinstance(env, (int, np.integer)) and 0 <= env < n_env):
                raise RecordError(f"{name}: from_sim: a batched result of {n_env} environments; give env= in [0, {n_env - 1}]")
            q, qd, q_all = result.q[env], result.qd[env], result.q_all[env]
        else:
            n_env = 1
            if env not in (None, 0):
                raise RecordError(f"{name}: from_sim: env = {env!r} for a single-environment result (use None)")
            env, q, qd, q_all = 0, result.q, result.qd, result.q_all
        try:
            controls = check_controls(surfaces)
        except ValueError as e:
            raise RecordError(f"{name}: from_sim: surfaces: {e}") from None
        t = np.asarray(result.t, dtype=np.float64)

        def sample(label: str, s: Schedule) -> np.ndarray:
            out = np.empty(t.size)
            for k, tk in enumerate(t):
                v = np.asarray(s(float(tk)) if callable(s) else s, dtype=np.float64)
                try:
                    out[k] = np.broadcast_to(v, (n_env,))[env]
                except ValueError:
                    raise RecordError(f"{name}: from_sim: {label}: value of shape {v.shape} does not broadcast to ({n_env},)") from None
            return out

        surf = {s: sample(f"surfaces[{s!r}]", v) for s, v in controls.items()}
        air: float | np.ndarray = float(np.broadcast_to(np.asarray(airspeed, dtype=np.float64), (n_env,))[env]) if not callable(airspeed) \
            else sample("airspeed", airspeed)
        locked = {j: float(q_all[0, k]) for k, j in enumerate(JOINTS) if j not in result.free_dofs}
        return cls(t=t.copy(), free_dofs=tuple(result.free_dofs), q=np.array(q), qd=np.array(qd) if rates else None, surfaces=surf,
                   airspeed=air, locked=locked, surface_kind=surface_kind, setup=dict(setup or {}), name=name)

    def write(self, path: str | os.PathLike, overwrite: bool = False) -> Path:
        """Write in the project's layout; the format follows the suffix (.csv, .npz, .mat; :mod:`rig_env.sysid.readers`).

        An existing file is an error unless ``overwrite``.  Returns the path.
        """
        from rig_env.sysid.readers import write

        return write(self, path, overwrite)

    @classmethod
    def read(cls, path: str | os.PathLike, columns: ColumnMap | None = None, *, free_dofs: Sequence[str] | None = None,
             locked: Mapping[str, float] | None = None, surface_kind: str | None = None, airspeed: float | None = None,
             setup: Mapping[str, float] | None = None, name: str | None = None, allow_gaps: bool = False) -> FlightRecord:
        """A record from a frame log, .csv, .npz or .mat file (:func:`rig_env.sysid.readers.read_fields`).

        The project's own files and frame logs need no ``columns``; a foreign file needs the column map
        ``{field: (column, unit)}`` and its configuration (``airspeed=`` unless mapped, ``surface_kind=``
        when surfaces are mapped, ``locked=``, ``setup=``, ``name=``).  Gaps in the times are an error
        unless ``allow_gaps`` (:func:`check_sampling`).
        """
        from rig_env.sysid.readers import read_fields

        return cls(**read_fields(path, columns, free_dofs=free_dofs, locked=locked, surface_kind=surface_kind, airspeed=airspeed,
                                 setup=setup, name=name, allow_gaps=allow_gaps))


def read_frame_log(path: str | os.PathLike, *, free_dofs: Sequence[str] | None = None, locked: Mapping[str, float] | None = None,
                   surface_kind: str = "commanded", setup: Mapping[str, float] | None = None, name: str | None = None,
                   allow_gaps: bool = False) -> FlightRecord:
    """A record from the real-time loop's frame log (:func:`rig_env.sysid.readers.frame_log_fields`: one sample
    per fresh sensor frame, the command sent after it held until the next)."""
    from rig_env.sysid.readers import frame_log_fields

    return FlightRecord(**frame_log_fields(path, free_dofs=free_dofs, locked=locked, surface_kind=surface_kind, setup=setup, name=name,
                                           allow_gaps=allow_gaps))
