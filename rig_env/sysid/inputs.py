"""Input design for identification: the paper's 3-2-1-1 and doublet, and orthogonal multisines.

Each function returns a :class:`rig_env.signals.InputSchedule` (deg, s), which :func:`rig_env.simulate`,
the environments (``RigEnvConfig(pilot_inputs=...)``) and the rig's loop (``rig-deploy run --test-input``)
fly as it is.

Orthogonal multisines (:func:`multisine`) follow Morelli's design: over the test length T the
harmonics k / T inside [f_min, f_max] are dealt to the surfaces in turn (surface j gets harmonics j,
j + m, j + 2m, ... of the band for m surfaces), so every surface has its own frequencies and any two
surfaces' signals are orthogonal over T (their cross-correlation is zero: the inputs can be told
apart in one test).  Each surface's components have equal amplitudes (a flat spectrum); their phases
start at Schroeder's, ``phi_j = -pi j (j - 1) / M`` for the j-th of M components, and are then chosen
to minimise the relative peak factor

    RPF = max |u| / (sqrt(2) rms(u))        (1 for a single sine)

by clipping and projection (the signal clipped below its peak, its spectrum's phases kept) followed by
a quasi-Newton descent of a p-norm of the signal (p up to 128), from Schroeder's phases and ``restarts``
random ones (``numpy.random.default_rng(seed)``); the best is kept.  The signal is then shifted in time
to start (and so, being periodic, end) at a zero crossing, the one of least slope, and scaled so that
its peak is the surface's amplitude.  No silent clamping: a design beyond the position or rate limit of
the command held at the loop's rate is a ValueError naming the surface and the amplitude to lower it to,
unless ``scale_to_limits=True`` asks for exactly that scaling.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from rig_env.params import SURFACES
from rig_env.signals import UNIT_3211, Doublet, InputSchedule, Multisine, ScheduleError, ThreeTwoOneOne


def _surface(name: str) -> str:
    if name not in SURFACES:
        raise ValueError(f"surface {name!r}: unknown; valid names: {list(SURFACES)}")
    return name


def _amplitude(amplitude_deg: float, limit_deg: float) -> float:
    if not (isinstance(amplitude_deg, (int, float)) and math.isfinite(amplitude_deg) and 0.0 < abs(amplitude_deg) <= limit_deg):
        raise ValueError(f"amplitude_deg = {amplitude_deg!r}: must be non-zero and within the position limit +-{limit_deg:g} deg")
    return float(amplitude_deg)


def three_two_one_one(surface: str, amplitude_deg: float, unit_s: float = UNIT_3211, start_s: float = 0.5,
                      limit_deg: float = 40.0) -> InputSchedule:
    """The paper's 3-2-1-1 on one surface: +A for 3 units from start_s, -A for 2, +A for 1, -A for 1 (deg, s).

    Its jumps (A, then 2A) reach the surface at the servo's rate limit (350 deg/s: 2A / 350 s);
    :meth:`InputSchedule.check` says whether a jump exceeds it within one control step.
    """
    return InputSchedule({_surface(surface): ThreeTwoOneOne(_amplitude(amplitude_deg, limit_deg), unit_s, start_s)})


def doublet(surface: str, amplitude_deg: float, period_s: float = 1.0, start_s: float = 0.5, limit_deg: float = 40.0) -> InputSchedule:
    """A doublet on one surface: +A for half of ``period_s`` from start_s, -A for the other half (deg, s).

    The paper's compensator doublet has a 1 s period."""
    return InputSchedule({_surface(surface): Doublet(_amplitude(amplitude_deg, limit_deg), period_s, start_s)})


# ---------------------------------------------------------------------- multisines
def schroeder_phases(n: int) -> np.ndarray:
    """(n,) Schroeder's phases of n equal-amplitude components, rad: ``-pi j (j - 1) / n``, j = 1..n."""
    j = np.arange(1, n + 1)
    return -math.pi * j * (j - 1) / n


def relative_peak_factor(u: np.ndarray) -> float:
    """max |u| / (sqrt(2) rms(u)) of samples u covering whole periods (1 for a sine)."""
    u = np.asarray(u, dtype=np.float64)
    return float(np.abs(u).max() / (math.sqrt(2.0) * math.sqrt(np.mean(u**2))))


def harmonics(duration_s: float, f_min_hz: float, f_max_hz: float, n_surfaces: int) -> list[np.ndarray]:
    """Harmonic numbers k (frequency k / duration_s) in [f_min, f_max], dealt in turn to n_surfaces: a list
    of n_surfaces disjoint int arrays.  ValueError when a surface would get none."""
    k_lo, k_hi = math.ceil(f_min_hz * duration_s - 1e-9), math.floor(f_max_hz * duration_s + 1e-9)
    k = np.arange(max(k_lo, 1), k_hi + 1)
    if k.size < n_surfaces:
        raise ValueError(f"multisine: {k.size} harmonic(s) of 1/{duration_s:g} s in [{f_min_hz:g}, {f_max_hz:g}] Hz for {n_surfaces} "
                         f"surface(s); lengthen duration_s or widen the band (each surface needs at least one)")
    return [k[j::n_surfaces] for j in range(n_surfaces)]


def _synth(k: np.ndarray, a: np.ndarray, phi: np.ndarray, n: int) -> np.ndarray:
    """(n,) samples over one period of sum a sin(2 pi k t / T + phi), t = T i / n (n > 2 max k)."""
    X = np.zeros(n // 2 + 1, dtype=np.complex128)
    X[k] = 0.5 * n * a * np.exp(1j * (phi - 0.5 * math.pi))
    return np.fft.irfft(X, n)


def _clip_project(k: np.ndarray, a: np.ndarray, phi: np.ndarray, n: int, iterations: int = 100) -> np.ndarray:
    """Phases after clipping-and-projection: clip the signal at 0.9 of its peak, keep the phases of its spectrum."""
    best, best_peak = phi, np.inf
    for _ in range(iterations):
        u = _synth(k, a, phi, n)
        peak = np.abs(u).max()
        if peak < best_peak:
            best, best_peak = phi, peak
        phi = np.angle(np.fft.rfft(np.clip(u, -0.9 * peak, 0.9 * peak))[k]) + 0.5 * math.pi
    return best


def _pnorm_descent(k: np.ndarray, a: np.ndarray, phi: np.ndarray, n: int) -> np.ndarray:
    """Phases minimising (1/p) log sum |u|^p (a smooth stand-in for the peak) by BFGS, p = 8, 32, 128 in turn."""
    from scipy.optimize import minimize

    for p in (8.0, 32.0, 128.0):

        def f(ph: np.ndarray, p: float = p) -> tuple[float, np.ndarray]:
            u = _synth(k, a, ph, n)
            s = np.abs(u).max()
            v = u / s
            w = np.abs(v) ** p
            total = w.sum()
            # d/dphi_j sum |u|^p / p = sum |u|^(p-1) sign(u) a_j cos(theta_j + phi_j) = a_j Re(e^(i phi_j) conj(G_j)), G = rfft(|v|^(p-1) sign v)
            g = np.fft.rfft(np.abs(v) ** (p - 1.0) * np.sign(v))[k]
            grad = a * np.real(np.exp(1j * ph) * np.conj(g)) / (s * total)
            return math.log(s) + math.log(total) / p, grad

        phi = minimize(f, phi, jac=True, method="BFGS", options={"maxiter": 200, "gtol": 1e-8}).x
    return phi


def _start_at_zero(k: np.ndarray, a: np.ndarray, phi: np.ndarray, T: float, n: int) -> np.ndarray:
    """Phases of the same periodic signal shifted in time to start at its zero crossing of least slope."""
    u = _synth(k, a, phi, n)
    t = T * np.arange(n) / n
    cross = np.flatnonzero(np.signbit(u) != np.signbit(np.roll(u, -1)))
    w = 2.0 * math.pi * k / T
    best_tau, best_slope = 0.0, np.inf
    for i in cross:
        u0, u1 = u[i], u[(i + 1) % n]
        tau = t[i] + (T / n) * u0 / (u0 - u1)  # linear interpolation, then Newton on the sum of sines
        for _ in range(4):
            val, slope = np.sum(a * np.sin(w * tau + phi)), np.sum(a * w * np.cos(w * tau + phi))
            tau -= val / slope
        if abs(slope) < best_slope:
            best_tau, best_slope = tau, abs(slope)
    return np.mod(phi + w * best_tau + math.pi, 2.0 * math.pi) - math.pi


def minimum_peak_phases(k: np.ndarray, duration_s: float, seed: int = 0, restarts: int = 4) -> np.ndarray:
    """Phases (rad) of equal-amplitude components at harmonics k of 1 / duration_s with the least relative
    peak factor found (Schroeder's start and ``restarts`` random ones), shifted to start at a zero crossing."""
    k = np.asarray(k, dtype=np.int64)
    a = np.ones(k.size)
    n = max(4096, 1 << int(math.ceil(math.log2(64 * k.max()))))
    if k.size == 1:
        return np.zeros(1)
    rng = np.random.default_rng(seed)
    starts = [schroeder_phases(k.size)] + [rng.uniform(-math.pi, math.pi, k.size) for _ in range(restarts)]
    best, best_rpf = starts[0], relative_peak_factor(_synth(k, a, starts[0], n))
    for phi in starts:
        phi = _pnorm_descent(k, a, _clip_project(k, a, phi, n), n)
        rpf = relative_peak_factor(_synth(k, a, phi, n))
        if rpf < best_rpf:
            best, best_rpf = phi, rpf
    return _start_at_zero(k, a, best, duration_s, n)


def multisine(
    surfaces: str | Sequence[str],
    duration_s: float,
    f_min_hz: float,
    f_max_hz: float,
    amplitude_deg: float | Sequence[float] | Mapping[str, float],
    rate_limit_deg_s: float = 350.0,
    limit_deg: float = 40.0,
    dt: float = 1.0 / 80.0,
    seed: int = 0,
    *,
    start_s: float = 0.5,
    restarts: int = 4,
    scale_to_limits: bool = False,
) -> InputSchedule:
    """Orthogonal multisines, one per surface, over [start_s, start_s + duration_s) (see the module docstring).

    surfaces: rig_env.SURFACES names, distinct.  duration_s: the period T, s (frequency resolution 1 / T).
    f_min_hz, f_max_hz: the band, Hz, 0 < f_min <= f_max < 1 / (2 dt).  amplitude_deg: each surface's
    peak deflection, deg (one number, one per surface in order, or by name).  rate_limit_deg_s,
    limit_deg, dt: the servos' rate and position limits and the control step the command is held over
    (:meth:`InputSchedule.check`).  A design beyond them raises ValueError naming the surface and the
    largest amplitude that fits; ``scale_to_limits=True`` instead scales that surface's amplitude down
    to it (the returned shapes carry the amplitudes used).  Each surface's relative peak factor is its
    shape's ``relative_peak_factor`` (:func:`peak_factors`).
    """
    names = (surfaces,) if isinstance(surfaces, str) else tuple(surfaces)
    if not names or len(set(names)) != len(names):
        raise ValueError(f"surfaces = {list(names)}: give one or more distinct names of {list(SURFACES)}")
    for s in names:
        _surface(s)
    for label, v in (("duration_s", duration_s), ("f_min_hz", f_min_hz), ("f_max_hz", f_max_hz), ("rate_limit_deg_s", rate_limit_deg_s),
                     ("limit_deg", limit_deg), ("dt", dt)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0.0):
            raise ValueError(f"{label} = {v!r}: must be a positive finite number")
    if not f_min_hz <= f_max_hz < 0.5 / dt:
        raise ValueError(f"band [{f_min_hz:g}, {f_max_hz:g}] Hz: need f_min_hz <= f_max_hz < {0.5 / dt:g} Hz (half the {1 / dt:g} Hz control rate)")
    if isinstance(amplitude_deg, Mapping):
        missing = [s for s in names if s not in amplitude_deg]
        if missing or set(amplitude_deg) - set(names):
            raise ValueError(f"amplitude_deg: give exactly the surfaces {list(names)}, got {sorted(amplitude_deg)}")
        amps = [amplitude_deg[s] for s in names]
    elif isinstance(amplitude_deg, (int, float)):
        amps = [amplitude_deg] * len(names)
    else:
        amps = list(amplitude_deg)
        if len(amps) != len(names):
            raise ValueError(f"amplitude_deg: {len(amps)} values for {len(names)} surfaces")
    for a in amps:
        if not (isinstance(a, (int, float)) and math.isfinite(a) and a > 0.0):
            raise ValueError(f"amplitude_deg = {a!r}: a peak deflection must be a positive finite number of degrees")
    if not (isinstance(start_s, (int, float)) and math.isfinite(start_s) and start_s >= 0.0):
        raise ValueError(f"start_s = {start_s!r}: must be a non-negative finite number of seconds")
    shapes: dict[str, Multisine] = {}
    t = np.arange(int(math.ceil((start_s + duration_s) / dt)) + 2) * dt  # the held command's samples, as check() takes them
    for s, k, amp in zip(names, harmonics(duration_s, f_min_hz, f_max_hz, len(names)), amps):
        phi = minimum_peak_phases(k, duration_s, seed, restarts)
        unit = Multisine(tuple(k / duration_s), (1.0,) * k.size, tuple(phi), duration_s, start_s)
        n = int(min(1 << 20, max(4096, 64.0 * k.max())))
        peak = float(np.abs(unit(start_s + duration_s * np.arange(n) / n)).max())
        rate = float(np.abs(np.diff(unit(t), prepend=0.0)).max()) / dt  # of unit component amplitudes, deg/s
        fit = min(limit_deg, rate_limit_deg_s * peak / rate)  # the largest peak deflection within both limits
        if amp > fit * (1.0 + 1e-12):
            if not scale_to_limits:
                which = "rate limit" if rate_limit_deg_s * peak / rate < limit_deg else "position limit"
                raise ValueError(f"multisine: {s}: a {amp:g} deg peak exceeds the {which} (+-{limit_deg:g} deg, {rate_limit_deg_s:g} deg/s "
                                 f"held every {dt:g} s); lower amplitude_deg for {s} to at most {fit:.4g} deg, or f_max_hz "
                                 f"(or pass scale_to_limits=True)")
            amp = fit
        shapes[s] = Multisine(tuple(k / duration_s), (amp / peak,) * k.size, tuple(phi), duration_s, start_s)
    sched = InputSchedule(shapes)
    try:
        sched.check(limit_deg * (1.0 + 1e-9), rate_limit_deg_s * (1.0 + 1e-9), dt)  # the design's own promise, on the loop's grid
    except ScheduleError as e:  # pragma: no cover - a bug here, not a user error
        raise AssertionError(f"multisine design broke its own limits: {e}") from None
    return sched


def peak_factors(schedule: InputSchedule) -> dict[str, float]:
    """Relative peak factor of every surface whose input is one multisine: {surface: RPF}."""
    return {s: seq[0].relative_peak_factor for s, seq in schedule.shapes.items() if len(seq) == 1 and isinstance(seq[0], Multisine)}


__all__ = ["doublet", "harmonics", "minimum_peak_phases", "multisine", "peak_factors", "relative_peak_factor", "schroeder_phases",
           "three_two_one_one"]
