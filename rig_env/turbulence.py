"""Tunnel turbulence: the Dryden and von Karman gust spectra and the gust's convection from the Hawk to the compensator.

**Dryden spectrum** (MIL-F-8785C; Hoblit, Gust Loads on Aircraft, ch. 3).  With the longitudinal integral
scale L (m), the intensity sigma (m/s, the same on every axis: isotropic turbulence), the airspeed V and
T = L / V (s), the gust components along the flow (u), across it (v) and vertically (w) are stationary
Gaussian processes with the autocorrelations and one-sided power spectra (omega in rad/s,
integral over 0 < omega < inf of Phi = sigma^2)

    R_u(tau) = sigma^2 exp(-|tau| / T),                           Phi_u = sigma^2 (2 T / pi) / (1 + (T omega)^2)
    R_v(tau) = sigma^2 (1 - |tau| / (2 T)) exp(-|tau| / T),      Phi_v = sigma^2 (T / pi) (1 + 3 (T omega)^2) / (1 + (T omega)^2)^2

and w as v.  One L serves all three: the transverse correlation of isotropic turbulence follows from the
longitudinal one, g(r) = f + (r / 2) f', which is R_v for f = exp(-r / L) (its integral scale is L / 2).
They are the outputs of shaping filters driven by unit white noise (two-sided spectral density 1):

    u: sigma sqrt(2 T) / (1 + T s),     v, w: sigma sqrt(T) (1 + sqrt(3) T s) / (1 + T s)^2.

Discretisation: exact at the control step h (the sampled filter states have exactly the continuous
process's statistics at the sample times: Astrom, Introduction to Stochastic Control Theory, ch. 3).
u is first order, u_{k+1} = phi u_k + sigma sqrt(1 - phi^2) n_k, phi = exp(-h / T) (the
Gauss-Markov recursion with tau = L / V).  v and w have the states x = (x1, x1'), x1'' = -a^2 x1 - 2 a x1'
+ white noise (a = 1 / T), output sigma sqrt(T) a^2 (x1 + sqrt(3) T x1'):

    x_{k+1} = Phi x_k + chol(Q) n_k,   Phi = e^{-a h} [[1 + a h, h], [-a^2 h, 1 - a h]],
    Q = int_0^h e^{-2 a s} [[s^2, s (1 - a s)], [s (1 - a s), (1 - a s)^2]] ds

(Q's integrals are incomplete gamma functions, accurate for any a h), started in the stationary
covariance diag(1 / (4 a^3), 1 / (4 a)).  Each component is held over the control step it is drawn for
(the gust inputs' zero-order hold, as the Gauss-Markov gusts are).

**Von Karman spectrum** (MIL-F-8785C; Hoblit, Gust Loads on Aircraft, ch. 3), the same L, sigma and T, with
a = Gamma(1/3) / (sqrt(pi) Gamma(5/6)) = 1.33899 (the standards' 1.339) and the same convention:

    Phi_u = sigma^2 (2 T / pi) / (1 + (a T omega)^2)^(5/6),   Phi_v = sigma^2 (T / pi) (1 + (8/3) (a T omega)^2) / (1 + (a T omega)^2)^(11/6)
    R_u(tau) = sigma^2 C xi^(1/3) K_{1/3}(xi),   R_v(tau) = sigma^2 C xi^(1/3) (K_{1/3}(xi) - (xi / 2) K_{2/3}(xi)),

xi = |tau| / (a T), C = 2^(2/3) / Gamma(1/3), K the modified Bessel functions of the second kind (the
transforms of each other: Gradshteyn and Ryzhik 3.771.2), and w as v.  Isotropy holds as for Dryden: the
spectral form of g = f + (r / 2) f' is Phi_v = (Phi_u - omega Phi_u') / 2, which turns von Karman's Phi_u
into its Phi_v with the same L (and Dryden's into Dryden's).  The spectrum is not rational (it falls as
omega^(-5/3)), so no finite filter is exact.  Here it is the sum of N = 5 independent Dryden processes of
scales lambda_i L and variances w_i sigma^2 (:data:`VON_KARMAN_SCALES`, :data:`VON_KARMAN_WEIGHTS`):
Phi ~ sum_i w_i Phi_Dryden(lambda_i L), a rational spectrum (poles 1 / (lambda_i T)).  Because the
isotropy relation is linear, the same weights and scales turn the u mixture into the v and w ones, so
the approximation is isotropic exactly, and each term is discretised exactly as above (:class:`SpectralGusts`).  Its accuracy
against the exact spectrum (sum w = 1 and sum w lambda = 1 to 1e-9, so the variance sigma^2 and the
integral scale L are exact):

* u within 0.25 %, v and w within 0.46 %, for 0 <= T omega <= 100 (the fit's band; T omega at the
  Nyquist frequency of 80 Hz is 9.5 at 20 m/s with L = 0.76 m, 29 at 244 Hz);
* beyond: at most 17 % high (T omega 300 - 1000, where the mixture puts the variance of the exact tail
  above its last corner, T omega = 1 / lambda_5 = 321), then falling as omega^(-2) instead of
  omega^(-5/3): u 24 % low at T omega = 3000 and 49 % at 1e4, v and w 15 % and 42 %.  Above T omega = 100
  lie 2.7 % of u's exact variance and 3.6 % of v's;
* the autocorrelation coefficients within 0.002 of the exact R_u / sigma^2 and R_v / sigma^2 at every lag.

It costs 5 N = 25 normals per environment and step (Dryden's 5).  The published rational approximations
(MIL-HDBK-1797's shaping filters, second order for u and third for v and w) keep Phi(0) but are 3.3 %
low to 2.8 % high for u up to T omega = 10 and 4.5 % low to 1.5 % high for v up to 20, with variances
3.1 % (u) and 3.8 % (v, w) below sigma^2 (derived: the quadrature of their squared magnitudes), hence
the mixture.

World axes: the tunnel flow is along -x, so the longitudinal gust u adds (-u, 0, 0) (a positive u is
faster air); v is along +y, w along +z (down).

**Convection** (Taylor's frozen turbulence): the gust field moves with the flow, so the compensator,
d = arm_length + hawk_cg_x - comp_aero_x (m) downstream of the Hawk's c.g. on the straight arm, meets the
air the Hawk met d / V earlier.  :class:`GustHistory` keeps each environment's Hawk gusts at the control
rate and gives the compensator's, the Hawk's delayed by d / V, interpolated linearly between samples.
Resolution: the gusts are held over control steps, so the compensator's gust is itself a control-rate
signal: the delay is resolved to a fraction of a step, but no content above half the control rate exists
to be delayed.  Linear interpolation is exact for a signal linear between samples; a sinusoid of
frequency f is attenuated by at worst cos(pi f h) (half-way between samples): 5 % at a tenth of the
control rate (8 Hz at 80 Hz, where, at 20 m/s and L = 0.76 m, u's spectrum is a fifth of its level at
zero frequency and v's and w's a half).
The distance is the straight arm's: rig yaw and pitch change the streamwise separation by their
cosine (1 - cos 10 deg = 1.5 %), which is left out.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from rig_env.physics import layout as L

TURBULENCE_MODELS = ("gauss_markov", "dryden", "von_karman")
"""``turbulence_model`` values: the first-order Gauss-Markov gusts of correlation time ``turbulence_tau``
(per world axis), or the Dryden or von Karman spectrum at the length scale ``turbulence_scale``."""
SPECTRAL_MODELS = ("dryden", "von_karman")
"""The models of u, v and w gusts at a length scale (:class:`SpectralGusts`); their gusts are convected by default."""

VON_KARMAN_A = math.gamma(1.0 / 3.0) / (math.sqrt(math.pi) * math.gamma(5.0 / 6.0))
"""1.33899, derived: the factor a of the von Karman spectra that makes their variance sigma^2 (MIL-F-8785C's 1.339)."""
VON_KARMAN_SCALES = (1.252707154, 0.411895697, 0.09795114632, 0.02229439873, 0.003112805938)
"""lambda_i, derived: scripts/von_karman_fit.py (module docstring): the mixture's Dryden scales, in units of L."""
VON_KARMAN_WEIGHTS = (0.7394528893, 0.1629799834, 0.06110384937, 0.0235969122, 0.01286636575)
"""w_i, derived: scripts/von_karman_fit.py: the mixture's variances, in units of sigma^2."""
MIXTURES: dict[str, tuple[tuple[float, ...], tuple[float, ...]]] = {
    "dryden": ((1.0,), (1.0,)),
    "von_karman": (VON_KARMAN_WEIGHTS, VON_KARMAN_SCALES),
}
"""Each spectral model as (weights w_i, scales lambda_i) of independent Dryden processes: Dryden is the one term."""

TEST_SECTION_WIDTH = 2.134
"""m, paper: the University of Bristol's 7 ft x 5 ft closed-section low-speed tunnel (Sec. III, Fig. 3)."""
TEST_SECTION_HEIGHT = 1.524
"""m, paper: 5 ft, the same tunnel."""
TUNNEL_SCALE = 0.76
"""m, estimate: the longitudinal integral scale of the tunnel's turbulence, taken as half the test section's
height (TEST_SECTION_HEIGHT / 2): a tunnel's free-stream turbulence has scales of the order of its
grid and section, the section's walls bound the largest eddies, and the integral scale is a fraction
of the largest.  Neither the scale nor the intensity of this tunnel's turbulence is published; a
screened tunnel's can be far smaller (cm), hence ``turbulence_scale``'s range [0.01, 10] m."""
SCALE_RANGE = (0.01, 10.0)
"""m: the allowed ``turbulence_scale`` (a fine screen's mesh to several test sections)."""
MIN_CONVECTION_SPEED = 0.5
"""m/s: the speed below which the tunnel flow counts as still (rig_env.physics.aero.MIN_AIRSPEED, where the
aerodynamic loads stop): convection delays and Dryden time scales use at least this speed."""


def convection_distance(P: np.ndarray) -> np.ndarray:
    """(n,) streamwise distance (m) from the Hawk's c.g. to the compensator's aerodynamic reference point on
    the straight arm: arm_length + hawk_cg_x - comp_aero_x, of parameter rows P (n, N_PARAMS) or (N_PARAMS,)."""
    P = np.atleast_2d(P)
    return P[:, L.P_GEOMETRY_ARM_LENGTH] + P[:, L.P_GEOMETRY_HAWK_CG_X] - P[:, L.P_GEOMETRY_COMP_AERO_X]


def convection_delay(P: np.ndarray, airspeed: np.ndarray | float) -> np.ndarray:
    """(n,) time (s) the air takes from the Hawk's c.g. to the compensator: :func:`convection_distance` / V,
    V the airspeed (m/s, (n,) or scalar) but at least :data:`MIN_CONVECTION_SPEED`."""
    return convection_distance(P) / np.maximum(np.asarray(airspeed, dtype=np.float64), MIN_CONVECTION_SPEED)


def world_gust(u: np.ndarray, v: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(n, 3) world-axes gust (m/s) of the longitudinal, lateral and vertical components (n,): (-u, v, w)."""
    return np.stack([-u, v, w], axis=1)


# ---------------------------------------------------------------------- the closed forms
def _longitudinal(component: str) -> bool:
    """True for "u", False for "v" or "w"; anything else is a ValueError."""
    if component not in ("u", "v", "w"):
        raise ValueError(f"component = {component!r}: one of 'u', 'v', 'w'")
    return component == "u"


def dryden_psd(component: str, omega: np.ndarray | float, sigma: float, scale: float, airspeed: float) -> np.ndarray:
    """One-sided power spectral density (m^2/s^2 per rad/s) of gust component "u", "v" or "w" at omega (rad/s)."""
    T = scale / airspeed
    x = (T * np.asarray(omega, dtype=np.float64)) ** 2
    if _longitudinal(component):
        return sigma**2 * (2.0 * T / math.pi) / (1.0 + x)
    return sigma**2 * (T / math.pi) * (1.0 + 3.0 * x) / (1.0 + x) ** 2


def dryden_autocorrelation(component: str, lag: np.ndarray | float, sigma: float, scale: float, airspeed: float) -> np.ndarray:
    """Autocorrelation (m^2/s^2) of gust component "u", "v" or "w" at time lag (s)."""
    r = np.abs(np.asarray(lag, dtype=np.float64)) * airspeed / scale
    if _longitudinal(component):
        return sigma**2 * np.exp(-r)
    return sigma**2 * (1.0 - 0.5 * r) * np.exp(-r)


def von_karman_psd(component: str, omega: np.ndarray | float, sigma: float, scale: float, airspeed: float) -> np.ndarray:
    """The exact von Karman one-sided power spectral density (m^2/s^2 per rad/s) of gust component "u", "v" or
    "w" at omega (rad/s) (module docstring; the generator's is within the stated error of it)."""
    T = scale / airspeed
    x = (VON_KARMAN_A * T * np.asarray(omega, dtype=np.float64)) ** 2
    if _longitudinal(component):
        return sigma**2 * (2.0 * T / math.pi) / (1.0 + x) ** (5.0 / 6.0)
    return sigma**2 * (T / math.pi) * (1.0 + 8.0 / 3.0 * x) / (1.0 + x) ** (11.0 / 6.0)


def von_karman_autocorrelation(component: str, lag: np.ndarray | float, sigma: float, scale: float, airspeed: float) -> np.ndarray:
    """The exact von Karman autocorrelation (m^2/s^2) of gust component "u", "v" or "w" at time lag (s)."""
    # the modified Bessel function of the second kind; scipy is loaded lazily
    from scipy.special import kv

    xi = np.abs(np.asarray(lag, dtype=np.float64)) * airspeed / (VON_KARMAN_A * scale)
    pos = np.where(xi > 0.0, xi, 1.0)  # xi^(1/3) K(xi) -> 2^(-2/3) Gamma(1/3) as xi -> 0: the coefficient 1
    c = 2.0 ** (2.0 / 3.0) / math.gamma(1.0 / 3.0) * np.cbrt(pos)
    rho = c * kv(1.0 / 3.0, pos) if _longitudinal(component) else c * (kv(1.0 / 3.0, pos) - 0.5 * pos * kv(2.0 / 3.0, pos))
    return sigma**2 * np.where(xi > 0.0, rho, 1.0)


def dryden_discretisation(airspeed: np.ndarray, scale: float, dt: float) -> dict[str, np.ndarray]:
    """The exact discrete filters of the module docstring at step dt (s) for airspeeds (n,) m/s (at least
    :data:`MIN_CONVECTION_SPEED`), per unit intensity.  Returns (n,) arrays: ``phi_u``, ``g_u`` (u's recursion
    u' = phi_u u + g_u n), ``Phi`` (n, 2, 2), ``chol`` (n, 2, 2) lower factor of Q, ``c`` (n, 2) the output
    row per unit sigma, ``P0`` (n, 2, 2) the stationary covariance of the v, w states."""
    from scipy.special import gammainc  # the regularised lower incomplete gamma P(k, x); scipy is loaded lazily

    V = np.maximum(np.asarray(airspeed, dtype=np.float64), MIN_CONVECTION_SPEED)
    T = scale / V
    a = 1.0 / T
    ah = a * dt
    phi_u = np.exp(-ah)
    g_u = np.sqrt(-np.expm1(-2.0 * ah))
    e = np.exp(-ah)
    Phi = np.empty((V.size, 2, 2))
    Phi[:, 0, 0], Phi[:, 0, 1] = e * (1.0 + ah), e * dt
    Phi[:, 1, 0], Phi[:, 1, 1] = -e * a * a * dt, e * (1.0 - ah)
    b = 2.0 * a  # I_k = int_0^h s^k e^{-b s} ds = k! / b^{k+1} P(k + 1, b h)
    I0 = gammainc(1.0, b * dt) / b
    I1 = gammainc(2.0, b * dt) / b**2
    I2 = 2.0 * gammainc(3.0, b * dt) / b**3
    q11, q12, q22 = I2, I1 - a * I2, I0 - 2.0 * a * I1 + a * a * I2
    chol = np.zeros((V.size, 2, 2))
    l11 = np.sqrt(q11)
    l21 = q12 / l11
    chol[:, 0, 0], chol[:, 1, 0], chol[:, 1, 1] = l11, l21, np.sqrt(np.maximum(q22 - l21 * l21, 0.0))
    c = np.stack([np.sqrt(T) * a * a, np.sqrt(T) * a * a * math.sqrt(3.0) * T], axis=1)
    P0 = np.zeros((V.size, 2, 2))
    P0[:, 0, 0], P0[:, 1, 1] = 0.25 / a**3, 0.25 / a
    return {"phi_u": phi_u, "g_u": g_u, "Phi": Phi, "chol": chol, "c": c, "P0": P0}


class SpectralGusts:
    """Dryden or von Karman gust generators (``model``, one of :data:`SPECTRAL_MODELS`) of n environments at the
    control step dt (s) and length scale (m): the sum of :data:`MIXTURES`'s independent Dryden processes of
    scales lambda_i x scale and variances w_i sigma^2 (Dryden: the one term), each discretised exactly.

    ``reset(idx, airspeed, sigma, normals)`` starts environments idx in the stationary distribution for
    their airspeeds (m/s) and intensities sigma (m/s), from normals (m, n_normals); ``step(normals)`` advances
    all of them one control step with standard normals (n, n_normals) (the N terms' u, then their v's two
    each, then their w's two each) and returns the world gust (n, 3), m/s.  The caller supplies the random
    numbers (the environments' counter streams).
    """

    def __init__(self, n: int, dt: float, scale: float, model: str = "dryden") -> None:
        if model not in SPECTRAL_MODELS:
            raise ValueError(f"model = {model!r}: one of {list(SPECTRAL_MODELS)}")
        if not (isinstance(scale, (int, float)) and SCALE_RANGE[0] <= scale <= SCALE_RANGE[1]):
            raise ValueError(f"turbulence_scale = {scale!r} m: allowed range [{SCALE_RANGE[0]}, {SCALE_RANGE[1]}] m")
        self.n, self.dt, self.scale, self.model = int(n), float(dt), float(scale), model
        weights, scales = MIXTURES[model]
        m = len(weights)
        self.n_normals = 5 * m  # standard normals per environment and step: each term's u one, v two and w two
        self._amp = np.sqrt(np.array(weights))  # (m,) each term's standard deviation per unit sigma
        self._scales = self.scale * np.array(scales)  # (m,) m
        self.sigma = np.zeros(n)
        self.u = np.zeros((n, m))  # each term's u per unit sigma and standard deviation
        self.xv = np.zeros((2, n, m))  # each term's v filter states (x1, x1'), per unit sigma
        self.xw = np.zeros((2, n, m))
        self._phi_u, self._g_u = np.ones((n, m)), np.zeros((n, m))
        self._Phi = np.zeros((2, 2, n, m))  # [i, j]: the (n, m) entries of the transition matrices
        self._chol = np.zeros((2, 2, n, m))  # lower factors of Q
        self._c = np.zeros((2, n, m))  # output rows per unit sigma, each term's standard deviation included

    def _split(self, normals: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
        """normals (k, n_normals) as u's (k, m) and the (k, m) pairs of v's and w's (each term's two adjacent)."""
        m = self._amp.size
        return normals[:, :m], (normals[:, m : 3 * m : 2], normals[:, m + 1 : 3 * m : 2]), (normals[:, 3 * m :: 2], normals[:, 3 * m + 1 :: 2])

    def reset(self, idx: np.ndarray, airspeed: np.ndarray, sigma: np.ndarray, normals: np.ndarray) -> None:
        self.sigma[idx] = sigma
        nu, nv, nw = self._split(normals)
        self.u[idx] = nu
        for i, scale in enumerate(self._scales):
            d = dryden_discretisation(airspeed, scale, self.dt)
            self._phi_u[idx, i], self._g_u[idx, i] = d["phi_u"], d["g_u"]
            for j in range(2):
                self._c[j, idx, i] = self._amp[i] * d["c"][:, j]
                s = np.sqrt(d["P0"][:, j, j])  # stationary: independent states of these deviations
                self.xv[j, idx, i], self.xw[j, idx, i] = s * nv[j][:, i], s * nw[j][:, i]
                for k in range(2):
                    self._Phi[j, k, idx, i], self._chol[j, k, idx, i] = d["Phi"][:, j, k], d["chol"][:, j, k]

    def gust(self) -> np.ndarray:
        """(n, 3) world gust (m/s) of the current states."""
        c = self._c  # sums row by row (never BLAS): an environment's gust is that of a batch of one
        u = np.sum(self.u * self._amp, axis=1)
        v = np.sum(c[0] * self.xv[0] + c[1] * self.xv[1], axis=1)
        w = np.sum(c[0] * self.xw[0] + c[1] * self.xw[1], axis=1)
        return world_gust(self.sigma * u, self.sigma * v, self.sigma * w)

    def _advance(self, x: np.ndarray, n: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        """The (2, n, m) states after one step: Phi x + chol(Q) n (chol lower triangular)."""
        P, C = self._Phi, self._chol
        return np.stack([P[0, 0] * x[0] + P[0, 1] * x[1] + C[0, 0] * n[0], P[1, 0] * x[0] + P[1, 1] * x[1] + (C[1, 0] * n[0] + C[1, 1] * n[1])])

    def step(self, normals: np.ndarray) -> np.ndarray:
        nu, nv, nw = self._split(normals)
        self.u = self._phi_u * self.u + self._g_u * nu
        self.xv, self.xw = self._advance(self.xv, nv), self._advance(self.xw, nw)
        return self.gust()


def gust_schedule(t_final: float, *, model: str = "dryden", airspeed: float = 20.0, intensity: float = 0.05,
                  scale: float = TUNNEL_SCALE, control_rate: float = 80.0, n_envs: int = 1, seed: int = 0) -> Callable[[float], np.ndarray]:
    """A Dryden or von Karman gust (``model``, one of :data:`SPECTRAL_MODELS`) for ``rig_env.simulate(gust=...)``:
    a function of time (s) returning the world gust (m/s), (3,) for one environment or (n_envs, 3), drawn once
    at the control rate (Hz) over [0, t_final] s and held over each control step, with sigma = ``intensity``
    x ``airspeed`` (m/s; intensity a fraction, [0, 0.5]) on every axis and the length scale ``scale`` (m),
    each environment from its own stream of ``seed`` (numpy's default generator).  Before 0 it is the gust
    of 0, after t_final the last one (simulate asks for delayed times, at the compensator, and nothing
    later).  ``simulate`` convects it to the compensator."""
    if not (math.isfinite(t_final) and 0.0 < t_final <= 1e5):
        raise ValueError(f"t_final = {t_final!r} s: allowed range (0, 1e5] s")
    if not (math.isfinite(airspeed) and MIN_CONVECTION_SPEED <= airspeed <= 100.0):
        raise ValueError(f"airspeed = {airspeed!r} m/s: allowed range [{MIN_CONVECTION_SPEED}, 100] m/s")
    if not (math.isfinite(intensity) and 0.0 <= intensity <= 0.5):
        raise ValueError(f"intensity = {intensity!r}: allowed range [0, 0.5] (a fraction of the airspeed)")
    if not (math.isfinite(control_rate) and 1.0 <= control_rate <= 10000.0):
        raise ValueError(f"control_rate = {control_rate!r} Hz: allowed range [1, 10000] Hz")
    if not (isinstance(n_envs, int) and 1 <= n_envs <= 100000):
        raise ValueError(f"n_envs = {n_envs!r}: an integer in [1, 100000]")
    dt = 1.0 / control_rate
    n_t = math.ceil(t_final / dt) + 1
    gen = SpectralGusts(n_envs, dt, scale, model)
    rng = np.random.default_rng(seed)  # drawn step by step: the numbers of one (n_t, n_envs, n_normals) draw
    gen.reset(np.arange(n_envs), np.full(n_envs, float(airspeed)), np.full(n_envs, intensity * airspeed), rng.standard_normal((n_envs, gen.n_normals)))
    series = np.empty((n_t, n_envs, 3))
    series[0] = gen.gust()
    for k in range(1, n_t):
        series[k] = gen.step(rng.standard_normal((n_envs, gen.n_normals)))

    def gust(t: float) -> np.ndarray:
        k = min(max(math.floor(t / dt + 1e-9), 0), n_t - 1)
        return series[k, 0].copy() if n_envs == 1 else series[k].copy()

    return gust


dryden_schedule = gust_schedule
"""The older name of :func:`gust_schedule` (whose model is "dryden" unless told)."""


class GustHistory:
    """Each environment's Hawk gusts at the control rate (a ring buffer) and the compensator's, the Hawk's
    delayed by the convection time and interpolated linearly in time (module docstring).

    n environments, control step dt (s), max_delay (s): the longest delay kept (longer ones are clamped to
    it: the compensator then meets the oldest gust kept); it holds n (ceil(max_delay / dt) + 2) x 3 floats
    (9 samples at 80 Hz with airspeeds from 15 m/s up on the default rig, 191 from the 0.5 m/s floor).
    ``reset(idx, gust, delay)`` fills environments idx's history with their first gust (m, 3) (the air
    upstream of the Hawk before the episode is taken to be that gust) and sets their delays (m,) s;
    ``push(gust)`` stores every environment's gust of the next control step and returns the
    compensator's (n, 3).
    """

    def __init__(self, n: int, dt: float, max_delay: float) -> None:
        self.dt = float(dt)
        self.size = int(math.ceil(max_delay / dt)) + 2
        self.buf = np.zeros((n, self.size, 3))
        self.count = np.zeros(n, dtype=np.int64)
        self.lag = np.zeros(n)  # delays in control steps

    def reset(self, idx: np.ndarray, gust: np.ndarray, delay: np.ndarray) -> None:
        self.buf[idx] = np.asarray(gust)[:, None, :]
        self.count[idx] = 0
        self.lag[idx] = np.minimum(np.asarray(delay) / self.dt, self.size - 2)

    def push(self, gust: np.ndarray) -> np.ndarray:
        self.count += 1
        rows = np.arange(self.buf.shape[0])
        self.buf[rows, self.count % self.size] = gust
        s = self.count - self.lag  # the sample time of the delayed gust, in control steps
        j = np.floor(s).astype(np.int64)
        f = (s - j)[:, None]
        return (1.0 - f) * self.buf[rows, j % self.size] + f * self.buf[rows, (j + 1) % self.size]
