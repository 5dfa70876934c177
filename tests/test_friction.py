"""LuGre gimbal friction (eqs. 19-21) against its closed forms and against a stiff reference.

(a) steady sliding: the bristle ODE held at constant v settles where eq. (21) equals
    S(v) sign(v) + sigma2 v, S(v) = Fc + (Fs - Fc) exp(-alpha_f |v|)  (eq. 20), computed here from the
    parameter file, not from rig_env's own steady-sliding function;
(b) pre-sliding: a joint given a small torque or rate behaves as a spring of stiffness sigma0 on the
    joint inertia (simulate, model pitch only, wind off, c.g. on the gimbal);
(c) the wind-off test of the paper's Fig. 4: a slow sinusoidal torque on the model-pitch gimbal traces
    the friction-velocity loop (stick at v ~ 0 while |tau| < Fs, slide on the steady curve), and the
    split integrator used by rig_env converges at second order to a Radau solution of the same problem.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit
from scipy.integrate import solve_ivp

import rig_env
from rig_env.physics import friction as fr
from rig_env.physics import layout as L

J = L.J_MODEL_PITCH


@pytest.fixture(scope="module")
def params() -> rig_env.RigParams:
    """Default rig with the Hawk c.g. on the model gimbal (gravity exerts no model-pitch torque)."""
    return rig_env.RigParams.default().replace(**{"geometry.hawk_cg_z": 0.0, "geometry.hawk_cg_x": 0.0})


@pytest.fixture(scope="module")
def lugre(params) -> rig_env.params.LuGre:
    return params.friction.model_pitch


def _inertia(params: rig_env.RigParams) -> float:
    """Model-pitch inertia about the gimbal axis: Iyy + m d^2 (d: c.g. distance from the gimbal)."""
    g, m = params.geometry, params.mass
    return m.hawk_Iyy + m.hawk_mass * (g.hawk_cg_x**2 + g.hawk_cg_z**2)


# ---------------------------------------------------------------- (a) steady sliding
@pytest.mark.parametrize("v", [0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0, -0.001, -0.02, -1.0])
def test_steady_sliding_matches_eqs_20_21(params, lugre, v):
    p = params.to_vector()
    s = lugre.Fc + (lugre.Fs - lugre.Fc) * math.exp(-lugre.alpha_f * abs(v))
    expected = math.copysign(s, v) + lugre.sigma2 * v
    rate = lugre.sigma0 * abs(v) / s  # bristle relaxation rate, 1/s
    dt = 1e-3
    z = 0.0
    for _ in range(int(math.ceil(40.0 / (rate * dt)))):  # exp(-40) of the start transient left
        z = fr.advance_bristle(p, J, v, z, dt)
    tau = fr.torque(p, J, v, z)
    assert abs(tau - expected) <= 1e-9 * abs(expected)
    assert abs(fr.steady_sliding(p, J, v) - expected) <= 1e-12 * abs(expected)


# ---------------------------------------------------------------- (b) pre-sliding spring
def _zero_crossing_times(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    i = np.flatnonzero(np.sign(x[:-1]) * np.sign(x[1:]) < 0)
    return t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])


def _pitch_only(params, q0, qd0, t_final, **kw):
    return rig_env.simulate(params, [q0], [qd0], t_final, free_dofs=("model_pitch",), aero=False, stops=False, servo=False, control_rate=400.0, **kw)


def test_presliding_small_rate_oscillates_as_a_spring(params, lugre):
    """A small kick: the joint springs back and forth about its start at sqrt(sigma0 / I), never slides."""
    inertia = _inertia(params)
    omega = math.sqrt(lugre.sigma0 / inertia)
    v0 = 2e-4  # rad/s: peak bristle force sigma0 v0 / omega = 4% of Fs
    r = _pitch_only(params, 0.0, v0, 2.0)
    q = r.q[:, 0]
    amp = v0 / omega
    assert np.abs(q).max() < 1.1 * amp  # free sliding would reach v0 t = 4e-4 rad = 47 amp
    assert np.abs(q).max() > 0.9 * amp
    tc = _zero_crossing_times(r.t[1:], q[1:])
    period = 2.0 * np.mean(np.diff(tc))
    assert abs(2.0 * math.pi / period - omega) < 0.02 * omega, f"{2 * math.pi / period:.3f} vs {omega:.3f} rad/s"


def test_presliding_torque_gives_displacement_tau_over_sigma0(params, lugre):
    """A constant torque below Fs (gravity on a c.g. moved 10 um forward) deflects the joint by about
    tau / sigma0, about which it oscillates as a spring at sqrt(sigma0 / I); free, it would fall away.

    Over the first period the mean angle is tau / sigma0; later the oscillation ratchets slowly in the
    direction of the torque (LuGre's known pre-sliding drift under oscillating load: the bristle loads
    more slowly than it unloads), so the bound on |q| over 2 s is looser.
    """
    x_cg = 1e-5  # m
    p = params.replace(**{"geometry.hawk_cg_x": x_cg})
    tau = p.mass.hawk_mass * p.environment.gravity * x_cg  # N m, nose down: towards -q
    assert tau < 0.1 * lugre.Fs
    r = _pitch_only(p, 0.0, 0.0, 2.0)
    q, z = r.q[:, 0], r.z[:, J]
    q_static = -tau / lugre.sigma0
    omega = math.sqrt(lugre.sigma0 / _inertia(p))
    tc = _zero_crossing_times(r.t, z - q_static)
    period = 2.0 * np.mean(np.diff(tc))
    assert abs(2.0 * math.pi / period - omega) < 0.03 * omega, f"{2 * math.pi / period:.3f} vs {omega:.3f} rad/s"
    first = r.t <= 2.0 * math.pi / omega
    assert abs(np.mean(q[first]) - q_static) < 0.15 * abs(q_static)
    assert 1.8 < q[first].min() / q_static < 2.2  # step response of an undamped spring peaks at 2x
    k0, k1 = np.searchsorted(r.t, [tc[0], tc[-1]])  # whole half-periods
    assert abs(np.mean(z[k0:k1]) - q_static) < 0.05 * abs(q_static)  # the bristle spring carries tau
    assert np.abs(q).max() < 4.0 * abs(q_static)
    free = _pitch_only(p, 0.0, 0.0, 0.5, friction=False).q[-1, 0]  # tau t^2 / 2 I = 70 q_static
    assert abs(free) > 50.0 * abs(q_static)


# ---------------------------------------------------------------- (c) the wind-off friction loop
@njit(cache=True, error_model="numpy")
def _one_dof(p, j, inertia, amp, freq, h, n_steps, every, out):
    """I qdd = amp sin(2 pi freq t) - tau_f, split as in rig_env.physics.integrator.

    z by its exact solution over h/2, RK4 on (q, v) with z frozen, z over h/2.  out: (n_steps // every
    + 1, 4) rows of t, q, v, z.
    """
    q = 0.0
    v = 0.0
    z = 0.0
    out[0, 0] = 0.0
    out[0, 1] = q
    out[0, 2] = v
    out[0, 3] = z
    w = 2.0 * math.pi * freq
    for n in range(n_steps):
        t = n * h
        z = fr.advance_bristle(p, j, v, z, 0.5 * h)
        k1q = v
        k1v = (amp * math.sin(w * t) - fr.torque(p, j, v, z)) / inertia
        v2 = v + 0.5 * h * k1v
        k2q = v2
        k2v = (amp * math.sin(w * (t + 0.5 * h)) - fr.torque(p, j, v2, z)) / inertia
        v3 = v + 0.5 * h * k2v
        k3q = v3
        k3v = (amp * math.sin(w * (t + 0.5 * h)) - fr.torque(p, j, v3, z)) / inertia
        v4 = v + h * k3v
        k4q = v4
        k4v = (amp * math.sin(w * (t + h)) - fr.torque(p, j, v4, z)) / inertia
        q += h * (k1q + 2.0 * k2q + 2.0 * k3q + k4q) / 6.0
        v += h * (k1v + 2.0 * k2v + 2.0 * k3v + k4v) / 6.0
        z = fr.advance_bristle(p, j, v, z, 0.5 * h)
        if (n + 1) % every == 0:
            r = (n + 1) // every
            out[r, 0] = (n + 1) * h
            out[r, 1] = q
            out[r, 2] = v
            out[r, 3] = z


LOOP_FREQ = 0.05  # Hz: slow, as the paper's spring-mass drive
LOOP_AMP_FS = 1.2  # torque amplitude in units of Fs


def _loop(params, lugre, h: float, t_final: float, sample_dt: float) -> np.ndarray:
    every = int(round(sample_dt / h))
    n_steps = int(round(t_final / h))
    out = np.zeros((n_steps // every + 1, 4))
    _one_dof(params.to_vector(), J, _inertia(params), LOOP_AMP_FS * lugre.Fs, LOOP_FREQ, h, n_steps, every, out)
    return out


def test_wind_off_friction_velocity_loop(params, lugre):
    """Fig. 4: stick (v ~ 0, friction = applied torque, |tau| < Fs), break away near Fs, slide on
    the steady curve; the loop is multi-valued at v ~ 0 (hysteresis) and single-valued when sliding."""
    p = params.to_vector()
    res = _loop(params, lugre, 1e-3, 2.0 / LOOP_FREQ, 1e-3)
    t, v, z = res[:, 0], res[:, 2], res[:, 3]
    tau_ext = LOOP_AMP_FS * lugre.Fs * np.sin(2 * np.pi * LOOP_FREQ * t)
    tau_f = np.array([fr.torque(p, J, vi, zi) for vi, zi in zip(v, z)])
    steady = np.sign(v) * (lugre.Fc + (lugre.Fs - lugre.Fc) * np.exp(-lugre.alpha_f * np.abs(v))) + lugre.sigma2 * v
    late = t > 0.5 / LOOP_FREQ  # past the first half-cycle's start-up
    v_peak = np.abs(v[late]).max()
    stuck = late & (np.abs(v) < 0.03 * v_peak)  # v ~ 0 (a pre-sliding ring-down and creep remain)
    sliding = late & (np.abs(v) > 0.3 * v_peak)
    assert stuck.mean() > 0.3 and sliding.mean() > 0.2, "expected both stick and slide phases"
    # stick: the applied torque stays below the breakaway torque and friction balances it (to the
    # inertia torque of the ring-down); LuGre's breakaway is gradual (the bristle saturates while
    # the joint creeps), so v exceeds 3% of its peak only once |tau| is a few percent above Fs
    assert np.all(np.abs(tau_ext[stuck]) < 1.1 * lugre.Fs)
    n_w = int(round(2 * math.pi * math.sqrt(_inertia(params) / lugre.sigma0) / (t[1] - t[0])))  # one ring period
    box = np.ones(n_w) / n_w
    core = np.convolve(stuck, box, mode="same") > 1 - 1e-9  # samples whose whole window is stuck
    imbalance = np.convolve(tau_f - tau_ext, box, mode="same")
    assert core.sum() > 0.5 * stuck.sum()
    assert np.abs(imbalance[core]).max() < 0.05 * lugre.Fs
    # hysteresis: at v ~ 0 the friction takes every value from -Fc to +Fc (the loop's vertical sides)
    assert tau_f[stuck].min() < -0.9 * lugre.Fc and tau_f[stuck].max() > 0.9 * lugre.Fc
    # breakaway: each slide starts with the applied torque between Fc and 1.1 Fs
    starts = np.flatnonzero(stuck[:-1] & ~stuck[1:] & late[1:] & (np.abs(tau_ext[1:]) > 0.5 * lugre.Fc))
    assert len(starts) >= 2
    for k in starts:
        assert lugre.Fc < abs(tau_ext[k]) < 1.1 * lugre.Fs, f"breakaway at {tau_ext[k] / lugre.Fs:.3f} Fs"
    # sliding branch: on the steady curve of eqs. (20)-(21)
    assert np.abs(tau_f[sliding] - steady[sliding]).max() < 0.02 * lugre.Fc


def test_split_bristle_converges_at_second_order(params, lugre):
    """The split scheme on the Fig. 4 problem against Radau with the bristle ODE in the state."""
    p = params.to_vector()
    inertia = _inertia(params)
    amp = LOOP_AMP_FS * lugre.Fs
    w = 2 * np.pi * LOOP_FREQ
    t_final = 12.0  # s: a first breakaway, slide, stop and stick
    sample = 0.01

    def rhs(t, y):
        q, v, z = y
        return [v, (amp * math.sin(w * t) - fr.torque(p, J, v, z)) / inertia, v - lugre.sigma0 * abs(v) * z / fr.stribeck(p, J, v)]

    t_s = np.arange(int(round(t_final / sample)) + 1) * sample
    ref = solve_ivp(rhs, (0.0, t_final), [0.0, 0.0, 0.0], method="Radau", t_eval=t_s, rtol=1e-10, atol=1e-13)
    assert ref.success
    hs = np.array([2e-3, 1e-3, 5e-4, 2.5e-4])
    err = np.array([np.abs(_loop(params, lugre, h, t_final, sample)[:, 1] - ref.y[0]).max() for h in hs])
    order = np.polyfit(np.log(hs), np.log(err), 1)[0]
    assert err[0] < 1e-6, f"errors {err} rad at h = {hs} s"  # measured 1.7e-7 at 2 ms
    assert order > 1.8, f"errors {err} rad at h = {hs} s: order {order:.2f}"


# ---------------------------------------------------------------- the bristle update itself
@pytest.mark.parametrize("v", [0.0, 1e-14, 1e-9, 1e-6, 1e-3, 0.05, 1.0, -0.3, -30.0])
@pytest.mark.parametrize("z0", [0.0, 2e-5, -7e-4])
def test_bristle_update_is_the_closed_form_of_eq_19(params, lugre, v, z0):
    """z(dt) of eq. (19) at frozen v: z_ss + (z0 - z_ss) exp(-a dt), z_ss = v / a, a = sigma0 |v| / S(v),
    written out here with the C library's exp; for a dt below 1e-4, where exp(-a dt) is close to 1, its
    Taylor series z0 + (v - a z0) dt (1 - a dt / 2 + (a dt)^2 / 6) instead."""
    p = params.to_vector()
    dt = 1.25e-3
    s = lugre.Fc + (lugre.Fs - lugre.Fc) * math.exp(-lugre.alpha_f * abs(v))
    a = lugre.sigma0 * abs(v) / s
    if a * dt > 1e-4:
        z_ss = v / a
        want = z_ss + (z0 - z_ss) * math.exp(-a * dt)
    else:
        want = z0 + (v - a * z0) * dt * (1.0 - 0.5 * a * dt + (a * dt) ** 2 / 6.0)
    got = fr.advance_bristle(p, J, v, z0, dt)
    assert got == pytest.approx(want, rel=1e-12, abs=1e-20)
    ra, g = fr.bristle_decay(p, J, v, dt)
    assert ra == pytest.approx(a, rel=1e-14)
    assert g == pytest.approx(dt if a == 0.0 else -math.expm1(-a * dt) / a, rel=1e-12)  # (1 - exp(-a dt)) / a, dt in the limit
