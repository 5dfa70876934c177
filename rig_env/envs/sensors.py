"""``Sensors``: what the rig's real-time loop sees, built from raw measurements, batched over envs.

Per control step (all environments at once, numpy, no per-environment loop):

    1. corrupt (simulation only):  m = lsb * round((x + sigma * n) / lsb)     n ~ N(0, 1), given
    2. transport delay:            m_k -> ring buffer -> m_{k - d}          d whole control steps
    3. rate estimate:              r_k = r_{k-1} + a ((m_k - m_{k-1}) / dt - r_{k-1}),
                                   a = dt / (tau + dt),  tau = 1 / (2 pi f_c)   (filtered backward difference)
    4. normalise:                  see the layout table below; every entry is clipped to its bounds

Steps 1-3 of every environment are one numba pass (:func:`_update_kernel`), and so is step 4
(:func:`_observation_kernel`); they give the same numbers as the numpy formulas above
(``tests/test_env_kernels.py``).  Both are called with one set of argument types only (C-contiguous
float64 arrays), and the first ``Sensors`` built in a process compiles them (or loads them from the
disk cache, a few ms), so a real-time loop never pays for that inside a tick; nothing is compiled, nor
numba imported, at import (:mod:`rig_env.physics.jit`).  A process in Python mode (the rig's loop,
``rig-deploy run``) runs the same kernels as Python: the same float32 observations bit for bit
(``tests/test_jit.py``).

The class takes only raw measurements (joint angles in rad, compensator flap positions in rad,
airspeed in m/s) and optional standard-normal noise samples, so the real-time deployment loop can
reuse it unchanged with ``noise=None``, ``quantise=False`` and ``delay_steps=0`` (the rig's own
converters quantise and its link delays).

Observation layout (``n_j`` measured joints, ``JOINTS`` order of the free joints):

| entries | signal | normalisation | bounds |
|---|---|---|---|
| per limited joint (rig_pitch, rig_yaw, model_pitch) | angle | / 30 deg | [-3, 3] |
| per unlimited joint (rig_roll, model_yaw) | sin, cos of angle | - | [-1, 1] |
| per joint | rate estimate | / ``rate_scale`` (12 rad/s rig_roll, model_yaw; 5 rad/s others) | [-5, 5] |
| 4 | compensator flaps 1-4 (encoders) | / 40 deg | [-1.5, 1.5] |
| 1 | airspeed | / 40 m/s | [0, 1.5] |

Converters: rig joints are potentiometers of ``pot_bits`` over 360 deg (12 bits: 0.088 deg); model
gimbal joints and flaps are magnetic encoders of ``encoder_bits`` over 360 deg (13 bits: 0.044 deg).
The Hawk's own surface deflections are not measured on the rig (paper, Sec. V).
"""

from __future__ import annotations

import math

import numpy as np

from rig_env.params import JOINTS
from rig_env.physics import vmath
from rig_env.physics.jit import kernel

_JIT = {"cache": True, "error_model": "numpy", "_nrt": False}  # allocation-free kernels, compiled lazily

UNLIMITED = ("rig_roll", "model_yaw")
POTENTIOMETER = ("rig_roll", "rig_pitch", "rig_yaw")
ANGLE_SCALE = math.radians(30.0)
FLAP_SCALE = math.radians(40.0)
AIRSPEED_SCALE = 40.0
RATE_SCALE = {"rig_roll": 12.0, "rig_pitch": 5.0, "rig_yaw": 5.0, "model_pitch": 5.0, "model_yaw": 12.0}
N_FLAPS = 4
_NO_NOISE = np.zeros((1, 1))


def _c64(x: np.ndarray) -> np.ndarray:
    """x as a C-contiguous float64 array (no copy when it already is one): the kernels' only argument type."""
    return np.ascontiguousarray(x, dtype=np.float64)


@kernel(**_JIT)
def _update_kernel(angles_raw, flaps_raw, airspeed_raw, noise_t, noisy, sigma, lsb, buf, k, kd, dt, alpha,
                   angles, flaps, airspeed, prev, rates):
    """Steps 1-3 of the module docstring for every environment, in place.

    angles_raw (n, n_j) rad, flaps_raw (n, 4) rad, airspeed_raw (n,) m/s; noise_t (C, n) N(0, 1),
    channel-major (the layout :func:`rig_env.envs.streams.normal` draws in), used when ``noisy``; sigma,
    lsb (C,) per channel (C = n_j + 5; lsb 0: not quantised).  The corrupted measurement goes to slot k
    of the ring buffer buf (n, d + 1, C); slot kd (the one d steps old) is unpacked into angles (n, n_j),
    flaps (n, 4), airspeed (n,); rates (n, n_j) rad/s are filtered with alpha from the backward
    difference over dt s against prev (n, n_j), which becomes the new angles.
    """
    n, nj = angles.shape
    n_ch = sigma.shape[0]
    for i in range(n):
        for c in range(n_ch):
            if c < nj:
                m = angles_raw[i, c]
            elif c < nj + N_FLAPS:
                m = flaps_raw[i, c - nj]
            else:
                m = airspeed_raw[i]
            if noisy:
                m = m + sigma[c] * noise_t[c, i]
            if lsb[c] > 0.0:
                m = np.rint(m / lsb[c]) * lsb[c]
            buf[i, k, c] = m
        for c in range(nj):
            a = buf[i, kd, c]
            angles[i, c] = a
            rates[i, c] += alpha * ((a - prev[i, c]) / dt - rates[i, c])
            prev[i, c] = a
        for c in range(N_FLAPS):
            flaps[i, c] = buf[i, kd, nj + c]
        airspeed[i] = buf[i, kd, nj + N_FLAPS]


@kernel(**_JIT)
def _clip(v, lo, hi):
    """v clipped to [lo, hi]; NaN stays NaN (as ``np.clip``)."""
    if v < lo:
        return lo
    if v > hi:
        return hi
    return v


@kernel(**_JIT)
def _sincos_columns(angles, unl_cols, col, sn, cs):
    """sn[a], cs[a] (n,) = sine and cosine of angles[:, unl_cols[a]], one vmath.sincos each (2 ulp of the
    C library's; two libm calls cost twice).  The column is first copied to col (n,) so that the sincos
    loop reads contiguous memory and LLVM runs it in SIMD lanes: a third of the observation's time at
    1024 environments, when it was computed inside the per-environment loop."""
    n = angles.shape[0]
    for a in range(unl_cols.shape[0]):
        c = unl_cols[a]
        for i in range(n):
            col[i] = angles[i, c]
        for i in range(n):
            s, co = vmath.sincos(col[i])
            sn[a, i] = s
            cs[a, i] = co


@kernel(**_JIT)
def _observation_kernel(angles, rates, flaps, airspeed, lim_cols, unl_cols, rate_scale, low, high, col, sn, cs, out):
    """Step 4 (the layout table) for every environment into out (n, obs_dim) float64.

    angles, rates (n, n_j) rad, rad/s; flaps (n, 4) rad; airspeed (n,) m/s; lim_cols, unl_cols: columns
    of the limited and unlimited joints; rate_scale (n_j,) rad/s; low, high (obs_dim,) bounds; col (n,),
    sn, cs (n_unlimited, n): scratch.
    """
    _sincos_columns(angles, unl_cols, col, sn, cs)
    n, nj = angles.shape
    nu = unl_cols.shape[0]
    for i in range(n):
        j = 0
        for c in lim_cols:
            out[i, j] = _clip(angles[i, c] / ANGLE_SCALE, low[j], high[j])
            j += 1
        for a in range(nu):
            out[i, j + a] = _clip(sn[a, i], low[j + a], high[j + a])
            out[i, j + nu + a] = _clip(cs[a, i], low[j + nu + a], high[j + nu + a])
        j += 2 * nu
        for c in range(nj):
            out[i, j] = _clip(rates[i, c] / rate_scale[c], low[j], high[j])
            j += 1
        for c in range(N_FLAPS):
            out[i, j] = _clip(flaps[i, c] / FLAP_SCALE, low[j], high[j])
            j += 1
        out[i, j] = _clip(airspeed[i] / AIRSPEED_SCALE, low[j], high[j])


class Sensors:
    """Noise, quantisation, delay, rate estimation and normalisation of the rig's measurements.

    joints: names of the measured joints (JOINTS order).  dt: control step, s.  rate_filter_hz: corner
    of the rate estimate's low-pass.  delay_steps: telemetry delay in control steps.  angle_noise,
    flap_noise: 1-sigma noise, rad; airspeed_noise: m/s.  quantise: apply converter resolution.
    Public after :meth:`update`: ``angles`` (n, n_j) rad, ``rates`` (n, n_j) rad/s, ``flaps`` (n, 4)
    rad, ``airspeed`` (n,) m/s: the delayed, corrupted measurements in physical units.
    """

    def __init__(
        self,
        n_envs: int,
        joints: tuple[str, ...],
        dt: float,
        *,
        rate_filter_hz: float = 10.0,
        delay_steps: int = 0,
        angle_noise: float = 0.0,
        flap_noise: float = 0.0,
        airspeed_noise: float = 0.0,
        quantise: bool = True,
        pot_bits: int = 12,
        encoder_bits: int = 13,
    ) -> None:
        bad = [j for j in joints if j not in JOINTS]
        if bad:
            raise ValueError(f"joints: unknown name(s) {bad}; valid: {list(JOINTS)}")
        if not (dt > 0 and math.isfinite(dt)):
            raise ValueError(f"dt = {dt} s must be positive")
        self.n_envs, self.joints, self.dt = n_envs, tuple(joints), float(dt)
        nj = len(self.joints)
        tau = 1.0 / (2.0 * math.pi * rate_filter_hz)
        self.alpha = self.dt / (tau + self.dt)
        self.delay_steps = int(delay_steps)
        two_pi = 2.0 * math.pi
        lsb_j = [two_pi / 2**pot_bits if j in POTENTIOMETER else two_pi / 2**encoder_bits for j in self.joints]
        # channel order of the raw vector: joints, flaps, airspeed
        self.lsb = np.array(lsb_j + [two_pi / 2**encoder_bits] * N_FLAPS + [0.0]) if quantise else np.zeros(nj + N_FLAPS + 1)
        self.sigma = np.array([angle_noise] * nj + [flap_noise] * N_FLAPS + [airspeed_noise])
        self.n_channels = nj + N_FLAPS + 1
        self.unlimited = np.array([j in UNLIMITED for j in self.joints], dtype=bool)
        self.rate_scale = np.array([RATE_SCALE[j] for j in self.joints])
        self._lim_cols = np.flatnonzero(~self.unlimited).astype(np.int64)
        self._unl_cols = np.flatnonzero(self.unlimited).astype(np.int64)
        n_ang = int(np.sum(~self.unlimited) + 2 * np.sum(self.unlimited))
        self.obs_dim = n_ang + nj + N_FLAPS + 1
        lo = [-3.0] * int(np.sum(~self.unlimited)) + [-1.0] * 2 * int(np.sum(self.unlimited)) + [-5.0] * nj + [-1.5] * N_FLAPS + [0.0]
        hi = [3.0] * int(np.sum(~self.unlimited)) + [1.0] * 2 * int(np.sum(self.unlimited)) + [5.0] * nj + [1.5] * N_FLAPS + [1.5]
        self.low, self.high = np.array(lo), np.array(hi)
        self._buf = np.zeros((n_envs, self.delay_steps + 1, self.n_channels))
        self._k = 0  # ring-buffer write pointer, shared by all environments
        self._prev = np.zeros((n_envs, nj))
        self.rates = np.zeros((n_envs, nj))
        self.angles = np.zeros((n_envs, nj))
        self.flaps = np.zeros((n_envs, N_FLAPS))
        self.airspeed = np.zeros(n_envs)
        self._obs = np.zeros((n_envs, self.obs_dim))
        self._col = np.zeros(n_envs)  # the observation kernel's scratch
        self._sin = np.zeros((len(self._unl_cols), n_envs))
        self._cos = np.zeros((len(self._unl_cols), n_envs))
        self._warm_up()

    # ------------------------------------------------------------------ stages
    def _corrupt(self, raw: np.ndarray, noise: np.ndarray | None) -> np.ndarray:
        m = raw if noise is None else raw + self.sigma * noise
        q = self.lsb > 0.0
        if np.any(q):
            m = m.copy() if m is raw else m
            m[:, q] = np.round(m[:, q] / self.lsb[q]) * self.lsb[q]
        return m

    @staticmethod
    def _stack(angles: np.ndarray, flaps: np.ndarray, airspeed: np.ndarray) -> np.ndarray:
        return np.concatenate([angles, flaps, np.asarray(airspeed, dtype=np.float64)[:, None]], axis=1)

    def _unpack(self, m: np.ndarray, rows: slice | np.ndarray) -> None:
        nj = len(self.joints)
        self.angles[rows] = m[:, :nj]
        self.flaps[rows] = m[:, nj : nj + N_FLAPS]
        self.airspeed[rows] = m[:, nj + N_FLAPS]

    # ------------------------------------------------------------------ API
    def reset(self, idx: np.ndarray, angles: np.ndarray, flaps: np.ndarray, airspeed: np.ndarray, noise: np.ndarray | None = None) -> None:
        """Start environments ``idx`` from a measurement held since forever (rates zero, buffer full).

        angles: (m, n_j) rad; flaps: (m, 4) rad; airspeed: (m,) m/s; noise: (m, n_channels) N(0, 1) or None.
        """
        m = self._corrupt(self._stack(angles, flaps, airspeed), noise)
        self._buf[idx] = m[:, None, :]
        self._unpack(m, idx)
        self._prev[idx] = self.angles[idx]
        self.rates[idx] = 0.0

    def update(self, angles: np.ndarray, flaps: np.ndarray, airspeed: np.ndarray, noise: np.ndarray | None = None) -> None:
        """One control step for every environment from raw measurements (shapes as in :meth:`reset`).

        noise is read channel-major: a Fortran-ordered (n, n_channels) array, as
        :func:`rig_env.envs.streams.normal` returns, costs no copy (any other layout is copied)."""
        nb = self.delay_steps + 1
        self._k = (self._k + 1) % nb
        _update_kernel(_c64(angles), _c64(flaps), _c64(airspeed), _NO_NOISE if noise is None else _c64(np.asarray(noise).T), noise is not None,
                       self.sigma, self.lsb, self._buf, self._k, (self._k - self.delay_steps) % nb, self.dt, self.alpha,
                       self.angles, self.flaps, self.airspeed, self._prev, self.rates)

    def observation(self, out: np.ndarray | None = None) -> np.ndarray:
        """(n, obs_dim) normalised observation of the current measurements (layout in the module doc).

        out: optional (n, obs_dim) array (e.g. the leading columns of the environment's float32
        observation) that receives it, cast to its dtype, and is returned; a new float64 array otherwise.
        """
        _observation_kernel(self.angles, self.rates, self.flaps, self.airspeed, self._lim_cols, self._unl_cols,
                            self.rate_scale, self.low, self.high, self._col, self._sin, self._cos, self._obs)
        if out is None:
            return self._obs.copy()
        out[...] = self._obs
        return out

    def _warm_up(self) -> None:
        """Compile (or load from the disk cache) both kernels on scratch arrays of the runtime types."""
        nj, nc = len(self.joints), self.n_channels
        z = lambda *shape: np.zeros(shape)
        _update_kernel(z(1, nj), z(1, N_FLAPS), z(1), _NO_NOISE, False, self.sigma, self.lsb, z(1, 1, nc), 0, 0, self.dt,
                       self.alpha, z(1, nj), z(1, N_FLAPS), z(1), z(1, nj), z(1, nj))
        nu = len(self._unl_cols)
        _observation_kernel(z(1, nj), z(1, nj), z(1, N_FLAPS), z(1), self._lim_cols, self._unl_cols, self.rate_scale,
                            self.low, self.high, z(1), z(nu, 1), z(nu, 1), z(1, self.obs_dim))

    def labels(self) -> list[str]:
        """Names of the observation entries, in order."""
        lim = [j for j, u in zip(self.joints, self.unlimited) if not u]
        unl = [j for j, u in zip(self.joints, self.unlimited) if u]
        return (
            [f"{j}_angle" for j in lim]
            + [f"sin_{j}" for j in unl]
            + [f"cos_{j}" for j in unl]
            + [f"{j}_rate" for j in self.joints]
            + [f"flap{k + 1}" for k in range(N_FLAPS)]
            + ["airspeed"]
        )
