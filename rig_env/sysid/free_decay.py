"""Coulomb and viscous friction and the inertia of a joint from its free decays (the later rig's rig-roll drops).

A joint released from an angle, alone free and wind off, swings about its equilibrium under gravity
(rig roll's mass imbalance, a pendulum) or a fixture's spring, and friction stops it.  For the linear
oscillator J x'' + c x' + k x + Fc sign(x') = 0 (x from the equilibrium) each half-cycle between two
reversals is half a period of the damped linear oscillator about the shifted equilibrium +-Fc / k, so
the successive peak amplitudes A_i (on alternating sides) obey exactly

    A_{i+1} = r A_i - (1 + r) Fc / k,      r = exp(-pi zeta / sqrt(1 - zeta^2)),  zeta = c / (2 sqrt(k J)),

the Coulomb part a linear decrement (4 Fc / k per cycle) and the viscous part an exponential one, and
the reversals are half a damped period pi / w_d apart, w_d = w_n sqrt(1 - zeta^2), w_n = sqrt(k / J)
(Coulomb friction does not change the period).  So a linear regression of A_{i+1} on A_i over every
half-cycle of every record gives r and Fc, zeta follows from r, w_n from the half-periods, and with
k known (the model's gravity and spring stiffness at the equilibrium) J = k / w_n^2, c = 2 zeta k / w_n.

The static torque of a pendulum softens with amplitude, Q = -k (x - kappa x^3 / 6 + ...) (kappa = 1 for
gravity alone, k_g / (k_g + k_spring) with a spring): per half-cycle the period grows by 1 + kappa
(A_i^2 + A_{i+1}^2) / 32 and the Coulomb decrement by 1 / (1 - kappa (A_i^2 + A_{i+1}^2) / 12) (energy
balance), both applied; kappa comes from the model.  The last half-cycles before the joint sticks
(ending within :data:`DEAD_BANDS` dead bands Fc / k of the equilibrium) are left out.  Neglected: the quadratic term of an asymmetric
static torque (a hanging weight on a pendulum), the Stribeck excess Fs - Fc and the bristles'
pre-sliding travel at each reversal.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
from scipy.optimize import brentq
from scipy.signal import savgol_filter

from rig_env.params import RigParams
from rig_env.sysid.checks import is_number
from rig_env.sysid.friction_loop import check_joint, check_records, check_rig, joint_terms, record_params
from rig_env.sysid.records import FlightRecord

DEAD_BANDS = 3.0
"""Half-cycles ending closer to the equilibrium than this many Coulomb dead bands Fc / k are not used."""


def _peaks(record: FlightRecord, window_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Times (s) and angles (rad) of the reversals of a record's angle: sign changes of its
    Savitzky-Golay rate, each refined by the vertex of a parabola through the smoothed angle."""
    dt = record.dt
    n_w = max(5, int(round(window_s / dt)))
    n_w += 1 - n_w % 2
    n_w = min(n_w, record.n_t - 1 + record.n_t % 2)  # the largest odd window the record holds (window_s <= its duration)
    q = savgol_filter(record.q[:, 0], n_w, 3)
    v = savgol_filter(record.q[:, 0], n_w, 3, deriv=1, delta=dt)
    t_out, q_out = [], []
    for k in np.flatnonzero((np.sign(v[:-1]) * np.sign(v[1:])) < 0):
        i = k if abs(v[k]) < abs(v[k + 1]) else k + 1
        if i < n_w // 2 or i + 1 + n_w // 2 >= q.size:  # the smoothing's edges
            continue
        y0, y1, y2 = q[i - 1], q[i], q[i + 1]
        curv = y0 - 2.0 * y1 + y2
        s = 0.5 * (y0 - y2) / curv if curv != 0.0 else 0.0
        s = min(max(s, -1.0), 1.0)
        t_out.append(record.t[i] + s * dt)
        q_out.append(y1 - 0.25 * (y0 - y2) * s)
    return np.array(t_out), np.array(q_out)


def free_decay_estimates(
    records: FlightRecord | Sequence[FlightRecord],
    params: RigParams,
    joint: str,
    window_s: float = 0.1,
    min_amplitude: float | None = None,
) -> dict[str, float]:
    """Coulomb friction, viscous friction and inertia of ``joint`` from free decays (the module docstring's method).

    records: one-joint wind-off records released from rest (their set-ups, e.g. a spring, applied to
    ``params`` for the static torque; all must share one set-up; at least 9 samples each), fitted jointly;
    window_s: the Savitzky-Golay window that finds the reversals, s, in (0, the shortest record's duration]
    (at least 5 samples are taken) and shorter than a half-cycle of the decays; min_amplitude: rad, >= 0,
    half-cycles with a smaller amplitude are left out (default 10 times the angle noise, which is estimated
    from the records).

    Returns {"Fc": N m, "sigma2": viscous N m s/rad, "inertia": J about the joint axis with the
    fixture's, kg m^2, "inertia_rig": the rig's alone (J minus the fixture's inertia), "stiffness": k,
    N m/rad, "equilibrium": rad, "damping_ratio": zeta, "period": the undamped small-amplitude period
    2 pi / w_n, s, "half_cycles": the number used}.
    """
    check_joint(joint)
    check_rig(params)
    recs = check_records(records, "free-decay record")
    short = [r for r in recs if r.n_t < 9]
    if short:
        raise ValueError(f"{short[0].name}: {short[0].n_t} samples; a free-decay record needs at least 9 (the noise estimate's window)")
    shortest = min(r.duration for r in recs)
    if not (is_number(window_s) and math.isfinite(window_s) and 0.0 < window_s <= shortest):
        raise ValueError(f"window_s = {window_s!r}: the reversals' smoothing window must be a number in (0, {shortest:.6g}] s (the "
                         "shortest record's duration)")
    if min_amplitude is not None and not (is_number(min_amplitude) and math.isfinite(min_amplitude) and min_amplitude >= 0.0):
        raise ValueError(f"min_amplitude = {min_amplitude!r}: must be a finite number >= 0 (rad) or None (10 times the angle noise)")
    setups = {tuple(sorted(r.setup.items())) for r in recs}
    if len(setups) != 1:
        raise ValueError("records: free decays fitted together must share one set-up (the static torque's)")
    for r in recs:
        if r.free_dofs != (joint,):
            raise ValueError(f"{r.name}: free_dofs = {list(r.free_dofs)}; a free decay has {joint!r} alone free")
    p = record_params(recs[0], params)
    locked = recs[0].locked_angles()

    def static(q: float | np.ndarray) -> np.ndarray:
        q = np.atleast_1d(np.asarray(q, dtype=np.float64))
        return joint_terms(p, joint, q, np.zeros_like(q), locked)[1]

    peaks = [_peaks(r, window_s) for r in recs]
    all_q = np.concatenate([qp for _, qp in peaks])
    if all_q.size < 3:
        raise ValueError(f"{joint}: {all_q.size} reversals found; a free decay needs at least 3")
    lo, hi = float(all_q.min()), float(all_q.max())
    q_eq = brentq(lambda x: float(static(x)[0]), lo, hi) if static(lo)[0] * static(hi)[0] < 0 else float(np.median(all_q))
    # the static torque about the equilibrium, Q = -k (x - kappa x^3 / 6) + even terms, by least squares
    # over the swing (a polynomial fit: the model's curve, not a finite difference of its spline)
    span = max(abs(hi - q_eq), abs(lo - q_eq), 1e-3)
    x = np.linspace(-span, span, 41)
    c = np.polynomial.polynomial.polyfit(x, static(q_eq + x), 5)
    k = -c[1]
    if not k > 0:
        raise ValueError(f"{joint}: the static torque's stiffness at the equilibrium is {k:.3g} N m/rad; a free decay needs a restoring one")
    kappa = 6.0 * c[3] / k
    noise = float(np.median([np.std(r.q[:, 0] - savgol_filter(r.q[:, 0], 9, 3)) for r in recs]))
    a_min = 10.0 * noise if min_amplitude is None else float(min_amplitude)
    A0, A1, kk, half = [], [], [], []
    for t_p, q_p in peaks:
        amp = np.abs(q_p - q_eq)
        for i in range(len(amp) - 1):
            if amp[i + 1] < a_min or np.sign(q_p[i] - q_eq) == np.sign(q_p[i + 1] - q_eq):
                continue
            s2 = amp[i] ** 2 + amp[i + 1] ** 2
            A0.append(amp[i])
            A1.append(amp[i + 1])
            kk.append(k * (1.0 - kappa * s2 / 12.0))
            half.append((t_p[i + 1] - t_p[i]) / (1.0 + kappa * s2 / 32.0))
    A0, A1, kk, half = map(np.array, (A0, A1, kk, half))
    if len(half) and window_s >= float(np.mean(half)):
        raise ValueError(f"window_s = {window_s!r}: not shorter than the decays' half-cycle ({float(np.mean(half)):.3g} s), over which the "
                         "smoothing moves the reversals; use a window well within a half-cycle (the default 0.1 s)")

    def regress(use: np.ndarray) -> tuple[float, float]:
        if use.sum() < 2:
            raise ValueError(f"{joint}: {int(use.sum())} usable half-cycles; the regression needs at least 2")
        (r_, beta_), *_ = np.linalg.lstsq(np.column_stack([A0[use], -1.0 / kk[use]]), A1[use], rcond=None)
        return float(r_), float(beta_)

    r, beta = regress(np.ones(A0.size, dtype=bool))
    # leave out the half-cycles ending within DEAD_BANDS Coulomb dead bands Fc / k of the equilibrium,
    # where the joint is about to stick (there the Stribeck rise and the bristles' creep, which the
    # linear oscillator has not, shorten and shrink them), and fit again
    use = A1 > DEAD_BANDS * beta / ((1.0 + r) * k)
    r, beta = regress(use)
    if not 0.0 < r < 1.0:
        raise ValueError(f"{joint}: amplitude ratio r = {r:.3g} per half-cycle; expected 0 < r < 1 (a decaying oscillation)")
    ln_r = math.log(r)
    zeta = -ln_r / math.sqrt(math.pi**2 + ln_r**2)
    w_n = math.pi / (float(np.mean(half[use])) * math.sqrt(1.0 - zeta**2))
    inertia = k / w_n**2
    fixture = getattr(p.fixture, joint).inertia
    return {
        "Fc": float(beta / (1.0 + r)),
        "sigma2": float(2.0 * zeta * k / w_n),
        "inertia": float(inertia),
        "inertia_rig": float(inertia - fixture),
        "stiffness": float(k),
        "equilibrium": float(q_eq),
        "damping_ratio": float(zeta),
        "period": float(2.0 * math.pi / w_n),
        "half_cycles": float(use.sum()),
    }

