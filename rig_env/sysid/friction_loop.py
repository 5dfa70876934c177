"""The friction-velocity loop of a one-joint wind-off record and the first estimates of its LuGre parameters.

With one joint j free and the others held, the model's equation of motion is a scalar one,

    J(q) qdd + h(q, qd) = Q_g(q) + Q_fix(q) - tau_f,

J = M_jj (the rig's inertia about the joint plus the fixture's), h the velocity-product term (zero for
a rotation about a fixed axis, computed anyway), Q_g the gravity torque and Q_fix = -k (q - neutral) +
torque the fixture's, all from the project's model (:mod:`rig_env.numpy_model`, equal to the kernels to
rounding) at the recorded angle.  Rate and acceleration come from a smoothing differentiator (a
least-squares polynomial over each swing between reversals, :func:`friction_velocity_loop`), so the
friction torque opposing the motion is

    tau_f = Q_g + Q_fix - h - J qdd         (N m; > 0 when it opposes a positive rate).

First estimates of eqs. (19)-(21) from that loop (:func:`friction_first_estimates`):

* Fc, sigma2 (and Fs, alpha_f where the data resolve the Stribeck dip): least squares of the steady-
  sliding curve tau = sign(v) (Fc + (Fs - Fc) exp(-alpha_f |v|)) + sigma2 v (what eq. 21 tends to at
  constant v) over the sliding samples of every record jointly: |v| above ``v_min``, away from the
  reversals.  The dip is fitted only when over 5 % of those samples are slower than 3 / alpha_f (the
  prior's), where its dip is above 5 % of its depth, and kept only when Fs - Fc exceeds twice its
  standard error; otherwise the data show none: Coulomb + viscous by linear least squares, Fs = Fc and
  alpha_f the prior's (with Fs = Fc it has no effect).
* sigma0 (pre-sliding stiffness, eq. 21 at v ~ 0): the slope of friction against displacement from
  each reversal, where the pre-sliding travel 2 Fs / sigma0 spans several samples and exceeds the
  angle noise several times; otherwise the prior's pre-sliding deflection Fs / sigma0 is kept (sigma0
  = Fs / that deflection).
* sigma1 (bristle damping): a damping-ratio rule, sigma1 = 2 zeta sqrt(sigma0 J), the bristle spring
  sigma0 damped on the joint's inertia J with ratio zeta: the prior's ratio unless one is given.  Not
  the critical zeta = 1: for the model-pitch gimbal that is sigma1 = 0.9 N m s/rad, 18,000 times Table
  2's, and it changes a simulated Fig. 4 decay by up to 2.7 deg (1.3 deg RMS over 16 s), far more
  than the data allow (the prior's ratio, 6e-5 there, and one 100 times larger differ by 0.014 deg):
  the data bound sigma1 from above but do not measure it.
* v_d: the prior's (it only sets where sigma1 fades out, which no wind-off record here resolves).

"The prior" is the ``params`` passed in: the rig's current values.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy.polynomial import chebyshev as C
from scipy.interpolate import CubicSpline
from scipy.optimize import least_squares
from scipy.signal import savgol_filter

from rig_env import numpy_model as nm
from rig_env.params import JOINTS, RigParams
from rig_env.sysid.checks import is_integer, is_number
from rig_env.sysid.records import FlightRecord


@dataclass(frozen=True)
class FrictionLoop:
    """The friction-velocity loop of one record (arrays (n,), the samples of the swings it could fit).

    t s; q rad (smoothed); v rad/s; a rad/s^2; torque: tau_f, N m, opposing positive v; inertia: J, kg
    m^2; sliding: bool mask of the samples the steady-sliding fit uses; noise: the angle noise (rad),
    the standard deviation of the recorded angle about its smoothed value.  Swings too short to fit
    are left out, so t has gaps.
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    torque: np.ndarray
    inertia: np.ndarray
    sliding: np.ndarray
    noise: float
    joint: str
    name: str


def check_joint(joint: object) -> str:
    """``joint`` if it is one of :data:`rig_env.JOINTS`, else ValueError naming the argument and the joints."""
    if not (isinstance(joint, str) and joint in JOINTS):
        raise ValueError(f"joint = {joint!r}; valid joints: {list(JOINTS)}")
    return joint


def check_records(records: object, what: str) -> list[FlightRecord]:
    """``records`` (a :class:`FlightRecord` or a non-empty sequence of them) as a list, else ValueError naming ``records``."""
    if isinstance(records, FlightRecord):
        recs = [records]
    else:
        recs = list(records) if isinstance(records, Sequence) and not isinstance(records, str) else []
    if not recs or not all(isinstance(r, FlightRecord) for r in recs):
        raise ValueError(f"records = {records!r:.80}: give a {what} (a FlightRecord) or a non-empty list of them")
    return recs


def check_rig(params: object) -> RigParams:
    """``params`` if it is a :class:`RigParams`, else ValueError naming ``params``."""
    if not isinstance(params, RigParams):
        raise ValueError(f"params = {params!r:.80}: give a RigParams (e.g. RigParams.default())")
    return params


def check_loop_options(degree: object, edge_s: object, v_min: object) -> tuple[int, float, float]:
    """(degree, edge_s, v_min) of :func:`friction_velocity_loop`, checked: ValueError naming the argument and its range."""
    if not (is_integer(degree) and degree >= 2):  # type: ignore[operator]
        raise ValueError(f"degree = {degree!r}: the swings' polynomial degree must be an integer >= 2 (a degree below 2 has no "
                         "acceleration)")
    for label, v, unit in (("edge_s", edge_s, "s"), ("v_min", v_min, "rad/s")):
        if not (is_number(v) and math.isfinite(v) and v >= 0.0):  # type: ignore[operator, arg-type]
            raise ValueError(f"{label} = {v!r}: must be a finite number >= 0 ({unit})")
    return int(degree), float(edge_s), float(v_min)  # type: ignore[call-overload, arg-type]


def steady_sliding(v: np.ndarray, Fc: float, Fs: float, alpha_f: float, sigma2: float) -> np.ndarray:
    """Steady-sliding friction (N m) at rates v (rad/s): sign(v) (Fc + (Fs - Fc) exp(-alpha_f |v|)) + sigma2 v."""
    v = np.asarray(v, dtype=np.float64)
    return np.sign(v) * (Fc + (Fs - Fc) * np.exp(-alpha_f * np.abs(v))) + sigma2 * v


def record_params(record: FlightRecord, params: RigParams) -> RigParams:
    """The rig's parameters with the record's set-up (fixture, stops) applied."""
    return params.replace(**dict(record.setup)) if record.setup else params


def joint_terms(params: RigParams, joint: str, q: np.ndarray, v: np.ndarray, locked: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(J, Q_static, h), each (n,), of ``joint`` free at angles q (n,) rad and rates v (n,) rad/s, the
    other joints held at ``locked`` (5,) rad: M_jj with the fixture's inertia (kg m^2), gravity plus
    fixture torque (N m) and the velocity-product term (N m) of :mod:`rig_env.numpy_model`.

    With one joint free, M_jj, Q_static and h / v^2 are functions of q alone (h = dM_jj/dq v^2 / 2), so
    the model is evaluated on a grid over the range of q (at most 0.5 deg apart) and interpolated by
    cubic splines (error below 1e-9 of each term's range for the rig's smooth kinematics)."""
    j = JOINTS.index(joint)
    p = params.to_vector()
    q = np.asarray(q, dtype=np.float64)
    lo, hi = float(q.min()), float(q.max())
    n_grid = max(8, int(math.ceil((hi - lo) / math.radians(0.5))) + 1)
    grid = np.linspace(lo - 1e-3, hi + 1e-3, n_grid)
    q5 = np.array(locked, dtype=np.float64)
    qd5 = np.zeros(5)
    qd5[j] = 1.0
    terms = np.empty((3, n_grid))
    for i, x in enumerate(grid):
        q5[j] = x
        kin, bs = nm.bodies(q5, qd5, p)
        M, hv = nm.mass_matrix_and_bias(bs, qd5)
        terms[:, i] = M[j, j], nm.gravity_force(bs, p)[j] + nm.fixture_force(q5, p)[j], hv[j]
    J, Q, h1 = CubicSpline(grid, terms, axis=1)(q)
    return J + nm.fixture_inertia(p)[j], Q, h1 * np.asarray(v, dtype=np.float64) ** 2


def _single_joint(record: FlightRecord, joint: str) -> None:
    if record.free_dofs != (joint,):
        raise ValueError(f"{record.name}: free_dofs = {list(record.free_dofs)}; a friction record has {joint!r} alone free")
    if np.any(record.airspeed_series() != 0.0):
        raise ValueError(f"{record.name}: airspeed must be 0 (a wind-off test)")


def friction_velocity_loop(
    record: FlightRecord,
    params: RigParams,
    joint: str,
    degree: int = 7,
    edge_s: float = 0.1,
    v_min: float = 0.05,
) -> FrictionLoop:
    """The friction-velocity loop of a one-joint wind-off record (see the module docstring).

    The smoothing differentiator: the record is cut at its reversals (sign changes of a Savitzky-Golay
    rate, 0.25 s cubic), and each swing between two reversals is fitted by a least-squares Chebyshev
    polynomial of ``degree`` in time, differentiated once and twice.  Within a swing the motion is
    smooth (friction keeps its sign), so one polynomial over the whole swing averages the angle noise
    over many more samples than a sliding window can, and the friction's jump at a reversal is never
    smoothed across.  Swings of fewer than 4 (degree + 1) samples are left out; samples within
    ``edge_s`` s of a swing's ends (where a polynomial fit is least certain) and slower than ``v_min``
    rad/s are not counted as sliding.  degree: an integer >= 2; edge_s (s) and v_min (rad/s): >= 0.
    """
    check_joint(joint)
    check_rig(params)
    degree, edge_s, v_min = check_loop_options(degree, edge_s, v_min)
    if not isinstance(record, FlightRecord):
        raise ValueError(f"record = {record!r:.80}: give a FlightRecord")
    _single_joint(record, joint)
    dt = record.dt
    if np.ptp(np.diff(record.t)) > 1e-6 * dt:
        raise ValueError(f"{record.name}: the loop needs uniformly sampled data (resample first)")
    raw = record.q[:, 0]
    n_w = max(5, int(round(0.25 / dt)))
    n_w += 1 - n_w % 2
    if raw.size < 2 * n_w:
        raise ValueError(f"{record.name}: {raw.size} samples; the loop needs at least {2 * n_w}")
    v_sg = savgol_filter(raw, n_w, 3, deriv=1, delta=dt)
    cuts = np.concatenate([[0], np.flatnonzero(np.sign(v_sg[:-1]) != np.sign(v_sg[1:])) + 1, [raw.size]])
    parts: list[tuple[np.ndarray, ...]] = []
    resid = []
    for s0, s1 in zip(cuts[:-1], cuts[1:]):
        if s1 - s0 < 4 * (degree + 1):
            continue
        t = record.t[s0:s1]
        half = 0.5 * (t[-1] - t[0])
        x = (t - t[0]) / half - 1.0  # [-1, 1]
        c = C.chebfit(x, raw[s0:s1], degree)
        q = C.chebval(x, c)
        v = C.chebval(x, C.chebder(c)) / half
        a = C.chebval(x, C.chebder(c, 2)) / half**2
        inner = (t > t[0] + edge_s) & (t < t[-1] - edge_s)
        parts.append((t, q, v, a, inner))
        resid.append(raw[s0:s1] - q)
    if not parts:
        raise ValueError(f"{record.name}: no swing of at least {4 * (degree + 1)} samples between reversals")
    t, q, v, a, inner = (np.concatenate(z) for z in zip(*parts))
    r = np.concatenate(resid)
    noise = float(np.sqrt(r @ r / max(r.size - len(parts) * (degree + 1), 1)))
    J, Q, h = joint_terms(record_params(record, params), joint, q, v, record.locked_angles())
    torque = Q - h - J * a
    sliding = (np.abs(v) > v_min) & inner
    return FrictionLoop(t, q, v, a, torque, J, sliding, noise, joint, record.name)


def _fit_sliding(v: np.ndarray, tau: np.ndarray, alpha0: float) -> tuple[dict[str, float], float]:
    """Least squares of the steady-sliding curve: ({Fc, Fs, alpha_f, sigma2}, standard error of Fs - Fc)."""
    # Coulomb + viscous first (linear), the start of the Stribeck fit
    A = np.column_stack([np.sign(v), v])
    (fc0, s20), *_ = np.linalg.lstsq(A, tau, rcond=None)
    fc0 = max(fc0, 1e-9)
    scale = max(abs(fc0), 1e-9)

    def resid(x: np.ndarray) -> np.ndarray:
        fc, dfs, log_alpha, s2 = x
        return (steady_sliding(v, fc, fc + dfs, math.exp(log_alpha), s2) - tau) / scale

    x0 = np.array([fc0, 0.05 * fc0, math.log(min(max(alpha0, 1.0), 1e3)), max(s20, 0.0)])
    lo = np.array([0.0, 0.0, math.log(1e-1), 0.0])
    hi = np.array([np.inf, 10.0 * fc0 + 1e-9, math.log(1e4), np.inf])
    sol = least_squares(resid, np.clip(x0, lo, hi), bounds=(lo, hi), x_scale=np.array([fc0, 0.05 * fc0, 1.0, max(abs(s20), 1e-6)]))
    fc, dfs, log_alpha, s2 = sol.x
    r = sol.fun * scale
    dof = max(v.size - 4, 1)
    sigma2_r = float(r @ r) / dof
    Jm = sol.jac * scale
    try:
        cov = np.linalg.inv(Jm.T @ Jm) * sigma2_r
        se_dfs = float(math.sqrt(max(cov[1, 1], 0.0)))
    except np.linalg.LinAlgError:
        se_dfs = math.inf
    return dict(Fc=float(fc), Fs=float(fc + dfs), alpha_f=float(math.exp(log_alpha)), sigma2=float(s2)), se_dfs


def _presliding_stiffness(loops: Sequence[FrictionLoop], deflection: float) -> float | None:
    """sigma0 (N m/rad) from friction against displacement after each reversal, or None when the
    pre-sliding travel 2 deflection spans fewer than 3 samples or less than 5 times the angle noise."""
    dq, dtau = [], []
    for lp in loops:
        for k in np.flatnonzero(np.sign(lp.v[:-1]) != np.sign(lp.v[1:])):
            end = k + 1
            while end < lp.q.size and abs(lp.q[end] - lp.q[k]) < 2.0 * deflection:
                end += 1
            seg = slice(k, end)
            if end - k >= 3 and 2.0 * deflection > 5.0 * lp.noise:
                dq.append(lp.q[seg] - lp.q[k])
                dtau.append(lp.torque[seg] - lp.torque[k])
    if not dq:
        return None
    x, y = np.concatenate(dq), np.concatenate(dtau)
    slope = float(x @ y / (x @ x)) if x @ x > 0 else 0.0
    return slope if slope > 0.0 else None


def friction_first_estimates(
    records: FlightRecord | Sequence[FlightRecord],
    params: RigParams,
    joint: str,
    degree: int = 7,
    edge_s: float = 0.1,
    v_min: float = 0.05,
    damping_ratio: float | None = None,
) -> dict[str, float]:
    """First estimates of ``joint``'s seven LuGre parameters from one-joint wind-off records (fitted jointly).

    Returns {"Fs", "Fc", "alpha_f", "v_d", "sigma0", "sigma1", "sigma2"} (N m, s/rad, rad/s, N m/rad, N m
    s/rad; the keys of ``friction.<joint>.*``).  The rules, and which parameters fall back on the prior
    ``params`` when the data cannot show them: the module docstring.  degree, edge_s, v_min: as
    :func:`friction_velocity_loop`; damping_ratio: zeta of the sigma1 rule, a finite number >= 0 (None: the
    prior's, 1: critical).
    """
    check_joint(joint)
    check_rig(params)
    recs = check_records(records, "friction record")
    degree, edge_s, v_min = check_loop_options(degree, edge_s, v_min)
    if damping_ratio is not None and not (is_number(damping_ratio) and math.isfinite(damping_ratio) and damping_ratio >= 0.0):
        raise ValueError(f"damping_ratio = {damping_ratio!r}: must be a finite number >= 0 (zeta of the sigma1 rule; 1: critical) or None "
                         "(the prior's)")
    prior = getattr(params.friction, joint)
    loops = [friction_velocity_loop(r, params, joint, degree, edge_s, v_min) for r in recs]
    v = np.concatenate([lp.v[lp.sliding] for lp in loops])
    tau = np.concatenate([lp.torque[lp.sliding] for lp in loops])
    if v.size < 10 or np.all(v > 0) or np.all(v < 0):
        raise ValueError(f"{joint}: {v.size} sliding samples; the fit needs sliding in both directions (|v| > {v_min} rad/s)")
    # the dip is looked for only where the data reach the speeds at which the prior's dip is above
    # exp(-3) = 5 % of its depth: otherwise a Stribeck term only fits the noise of the slowest samples
    visible = np.mean(np.abs(v) < 3.0 / prior.alpha_f) > 0.05 if prior.alpha_f > 0 else True
    if visible:
        est, se_dfs = _fit_sliding(v, tau, prior.alpha_f)
    if not visible or not (est["Fs"] - est["Fc"] > 2.0 * se_dfs) or est["alpha_f"] >= 0.999e4:
        (fc, s2), *_ = np.linalg.lstsq(np.column_stack([np.sign(v), v]), tau, rcond=None)
        fc = max(float(fc), 1e-6)  # within the parameter's range (a start value for the refinement)
        est = dict(Fc=fc, Fs=fc, alpha_f=prior.alpha_f, sigma2=max(float(s2), 0.0))  # no dip resolved
    deflection = prior.Fs / prior.sigma0
    sigma0 = _presliding_stiffness(loops, deflection)
    est["sigma0"] = sigma0 if sigma0 is not None else est["Fs"] / deflection
    inertia = float(np.median(np.concatenate([lp.inertia for lp in loops])))
    zeta = prior.sigma1 / (2.0 * math.sqrt(prior.sigma0 * inertia)) if damping_ratio is None else float(damping_ratio)
    est["sigma1"] = 2.0 * zeta * math.sqrt(est["sigma0"] * inertia)
    est["v_d"] = prior.v_d
    return {k: float(est[k]) for k in ("Fs", "Fc", "alpha_f", "v_d", "sigma0", "sigma1", "sigma2")}
