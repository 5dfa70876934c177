"""Test inputs on the control surfaces: shapes of time, and the :class:`InputSchedule` that flies them.

One schedule drives :func:`rig_env.simulate` (``controls=schedule.controls()``), the environments' pilot
inputs (``RigEnvConfig(pilot_inputs=schedule)``) and the rig's real-time loop
(``LoopConfig(test_input=schedule)``, ``rig-deploy run --test-input FILE.json``), so a test planned here
is flown in simulation and on the rig with the same numbers.  Every caller evaluates the schedule at the
start of each control step and holds the value over the step.

| shape | fields (deg, s, Hz, rad) | value at time t |
|---|---|---|
| :class:`ThreeTwoOneOne` | amplitude_deg, unit_s (0.28), start_s | +A for 3 units from start_s, -A for 2, +A for 1, -A for 1, then 0 |
| :class:`Doublet` | amplitude_deg, period_s (1.0), start_s | +A for half a period from start_s, -A for the other half, then 0 |
| :class:`Step` | amplitude_deg, duration_s, start_s | A for duration_s from start_s, then 0 (a pulse; a long one is a step) |
| :class:`Multisine` | frequencies_hz, amplitudes_deg, phases_rad, duration_s, start_s | sum A_k sin(2 pi f_k (t - start_s) + phi_k) inside [start_s, start_s + duration_s), 0 outside |
| :class:`Sampled` | values_deg, dt_s, start_s | values_deg[k] over [start_s + k dt_s, start_s + (k + 1) dt_s) (zero-order hold), 0 outside |

Every window is closed at its start and open at its end.  The schedule's time is its own: t = 0 is the
start of the simulation, the episode, or the loop's arming.  Plain data both ways (:meth:`InputSchedule.to_data`,
:meth:`InputSchedule.from_data`, JSON files by :meth:`InputSchedule.save` / :meth:`InputSchedule.load`;
never pickle).  numpy and the standard library only: the rig process imports this module.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar, Union

import numpy as np

from rig_env.params import SURFACES

UNIT_3211 = 0.28
"""s, the unit of the paper's 3-2-1-1 on the Hawk elevator (Sec. V: a third of the 1.2 Hz short period)."""
FORMAT = "rig_env.InputSchedule"
VERSION = 1
_SAMPLE_TOL = 1e-9  # fraction of a sample: a time this close below a sample boundary counts as the next sample
MAX_CHECK_SAMPLES = 1 << 22
"""Most samples :meth:`InputSchedule.check` evaluates per surface (4194304: 14.5 hours at 80 Hz, 4.8 hours at 244 Hz);
a check of more (a tiny ``dt`` or a very long schedule) is refused, naming dt and the duration."""
_CHUNK = 1 << 20  # values (samples x components) evaluated at once: bounds the memory of a long or rich evaluation


class ScheduleError(ValueError):
    """A shape or schedule that cannot be used: the message names the field and what is allowed."""


# ---------------------------------------------------------------------- the step shapes as functions of arrays
def three_two_one_one(t: np.ndarray, t0: np.ndarray | float, amp: np.ndarray | float, unit: float = UNIT_3211) -> np.ndarray:
    """3-2-1-1, same shape as ``t`` (broadcast with t0, amp): +amp for 3 units from t0, -amp for 2, +amp for 1,
    -amp for 1, then 0.  t, t0: s; unit: s; amp in the caller's unit (deg or rad)."""
    k = (t - t0) / unit
    return amp * np.select([k < 0.0, k < 3.0, k < 5.0, k < 6.0, k < 7.0], [0.0, 1.0, -1.0, 1.0, -1.0], 0.0)


def doublet(t: np.ndarray, t0: np.ndarray | float, amp: np.ndarray | float, period: float = 1.0) -> np.ndarray:
    """Doublet, same shape as ``t``: +amp for half a period from t0, -amp for the other half, then 0 (s)."""
    k = (t - t0) / period
    return amp * np.select([k < 0.0, k < 0.5, k < 1.0], [0.0, 1.0, -1.0], 0.0)


# ---------------------------------------------------------------------- validation of the fields
def _number(owner: str, name: str, v: Any, *, positive: bool = False, nonneg: bool = False) -> float:
    ok = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) and math.isfinite(v)
    if ok and positive and not v > 0.0:
        ok = False
    if ok and nonneg and not v >= 0.0:
        ok = False
    if not ok:
        need = "a positive" if positive else "a non-negative" if nonneg else "a"
        raise ScheduleError(f"{owner}.{name} = {v!r}: must be {need} finite number")
    return float(v)


def _numbers(owner: str, name: str, v: Any, *, positive: bool = False) -> tuple[float, ...]:
    if isinstance(v, (str, bytes, Mapping)) or not isinstance(v, (Sequence, np.ndarray)):
        raise ScheduleError(f"{owner}.{name}: must be a sequence of numbers, got {type(v).__name__}")
    if isinstance(v, np.ndarray) and v.ndim != 1:
        raise ScheduleError(f"{owner}.{name}: must be a flat sequence of numbers, got an array of shape {v.shape}")
    for k, x in enumerate(v):
        if isinstance(x, (Sequence, np.ndarray)) and not isinstance(x, (str, bytes)):
            raise ScheduleError(f"{owner}.{name}[{k}] = {x!r}: must be a number ({name} is a flat sequence, not nested)")
    out = tuple(_number(owner, f"{name}[{k}]", x, positive=positive) for k, x in enumerate(v))
    if not out:
        raise ScheduleError(f"{owner}.{name}: must not be empty")
    return out


class _Shape:
    """What every shape shares: ``kind``, validation, ``end_s``, plain data."""

    kind: ClassVar[str]
    _positive: ClassVar[tuple[str, ...]] = ()  # fields that must be > 0
    _sequences: ClassVar[tuple[str, ...]] = ()  # fields that are sequences of numbers

    def _check(self) -> None:
        owner = type(self).__name__
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            if not f.init:
                continue
            v = getattr(self, f.name)
            if f.name in self._sequences:
                object.__setattr__(self, f.name, _numbers(owner, f.name, v, positive=f.name in self._positive))
            else:
                object.__setattr__(self, f.name, _number(owner, f.name, v, positive=f.name in self._positive, nonneg=f.name == "start_s"))

    @property
    def end_s(self) -> float:
        """Time from which the shape is 0 for good, s."""
        raise NotImplementedError

    def to_data(self) -> dict[str, Any]:
        """``{"kind": ..., field: value}``, JSON-able (sequences as lists)."""
        out: dict[str, Any] = {"kind": self.kind}
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            if f.init:
                v = getattr(self, f.name)
                out[f.name] = list(v) if isinstance(v, tuple) else v
        return out


@dataclass(frozen=True)
class ThreeTwoOneOne(_Shape):
    """3-2-1-1 multistep of ``amplitude_deg`` deg with a ``unit_s`` s unit from ``start_s`` s (7 units long)."""

    amplitude_deg: float
    unit_s: float = UNIT_3211
    start_s: float = 0.0
    kind: ClassVar[str] = "three_two_one_one"
    _positive: ClassVar[tuple[str, ...]] = ("unit_s",)

    def __post_init__(self) -> None:
        self._check()

    @property
    def end_s(self) -> float:
        return self.start_s + 7.0 * self.unit_s

    def __call__(self, t: np.ndarray | float) -> np.ndarray:
        """Deflection at times t (s, any shape), deg."""
        return three_two_one_one(np.asarray(t, dtype=np.float64), self.start_s, self.amplitude_deg, self.unit_s)


@dataclass(frozen=True)
class Doublet(_Shape):
    """Doublet of ``amplitude_deg`` deg and ``period_s`` s from ``start_s`` s (the paper's compensator doublet: 1 s)."""

    amplitude_deg: float
    period_s: float = 1.0
    start_s: float = 0.0
    kind: ClassVar[str] = "doublet"
    _positive: ClassVar[tuple[str, ...]] = ("period_s",)

    def __post_init__(self) -> None:
        self._check()

    @property
    def end_s(self) -> float:
        return self.start_s + self.period_s

    def __call__(self, t: np.ndarray | float) -> np.ndarray:
        """Deflection at times t (s, any shape), deg."""
        return doublet(np.asarray(t, dtype=np.float64), self.start_s, self.amplitude_deg, self.period_s)


@dataclass(frozen=True)
class Step(_Shape):
    """``amplitude_deg`` deg held for ``duration_s`` s from ``start_s`` s, then 0: a pulse (a step for a test shorter than it)."""

    amplitude_deg: float
    duration_s: float
    start_s: float = 0.0
    kind: ClassVar[str] = "step"
    _positive: ClassVar[tuple[str, ...]] = ("duration_s",)

    def __post_init__(self) -> None:
        self._check()

    @property
    def end_s(self) -> float:
        return self.start_s + self.duration_s

    def __call__(self, t: np.ndarray | float) -> np.ndarray:
        """Deflection at times t (s, any shape), deg."""
        k = (np.asarray(t, dtype=np.float64) - self.start_s) / self.duration_s
        return self.amplitude_deg * np.select([k < 0.0, k < 1.0], [0.0, 1.0], 0.0)


@dataclass(frozen=True)
class Multisine(_Shape):
    """Sum of sines ``A_k sin(2 pi f_k (t - start_s) + phi_k)`` (deg; Hz; rad) inside [start_s, start_s + duration_s), 0 outside.

    With every f_k a harmonic of ``1 / duration_s`` the window is whole periods; :mod:`rig_env.sysid.inputs`
    designs them (orthogonal across surfaces, minimum peak factor, zero at both ends).
    """

    frequencies_hz: tuple[float, ...]
    amplitudes_deg: tuple[float, ...]
    phases_rad: tuple[float, ...]
    duration_s: float
    start_s: float = 0.0
    kind: ClassVar[str] = "multisine"
    _positive: ClassVar[tuple[str, ...]] = ("frequencies_hz", "duration_s")
    _sequences: ClassVar[tuple[str, ...]] = ("frequencies_hz", "amplitudes_deg", "phases_rad")
    _arrays: tuple[np.ndarray, np.ndarray, np.ndarray] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        self._check()
        n = {len(self.frequencies_hz), len(self.amplitudes_deg), len(self.phases_rad)}
        if len(n) != 1:
            raise ScheduleError(f"Multisine: frequencies_hz, amplitudes_deg and phases_rad need the same length, got "
                                f"{len(self.frequencies_hz)}, {len(self.amplitudes_deg)}, {len(self.phases_rad)}")
        object.__setattr__(self, "_arrays", tuple(np.array(v) for v in (self.frequencies_hz, self.amplitudes_deg, self.phases_rad)))

    @property
    def end_s(self) -> float:
        return self.start_s + self.duration_s

    def __call__(self, t: np.ndarray | float) -> np.ndarray:
        """Deflection at times t (s, any shape), deg."""
        f, a, p = self._arrays
        tau = np.asarray(t, dtype=np.float64) - self.start_s
        flat = tau.ravel()
        u = np.empty(flat.size)
        step = max(1, _CHUNK // f.size)  # in blocks: samples x components bounded, whatever the length of t
        for i in range(0, flat.size, step):
            u[i : i + step] = (np.sin(2.0 * math.pi * np.multiply.outer(flat[i : i + step], f) + p) * a).sum(axis=-1)
        return np.where((tau >= 0.0) & (tau < self.duration_s), u.reshape(tau.shape), 0.0)

    @property
    def relative_peak_factor(self) -> float:
        """max |u| / (sqrt(2) rms(u)) over the window (1 for a single sine), on a grid of at least 64 points
        per period of the highest frequency (and 4096 in all)."""
        n = int(min(1 << 20, max(4096, 64.0 * max(self.frequencies_hz) * self.duration_s)))
        f, a, p = self._arrays
        k = f * self.duration_s
        kk = np.round(k).astype(np.int64)
        if np.all(np.abs(k - kk) <= 1e-9 * k) and kk.min() >= 1 and kk.max() < n // 2:
            # harmonics of 1 / duration_s (as designed): the same grid by one inverse FFT, not n x components sines
            X = np.zeros(n // 2 + 1, dtype=np.complex128)
            np.add.at(X, kk, 0.5 * n * a * np.exp(1j * (p - 0.5 * math.pi)))
            u = np.fft.irfft(X, n)
        else:
            u = self(self.start_s + self.duration_s * np.arange(n) / n)
        return float(np.abs(u).max() / (math.sqrt(2.0) * math.sqrt(np.mean(u**2))))


@dataclass(frozen=True)
class Sampled(_Shape):
    """A sampled series held between samples: ``values_deg[k]`` over [start_s + k dt_s, start_s + (k + 1) dt_s), 0 outside.

    A time within 1e-9 of a sample interval below a boundary counts as the next sample, so a series
    sampled at the control step replays sample k at step k despite the rounding of ``k * dt``.
    """

    values_deg: tuple[float, ...]
    dt_s: float
    start_s: float = 0.0
    kind: ClassVar[str] = "sampled"
    _positive: ClassVar[tuple[str, ...]] = ("dt_s",)
    _sequences: ClassVar[tuple[str, ...]] = ("values_deg",)
    _values: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        self._check()
        object.__setattr__(self, "_values", np.append(np.array(self.values_deg), 0.0))  # index n: after the end

    @property
    def end_s(self) -> float:
        return self.start_s + len(self.values_deg) * self.dt_s

    def __call__(self, t: np.ndarray | float) -> np.ndarray:
        """Deflection at times t (s, any shape), deg."""
        k = np.floor((np.asarray(t, dtype=np.float64) - self.start_s) / self.dt_s + _SAMPLE_TOL)
        n = len(self.values_deg)
        return np.where(k >= 0.0, self._values[np.clip(k, 0, n).astype(np.int64)], 0.0)


Shape = Union[ThreeTwoOneOne, Doublet, Step, Multisine, Sampled]
SHAPES: dict[str, type] = {c.kind: c for c in (ThreeTwoOneOne, Doublet, Step, Multisine, Sampled)}
"""Shape classes by their ``kind`` (the ``"kind"`` of their plain data)."""


def shape_from_data(data: Mapping[str, Any], where: str = "shape") -> Shape:
    """The shape a :meth:`to_data` dict describes; :class:`ScheduleError` naming ``where`` and the problem."""
    if not isinstance(data, Mapping):
        raise ScheduleError(f"{where}: expected an object with a 'kind', got {type(data).__name__}")
    kind = data.get("kind")
    if kind not in SHAPES:
        raise ScheduleError(f"{where}: unknown shape kind {kind!r}; valid kinds: {sorted(SHAPES)}")
    cls = SHAPES[kind]
    names = [f.name for f in dataclasses.fields(cls) if f.init]
    required = [f.name for f in dataclasses.fields(cls) if f.init and f.default is dataclasses.MISSING]
    unknown = sorted(set(data) - set(names) - {"kind"})
    missing = [n for n in required if n not in data]
    if unknown or missing:
        raise ScheduleError(f"{where} ({kind}): " + "; ".join(
            ([f"unknown field(s) {unknown}"] if unknown else []) + ([f"missing field(s) {missing}"] if missing else []))
            + f"; fields: {names}")
    try:
        return cls(**{k: v for k, v in data.items() if k != "kind"})
    except ScheduleError as e:
        raise ScheduleError(f"{where}: {e}") from None


# ---------------------------------------------------------------------- the schedule
@dataclass(frozen=True)
class InputSchedule:
    """Test inputs by surface: ``{name in rig_env.SURFACES: shape or sequence of shapes (summed)}``, deg.

    ``shapes`` is normalised to ``{name: tuple of shapes}`` in SURFACES order; surfaces it does not name
    are held at 0.  Evaluation: ``schedule(t)`` (values by surface), :meth:`controls` (for
    :func:`rig_env.simulate`), :meth:`sample` (an array).  :meth:`check` compares the held command with
    the servos' position and rate limits.
    """

    shapes: Mapping[str, Shape | Sequence[Shape]]

    def __post_init__(self) -> None:
        if not isinstance(self.shapes, Mapping):
            raise ScheduleError(f"InputSchedule: shapes must be a mapping of surface names to shapes, got {type(self.shapes).__name__}")
        unknown = [s for s in self.shapes if s not in SURFACES]
        if unknown:
            raise ScheduleError(f"InputSchedule: unknown surface(s) {unknown}; valid names: {list(SURFACES)}")
        out: dict[str, tuple[Shape, ...]] = {}
        for s in SURFACES:
            if s not in self.shapes:
                continue
            v = self.shapes[s]
            seq = (v,) if isinstance(v, _Shape) else tuple(v) if isinstance(v, (list, tuple)) else None
            if seq is None or not all(isinstance(x, _Shape) for x in seq):
                raise ScheduleError(f"InputSchedule: shapes[{s!r}] must be a shape ({', '.join(c.__name__ for c in SHAPES.values())}) "
                                    f"or a sequence of them, got {v!r}")
            out[s] = seq
        object.__setattr__(self, "shapes", out)

    @property
    def surfaces(self) -> tuple[str, ...]:
        """The scheduled surfaces, in SURFACES order."""
        return tuple(self.shapes)

    @property
    def duration(self) -> float:
        """s from t = 0 after which every scheduled value is 0 for good (0.0 for an empty schedule)."""
        return max((x.end_s for seq in self.shapes.values() for x in seq), default=0.0)

    def value(self, surface: str, t: np.ndarray | float) -> np.ndarray:
        """Command of one surface at times t (s, any shape), deg (zeros for an unscheduled surface)."""
        if surface not in SURFACES:
            raise ScheduleError(f"surface {surface!r}: unknown; valid names: {list(SURFACES)}")
        tt = np.asarray(t, dtype=np.float64)
        out = np.zeros(tt.shape)
        for x in self.shapes.get(surface, ()):
            out = out + x(tt)
        return out

    def __call__(self, t: np.ndarray | float) -> dict[str, float | np.ndarray]:
        """Commands of the scheduled surfaces at times t (s), deg: floats for a scalar t, else arrays of t's shape."""
        if np.ndim(t) == 0:
            return {s: float(self.value(s, t)) for s in self.shapes}
        return {s: self.value(s, t) for s in self.shapes}

    def controls(self) -> dict[str, Callable[[float], float]]:
        """``{surface: f(t s) -> deg}``, exactly what ``rig_env.simulate(controls=...)`` takes."""
        return {s: (lambda t, s=s: float(self.value(s, t))) for s in self.shapes}

    def sample(self, t: np.ndarray | Sequence[float]) -> np.ndarray:
        """(n_t, len(SURFACES)) commands at the times t (n_t,) s, deg, columns in SURFACES order."""
        tt = np.asarray(t, dtype=np.float64)
        if tt.ndim != 1:
            raise ValueError(f"sample: t must be 1-D times, s; got shape {tt.shape}")
        return np.stack([self.value(s, tt) for s in SURFACES], axis=1)

    def check(self, limit_deg: float = 40.0, rate_deg_s: float = 350.0, dt: float = 1.0 / 80.0) -> None:
        """ValueError naming the surface, the time and the limit if the command, sampled every ``dt`` s from
        t = 0 and held, exceeds +-``limit_deg`` deg or changes faster than ``rate_deg_s`` deg/s between
        samples (the command before t = 0 is 0: the servos start at rest at 0).  At most
        :data:`MAX_CHECK_SAMPLES` samples (``duration / dt + 2``): a check of more is refused, naming dt."""
        for name, v in (("limit_deg", limit_deg), ("rate_deg_s", rate_deg_s), ("dt", dt)):
            _number("check", name, v, positive=True)
        dt = float(dt)
        count = self.duration / dt + 2.0
        if not count <= MAX_CHECK_SAMPLES:  # also inf
            raise ScheduleError(f"check: dt = {dt:g} s over the schedule's {self.duration:g} s is {count:.4g} samples, more than "
                                f"{MAX_CHECK_SAMPLES} (rig_env.signals.MAX_CHECK_SAMPLES); check with a larger dt or shorten the schedule")
        n = int(math.ceil(self.duration / dt)) + 2
        for s in self.shapes:  # SURFACES order
            fast_at: tuple[float, float] | None = None  # the first rate excess (reported if no position excess)
            before = 0.0
            for i in range(0, n, 1 << 16):  # in blocks: bounded memory
                t = np.arange(i, min(n, i + (1 << 16))) * dt
                u = self.value(s, t)
                over = np.flatnonzero(np.abs(u) > limit_deg * (1.0 + 1e-12))
                if over.size:
                    k = over[0]
                    raise ScheduleError(f"{s}: {u[k]:.4g} deg at t = {t[k]:.4f} s exceeds the position limit +-{limit_deg:g} deg")
                rate = np.diff(u, prepend=before) / dt
                before = float(u[-1])
                fast = np.flatnonzero(np.abs(rate) > rate_deg_s * (1.0 + 1e-12))
                if fast.size and fast_at is None:
                    fast_at = (float(abs(rate[fast[0]])), float(t[fast[0]]))
            if fast_at is not None:
                raise ScheduleError(f"{s}: the command changes at {fast_at[0]:.4g} deg/s at t = {fast_at[1]:.4f} s (held every {dt:g} s), "
                                    f"beyond the rate limit {rate_deg_s:g} deg/s")

    # ------------------------------------------------------------------ plain data
    def to_data(self) -> dict[str, Any]:
        """``{"format", "version", "surfaces": {name: [shape data, ...]}}``, JSON-able."""
        return {"format": FORMAT, "version": VERSION, "surfaces": {s: [x.to_data() for x in seq] for s, seq in self.shapes.items()}}

    @classmethod
    def from_data(cls, data: Mapping[str, Any]) -> "InputSchedule":
        """The schedule of a :meth:`to_data` dict; :class:`ScheduleError` naming what is wrong."""
        if not isinstance(data, Mapping):
            raise ScheduleError(f"input schedule: expected an object, got {type(data).__name__}")
        if data.get("format") != FORMAT or data.get("version") != VERSION:
            raise ScheduleError(f"input schedule: format {data.get('format')!r} version {data.get('version')!r}; expected {FORMAT!r} version {VERSION}")
        unknown = sorted(set(data) - {"format", "version", "surfaces"})
        if unknown:
            raise ScheduleError(f"input schedule: unknown key(s) {unknown}; keys: format, version, surfaces")
        surf = data.get("surfaces")
        if not isinstance(surf, Mapping):
            raise ScheduleError("input schedule: 'surfaces' must be an object {surface name: [shape, ...]}")
        shapes: dict[str, list[Shape]] = {}
        for s, seq in surf.items():
            if s not in SURFACES:
                raise ScheduleError(f"input schedule: unknown surface {s!r}; valid names: {list(SURFACES)}")
            if not isinstance(seq, list):
                raise ScheduleError(f"input schedule: surfaces[{s!r}] must be a list of shapes")
            shapes[s] = [shape_from_data(x, f"surfaces[{s!r}][{k}]") for k, x in enumerate(seq)]
        return cls(shapes)

    def save(self, path: str | Path, overwrite: bool = False) -> None:
        """Write the schedule as JSON; FileExistsError if ``path`` exists unless ``overwrite``."""
        text = json.dumps(self.to_data(), indent=1, allow_nan=False) + "\n"
        with open(path, "w" if overwrite else "x") as f:
            f.write(text)

    @classmethod
    def load(cls, path: str | Path) -> "InputSchedule":
        """The schedule in a JSON file written by :meth:`save`; ScheduleError naming the file and the problem
        (a missing, unreadable or non-UTF-8 file too)."""
        try:
            raw = Path(path).read_bytes()
        except FileNotFoundError as e:
            raise ScheduleError(f"{path}: input schedule file not found ({e.strerror})") from None
        except IsADirectoryError:
            raise ScheduleError(f"{path}: is a folder, not an input schedule file") from None
        except OSError as e:
            raise ScheduleError(f"{path}: cannot be read ({e.strerror or e})") from None
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as e:
            raise ScheduleError(f"{path}: not an input schedule (not UTF-8 text: byte {e.start} is {raw[e.start:e.start + 1]!r})") from None

        def refuse(token: str) -> float:
            raise ScheduleError(f"{path}: non-finite number {token} (numbers must be finite)")

        try:
            data = json.loads(text, parse_constant=refuse)
        except json.JSONDecodeError as e:
            raise ScheduleError(f"{path}: not JSON ({e})") from None
        try:
            return cls.from_data(data)
        except ScheduleError as e:
            raise ScheduleError(f"{path}: {e}") from None


__all__ = [
    "MAX_CHECK_SAMPLES", "SHAPES", "UNIT_3211", "Doublet", "InputSchedule", "Multisine", "Sampled", "ScheduleError", "Shape", "Step",
    "ThreeTwoOneOne", "doublet", "shape_from_data", "three_two_one_one",
]
