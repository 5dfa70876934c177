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
a limited-memory quasi-Newton (L-BFGS) descent of a p-norm of the signal (p = 8, 32, 128), from Schroeder's
phases and ``restarts`` random ones (``numpy.random.default_rng(seed)``); the best is kept.  The search runs
on a grid of 16 samples per period of the highest harmonic (the peak factors are compared on 64) and is
capped so that its cost does not grow without bound with the design: at most 200 descent iterations per p,
fewer on a grid beyond 2**13 samples (``_WORK``), the iterations times the grid's size at most 2**21 per p
(25 at least).  Measured on one core: one surface, 20 s, 0.1-5 Hz (99 harmonics) about 1 s; 60 s, 0.1-10 Hz
(595 harmonics) about 2 s; every surface costs about as much as its highest harmonic asks, times
1 + ``restarts``.  A design beyond :data:`MAX_HARMONIC` (``duration_s * f_max_hz``) or whose held command
takes more than :data:`MAX_EVALUATIONS` sine terms to evaluate is refused.  The signal is then shifted in time
to start (and so, being periodic, end) at a zero crossing, the one of least slope, and scaled so that
its peak is the surface's amplitude.  No silent clamping: a design beyond the position or rate limit of
the command held at the loop's rate is a ValueError naming the surface and the amplitude to lower it to,
unless ``scale_to_limits=True`` asks for exactly that scaling.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import TypeGuard

import numpy as np

from rig_env.params import SURFACES
from rig_env.signals import MAX_CHECK_SAMPLES, UNIT_3211, Doublet, InputSchedule, Multisine, ScheduleError, ThreeTwoOneOne

MAX_HARMONIC = 4096
"""Highest harmonic number of 1 / duration_s a multisine may use (``duration_s * f_max_hz``: e.g. 200 s to 20 Hz, 400 s
to 10 Hz): the phase search's grid, and so its cost, grow with it; beyond it :func:`multisine` refuses the design."""
MAX_EVALUATIONS = 1 << 27
"""Most sine terms a design may evaluate for its command held at the control steps (control steps over
start_s + duration_s times the harmonics used; each is evaluated twice, for the limits and for
:meth:`InputSchedule.check`): about 1.3e8, a few seconds.  Beyond it :func:`multisine` refuses the design."""
MAX_RESTARTS = 100
"""Most random restarts of the phase search (each costs as much as the first)."""
_OPT_POINTS = 16  # samples per period of the highest harmonic on the phase search's grid
_FINE_POINTS = 64  # ... on the grid the starts' peak factors are compared on
_MAXITER = 200  # descent iterations per p, at most ...
_WORK = 1 << 21  # ... and at most this many over the grid's size (25 at least): bounded cost on a large grid


def _is_real(v: object) -> TypeGuard[float]:
    """A real number, Python's or numpy's (not a bool)."""
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def _count(label: str, v: object, lo: int, hi: int | None = None) -> int:
    """An integer argument (Python or numpy int) in [lo, hi]; ValueError naming it otherwise."""
    if not isinstance(v, (int, np.integer)) or isinstance(v, (bool, np.bool_)) or v < lo or (hi is not None and v > hi):
        within = f"in [{lo}, {hi}]" if hi is not None else f">= {lo}"
        raise ValueError(f"{label} = {v!r}: must be an integer {within}")
    return int(v)


def _surface(name: str) -> str:
    if name not in SURFACES:
        raise ValueError(f"surface {name!r}: unknown; valid names: {list(SURFACES)}")
    return name


def _amplitude(amplitude_deg: float, limit_deg: float) -> float:
    if not (_is_real(limit_deg) and math.isfinite(limit_deg) and limit_deg > 0.0):
        raise ValueError(f"limit_deg = {limit_deg!r}: the position limit must be a positive finite number of degrees")
    if not (_is_real(amplitude_deg) and math.isfinite(amplitude_deg)):
        raise ValueError(f"amplitude_deg = {amplitude_deg!r}: must be a finite number of degrees")
    if not 0.0 < abs(amplitude_deg) <= limit_deg:
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


def _lbfgs(fg: Callable[[np.ndarray], tuple[float, np.ndarray]], x: np.ndarray, maxiter: int, memory: int = 10) -> np.ndarray:
    """Minimise f by limited-memory BFGS (two-loop recursion, backtracking Armijo steps) for at most ``maxiter``
    iterations: vector operations only (scipy's BFGS costs n^3 per iteration, its L-BFGS-B spends its time in
    threaded BLAS calls on these small vectors)."""
    f, g = fg(x)
    S: list[np.ndarray] = []
    Y: list[np.ndarray] = []
    for _ in range(maxiter):
        gmax = np.abs(g).max()
        if not gmax > 1e-10:
            break
        q = g.copy()
        alphas = []
        for s_, y_ in zip(reversed(S), reversed(Y)):
            al = (s_ @ q) / (y_ @ s_)
            q -= al * y_
            alphas.append(al)
        q *= (S[-1] @ Y[-1]) / (Y[-1] @ Y[-1]) if S else 0.1 / gmax  # first step: 0.1 rad at most
        for s_, y_, al in zip(S, Y, reversed(alphas)):
            q += s_ * (al - (y_ @ q) / (y_ @ s_))
        d = -q
        slope = g @ d
        if not slope < 0.0:  # not a descent direction: start the memory afresh
            S.clear()
            Y.clear()
            d = -g * (0.1 / gmax)
            slope = g @ d
        step = 1.0
        for _ in range(30):
            x_new = x + step * d
            f_new, g_new = fg(x_new)
            if f_new <= f + 1e-4 * step * slope:
                break
            step *= 0.5
        else:
            break  # no decrease along a descent direction: at a minimum to rounding
        s_, y_ = x_new - x, g_new - g
        if s_ @ y_ > 1e-12 * math.sqrt((s_ @ s_) * (y_ @ y_)):
            S.append(s_)
            Y.append(y_)
            if len(S) > memory:
                S.pop(0)
                Y.pop(0)
        done = f - f_new <= 1e-13 * max(1.0, abs(f))
        x, f, g = x_new, f_new, g_new
        if done:
            break
    return x


def _pnorm_descent(k: np.ndarray, a: np.ndarray, phi: np.ndarray, n: int) -> np.ndarray:
    """Phases minimising log ||u||_p (a smooth stand-in for the peak), p = 8, 32, 128 in turn, by :func:`_lbfgs`,
    at most ``_MAXITER`` iterations per p and ``_WORK / n`` (25 at least) on an n-sample grid."""
    maxiter = min(_MAXITER, max(25, _WORK // n))
    for p in (8.0, 32.0, 128.0):
        squarings = int(round(math.log2(p))) - 1

        def f(ph: np.ndarray, p: float = p, squarings: int = squarings) -> tuple[float, np.ndarray]:
            u = _synth(k, a, ph, n)
            s = np.abs(u).max()
            v = u / s
            w = v * v
            for _ in range(squarings):  # |v|^p by squaring: p a power of 2, exact and far cheaper than a float power
                w = w * w
            total = w.sum()
            # d/dphi_j sum |u|^p / p = sum |u|^(p-1) sign(u) a_j cos(theta_j + phi_j) = a_j Re(e^(i phi_j) conj(G_j)), G = rfft(|v|^(p-1) sign v)
            g = np.fft.rfft(np.divide(w, v, out=np.zeros_like(w), where=v != 0.0))[k]
            grad = a * np.real(np.exp(1j * ph) * np.conj(g)) / (s * total)
            return math.log(s) + math.log(total) / p, grad

        phi = _lbfgs(f, phi, maxiter)
    return phi


def _start_at_zero(k: np.ndarray, a: np.ndarray, phi: np.ndarray, T: float, n: int) -> np.ndarray:
    """Phases of the same periodic signal shifted in time to start at its zero crossing of least slope."""
    u = _synth(k, a, phi, n)
    t = T * np.arange(n) / n
    cross = np.flatnonzero(np.signbit(u) != np.signbit(np.roll(u, -1)))
    cross = cross[np.argsort(np.abs(u[(cross + 1) % n] - u[cross]), kind="stable")[:16]]  # refine the 16 least steep on the grid
    w = 2.0 * math.pi * k / T
    best_tau, best_slope = 0.0, np.inf
    for i in np.sort(cross):
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
    peak factor found (Schroeder's start and ``restarts`` random ones, 0 to :data:`MAX_RESTARTS`; ``seed`` >= 0),
    shifted to start at a zero crossing.  The search's cost is bounded (module docstring)."""
    seed = _count("seed", seed, 0)
    restarts = _count("restarts", restarts, 0, MAX_RESTARTS)
    k = np.asarray(k, dtype=np.int64)
    a = np.ones(k.size)
    n = max(4096, 1 << int(math.ceil(math.log2(_FINE_POINTS * k.max()))))  # comparing the starts
    n_opt = max(256, 1 << int(math.ceil(math.log2(_OPT_POINTS * k.max()))))  # searching
    if k.size == 1:
        return np.zeros(1)
    rng = np.random.default_rng(seed)
    starts = [schroeder_phases(k.size)] + [rng.uniform(-math.pi, math.pi, k.size) for _ in range(restarts)]
    best, best_rpf = starts[0], relative_peak_factor(_synth(k, a, starts[0], n))
    for phi in starts:
        phi = _pnorm_descent(k, a, _clip_project(k, a, phi, n_opt), n_opt)
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
    shape's ``relative_peak_factor`` (:func:`peak_factors`).  seed >= 0 and restarts (0 to :data:`MAX_RESTARTS`)
    set the phase search; numbers may be Python's or numpy's.  Refused: ``duration_s * f_max_hz`` beyond
    :data:`MAX_HARMONIC`, and a command of more than ``rig_env.signals.MAX_CHECK_SAMPLES`` control steps.
    """
    names = (surfaces,) if isinstance(surfaces, str) else tuple(surfaces)
    if not names or len(set(names)) != len(names):
        raise ValueError(f"surfaces = {list(names)}: give one or more distinct names of {list(SURFACES)}")
    for s in names:
        _surface(s)
    for label, v in (("duration_s", duration_s), ("f_min_hz", f_min_hz), ("f_max_hz", f_max_hz), ("rate_limit_deg_s", rate_limit_deg_s),
                     ("limit_deg", limit_deg), ("dt", dt)):
        if not (_is_real(v) and math.isfinite(v) and v > 0.0):
            raise ValueError(f"{label} = {v!r}: must be a positive finite number")
    duration_s, f_min_hz, f_max_hz, rate_limit_deg_s, limit_deg, dt = (
        float(v) for v in (duration_s, f_min_hz, f_max_hz, rate_limit_deg_s, limit_deg, dt))
    seed = _count("seed", seed, 0)
    restarts = _count("restarts", restarts, 0, MAX_RESTARTS)
    if not f_min_hz <= f_max_hz < 0.5 / dt:
        raise ValueError(f"band [{f_min_hz:g}, {f_max_hz:g}] Hz: need f_min_hz <= f_max_hz < {0.5 / dt:g} Hz (half the {1 / dt:g} Hz control rate)")
    if isinstance(amplitude_deg, Mapping):
        missing = [s for s in names if s not in amplitude_deg]
        if missing or set(amplitude_deg) - set(names):
            raise ValueError(f"amplitude_deg: give exactly the surfaces {list(names)}, got {sorted(amplitude_deg)}")
        amps = [amplitude_deg[s] for s in names]
    elif _is_real(amplitude_deg):
        amps = [amplitude_deg] * len(names)
    elif isinstance(amplitude_deg, (Sequence, np.ndarray)) and not isinstance(amplitude_deg, str) and np.ndim(amplitude_deg) == 1:
        amps = list(amplitude_deg)
        if len(amps) != len(names):
            raise ValueError(f"amplitude_deg: {len(amps)} values for {len(names)} surfaces")
    else:
        raise ValueError(f"amplitude_deg = {amplitude_deg!r}: give one number, one per surface in order, or a mapping by surface name")
    for a in amps:
        if not (_is_real(a) and math.isfinite(a) and a > 0.0):
            raise ValueError(f"amplitude_deg = {a!r}: a peak deflection must be a positive finite number of degrees")
    amps = [float(a) for a in amps]
    if not (_is_real(start_s) and math.isfinite(start_s) and start_s >= 0.0):
        raise ValueError(f"start_s = {start_s!r}: must be a non-negative finite number of seconds")
    start_s = float(start_s)
    if duration_s * f_max_hz > MAX_HARMONIC + 1e-9:
        raise ValueError(f"multisine: duration_s * f_max_hz = {duration_s:g} s x {f_max_hz:g} Hz = {duration_s * f_max_hz:g}, beyond harmonic "
                         f"{MAX_HARMONIC} of 1/duration_s (rig_env.sysid.inputs.MAX_HARMONIC: the phase design's cost grows with it); "
                         f"shorten duration_s or lower f_max_hz")
    steps = (start_s + duration_s) / dt + 2.0
    if steps > MAX_CHECK_SAMPLES:
        raise ValueError(f"multisine: start_s + duration_s = {start_s + duration_s:g} s held every dt = {dt:g} s is {steps:.4g} control steps, "
                         f"more than {MAX_CHECK_SAMPLES} (rig_env.signals.MAX_CHECK_SAMPLES); a larger dt or a shorter duration_s")
    used = sum(k.size for k in harmonics(duration_s, f_min_hz, f_max_hz, len(names)))
    if steps * used > MAX_EVALUATIONS:
        raise ValueError(f"multisine: the command held every dt = {dt:g} s over start_s + duration_s = {start_s + duration_s:g} s "
                         f"({steps:.0f} steps) with {used} harmonics is {steps * used:.3g} sine terms, more than {MAX_EVALUATIONS} "
                         f"(rig_env.sysid.inputs.MAX_EVALUATIONS); shorten duration_s, narrow the band or raise dt")
    shapes: dict[str, Multisine] = {}
    t = np.arange(int(math.ceil((start_s + duration_s) / dt)) + 2) * dt  # the held command's samples, as check() takes them
    for s, k, amp in zip(names, harmonics(duration_s, f_min_hz, f_max_hz, len(names)), amps):
        phi = minimum_peak_phases(k, duration_s, seed, restarts)
        unit = Multisine(tuple(k / duration_s), (1.0,) * k.size, tuple(phi), duration_s, start_s)
        n = int(min(1 << 20, max(4096, 64.0 * k.max())))
        held = unit(t)
        # the peak on a grid of 64 samples per period of the highest harmonic (by FFT: t = start_s + duration_s i / n),
        # and at the held samples themselves, so that check() on the loop's grid keeps the position limit exactly
        peak = max(float(np.abs(_synth(k, np.ones(k.size), phi, n)).max()), float(np.abs(held).max()))
        rate = float(np.abs(np.diff(held, prepend=0.0)).max()) / dt  # of unit component amplitudes, deg/s
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


__all__ = ["MAX_EVALUATIONS", "MAX_HARMONIC", "MAX_RESTARTS", "doublet", "harmonics", "minimum_peak_phases", "multisine", "peak_factors", "relative_peak_factor", "schroeder_phases",
           "three_two_one_one"]
