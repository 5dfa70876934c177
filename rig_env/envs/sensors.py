"""``Sensors``: what the rig's real-time loop sees, built from raw measurements, batched over envs.

Per control step (all environments at once, numpy, no per-environment loop):

    1. corrupt (simulation only):  m = lsb * round((x + sigma * n) / lsb)     n ~ N(0, 1), given
    2. transport delay:            m_k -> ring buffer -> m_{k - d}          d whole control steps
    3. rate estimate:              r_k = r_{k-1} + a ((m_k - m_{k-1}) / dt - r_{k-1}),
                                   a = dt / (tau + dt),  tau = 1 / (2 pi f_c)   (filtered backward difference)
    4. normalise:                  see the layout table below; every entry is clipped to its bounds

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

UNLIMITED = ("rig_roll", "model_yaw")
POTENTIOMETER = ("rig_roll", "rig_pitch", "rig_yaw")
ANGLE_SCALE = math.radians(30.0)
FLAP_SCALE = math.radians(40.0)
AIRSPEED_SCALE = 40.0
RATE_SCALE = {"rig_roll": 12.0, "rig_pitch": 5.0, "rig_yaw": 5.0, "model_pitch": 5.0, "model_yaw": 12.0}
N_FLAPS = 4


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
        """One control step for every environment from raw measurements (shapes as in :meth:`reset`)."""
        m = self._corrupt(self._stack(angles, flaps, airspeed), noise)
        nb = self.delay_steps + 1
        self._k = (self._k + 1) % nb
        self._buf[:, self._k] = m
        delayed = self._buf[:, (self._k - self.delay_steps) % nb]
        self._unpack(delayed, slice(None))
        diff = (self.angles - self._prev) / self.dt
        self.rates += self.alpha * (diff - self.rates)
        self._prev[:] = self.angles

    def observation(self) -> np.ndarray:
        """(n, obs_dim) normalised observation of the current measurements (layout in the module doc)."""
        a = self.angles
        parts = [
            a[:, ~self.unlimited] / ANGLE_SCALE,
            np.sin(a[:, self.unlimited]),
            np.cos(a[:, self.unlimited]),
            self.rates / self.rate_scale,
            self.flaps / FLAP_SCALE,
            self.airspeed[:, None] / AIRSPEED_SCALE,
        ]
        return np.clip(np.concatenate(parts, axis=1), self.low, self.high)

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
