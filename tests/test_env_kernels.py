"""The environments' numba bookkeeping kernels against the plain numpy formulas they replaced.

Each reference below is written out independently with numpy (vectorised over the batch, as the
environment computed it before the kernels), and the kernels must give the same bits: the random
streams (SplitMix64 + Box-Muller), the sensor chain, the step metrics, the stop flags, the control
cost and the action clip.  Sizes include 1 (the scalar environment) and batches with NaN rows.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rig_env.envs import RigVectorEnv
from rig_env.envs import streams as rs
from rig_env.envs.metrics import StepMetrics
from rig_env.envs.sensors import AIRSPEED_SCALE, ANGLE_SCALE, FLAP_SCALE, Sensors
from rig_env.envs.tasks import VelocityVectorRoll
from rig_env.envs.tasks.base import STOP_MARGIN
from rig_env.envs.vector_env import _command_inputs, _episode_ends
from rig_env.params import JOINTS, RigParams, param_batch
from rig_env.physics import layout as L

# ---------------------------------------------------------------------------------------------- streams
_M1, _M2, _GOLD = np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB), np.uint64(0x9E3779B97F4A7C15)


def _mix_np(x: np.ndarray) -> np.ndarray:
    """SplitMix64 finaliser (Steele, Lea & Flood 2014; the constants of Vigna's splitmix64.c)."""
    x = x ^ (x >> np.uint64(30))
    x = x * _M1
    x = x ^ (x >> np.uint64(27))
    x = x * _M2
    return x ^ (x >> np.uint64(31))


def _uniform_np(keys, episode, step, stream, k):
    with np.errstate(over="ignore"):
        base = (keys.astype(np.uint64) ^ (np.asarray(episode, dtype=np.uint64) * rs._C_EP)
                ^ (np.asarray(step, dtype=np.uint64) * rs._C_STEP) ^ (np.uint64(stream) * rs._C_STREAM))
        x = _mix_np(_mix_np(base)[:, None] + (np.arange(1, k + 1, dtype=np.uint64) * _GOLD)[None, :])
    return (x >> np.uint64(11)).astype(np.float64) * 2.0**-53


def _normal_np(keys, episode, step, stream, k):
    u = _uniform_np(keys, episode, step, stream, 2 * k)
    return np.sqrt(-2.0 * np.log(1.0 - u[:, :k])) * np.cos(2.0 * np.pi * u[:, k:])


@pytest.mark.parametrize("n", [1, 5, 1024, rs.NORMAL_PARALLEL_MIN + 3])
def test_streams_equal_the_numpy_splitmix_box_muller(n):
    """Uniforms bit for bit; normals (vmath's log and cos) to 3e-15: 2 ulp of a cosine times the largest
    radius sqrt(-2 ln 2^-53) = 8.6 plus the radius' own rounding.  The largest batch takes the parallel
    kernel, whose blocks must not change any number."""
    keys = rs.env_keys(12345, n)
    episode = np.arange(n, dtype=np.uint64) % 4
    step = (np.arange(n) * 7) % 640
    for stream in (rs.S_PARAMS, rs.S_SENSOR, rs.S_TURBULENCE):
        for k in (1, 3, 9):
            np.testing.assert_array_equal(rs.uniform(keys, episode, step, stream, k), _uniform_np(keys, episode, step, stream, k))
            np.testing.assert_array_equal(rs.uniform(keys, episode, 0, stream, k), _uniform_np(keys, episode, 0, stream, k))
            z = rs.normal(keys, episode, step, stream, k)
            assert z.shape == (n, k) and z.T.flags.c_contiguous  # channel-major: Sensors.update reads it without a copy
            np.testing.assert_allclose(z, _normal_np(keys, episode, step, stream, k), rtol=0.0, atol=3e-15)
            np.testing.assert_array_equal(z[-1:], rs.normal(keys[-1:], episode[-1:], step[-1:], stream, k))  # alone = in a batch


def test_stream_keys_take_64_bit_seeds_and_refuse_wrapping():
    """env_keys(seed, n) is for seed + n - 1 < 2**64; beyond, a ValueError (it wrapped to seed 0's key)."""
    top = rs.env_keys(2**64 - 2, 2)
    assert top[1] == rs.env_keys(2**64 - 1, 1)[0] != rs.env_keys(0, 1)[0]
    for seed, n in ((2**64, 1), (2**64 - 1, 2), (-1, 1), (True, 1)):
        with pytest.raises(ValueError, match=r"seed = .*: must be an integer in \[0, 2\*\*64 - "):
            rs.env_keys(seed, n)


def test_normal_draws_are_standard_normal():
    z = rs.normal(rs.env_keys(7, 20000), np.zeros(20000, dtype=np.uint64), 3, rs.S_SENSOR, 10).ravel()
    assert abs(z.mean()) < 4.0 / math.sqrt(z.size)  # 4 standard errors
    assert abs(z.std() - 1.0) < 0.01
    assert abs(np.mean(z**4) - 3.0) < 0.05  # kurtosis of a normal


# ---------------------------------------------------------------------------------------------- sensors
def _sensor_chain_np(s: Sensors, raws, noises, delay):
    """Corrupt, delay, rate filter and normalise with numpy over the batch; observations per step."""
    nj = len(s.joints)
    q = s.lsb > 0
    hist, prev, rates, out = [], None, None, []
    for raw, noise in zip(raws, noises):
        m = raw + s.sigma * noise
        m[:, q] = np.round(m[:, q] / s.lsb[q]) * s.lsb[q]
        if not hist:
            hist = [m] * (delay + 1)
            prev, rates = m[:, :nj].copy(), np.zeros((m.shape[0], nj))
            cur = m
        else:
            hist = hist[1:] + [m]
            cur = hist[0]
            rates = rates + s.alpha * ((cur[:, :nj] - prev) / s.dt - rates)
            prev = cur[:, :nj].copy()
        a = cur[:, :nj]
        obs = np.concatenate([a[:, ~s.unlimited] / ANGLE_SCALE, np.sin(a[:, s.unlimited]), np.cos(a[:, s.unlimited]),
                              rates / s.rate_scale, cur[:, nj : nj + 4] / FLAP_SCALE, cur[:, nj + 4 :] / AIRSPEED_SCALE], axis=1)
        out.append(np.clip(obs, s.low, s.high))
    return out


@pytest.mark.parametrize("n", [1, 64])
@pytest.mark.parametrize("delay", [0, 2])
def test_sensors_equal_the_numpy_chain(n, delay):
    joints = ("rig_roll", "rig_pitch", "model_pitch", "model_yaw")
    s = Sensors(n, joints, 1 / 80, rate_filter_hz=10.0, delay_steps=delay, angle_noise=np.radians(0.05),
                flap_noise=np.radians(0.05), airspeed_noise=0.1, quantise=True)
    rng = np.random.default_rng(3)
    raws = [np.concatenate([rng.uniform(-4, 4, (n, 4)), rng.uniform(-0.8, 0.8, (n, 4)), rng.uniform(15, 70, (n, 1))], axis=1)
            for _ in range(8)]
    raws[5][0, 1] = np.nan  # a blown-up environment: NaN flows through, not clipped
    noises = [rng.standard_normal((n, s.n_channels)) for _ in range(8)]
    expected = _sensor_chain_np(s, raws, noises, delay)
    n_lim, n_unl = int(np.sum(~s.unlimited)), int(np.sum(s.unlimited))
    trig = np.zeros(s.obs_dim, dtype=bool)
    trig[n_lim : n_lim + 2 * n_unl] = True  # the unlimited joints' sine and cosine columns
    idx = np.arange(n)
    for k, (raw, noise) in enumerate(zip(raws, noises)):
        if k == 0:
            s.reset(idx, raw[:, :4], raw[:, 4:8], raw[:, 8], noise)
        else:
            s.update(raw[:, :4], raw[:, 4:8], raw[:, 8], noise)
        got = s.observation()
        np.testing.assert_array_equal(got[:, ~trig], expected[k][:, ~trig])
        np.testing.assert_allclose(got[:, trig], expected[k][:, trig], rtol=0.0, atol=2.3e-16)  # vmath.sincos vs numpy: 2 ulp
        out32 = np.zeros((n, s.obs_dim + 2), dtype=np.float32)
        s.observation(out=out32[:, : s.obs_dim])
        np.testing.assert_array_equal(out32[:, : s.obs_dim][:, ~trig], expected[k][:, ~trig].astype(np.float32))
        # the cast of a value within 2 ulp may round to the neighbouring float32: at most one float32 ulp of [-1, 1]
        np.testing.assert_allclose(out32[:, : s.obs_dim][:, trig], expected[k][:, trig].astype(np.float32), rtol=0.0, atol=6e-8)
    assert np.isnan(expected[-1][0]).any()  # the NaN row was compared too (the rate filter keeps it)


def test_sensors_without_noise_or_quantisation_pass_the_signal():
    s = Sensors(3, ("rig_roll",), 0.01, delay_steps=0, quantise=False)
    a = np.array([[0.1], [0.2], [-0.3]])
    s.reset(np.arange(3), a, np.zeros((3, 4)), np.full(3, 20.0))
    s.update(a + 0.01, np.zeros((3, 4)), np.full(3, 20.0))
    np.testing.assert_array_equal(s.angles, a + 0.01)
    np.testing.assert_allclose(s.rates, s.alpha * 0.01 / 0.01, rtol=1e-12)  # one filtered step of a 1 rad/s difference


# ---------------------------------------------------------------------------------------------- metrics
class _MetricsNp(StepMetrics):
    """StepMetrics with the per-step accounting written as the numpy formulas of its docstring."""

    def update(self, t, seg, y, r, err, band_abs, action, prev_action, violation):
        new = seg != self.seg
        if np.any(new):
            idx = np.flatnonzero(new)
            self._close(idx, t - self.dt)
            self.seg[idx] = seg[idx]
            self.y0[idx], self.r[idx], self.t0[idx] = y[idx], r[idx], t[idx] - self.dt
            self.t10[idx] = self.t90[idx] = np.nan
            self.t_out[idx] = t[idx] - self.dt
            self.peak[idx] = -np.inf
        self.r = np.where(seg >= 0, r, self.r)
        d = self.r - self.y0
        frac = np.where(np.abs(d) > 1e-12, (y - self.y0) / np.where(d == 0, 1.0, d), 1.0)
        self.t10 = np.where(np.isnan(self.t10) & (frac >= 0.1), t, self.t10)
        self.t90 = np.where(np.isnan(self.t90) & (frac >= 0.9), t, self.t90)
        self.t_out = np.where(np.abs(y - self.r) > np.maximum(0.05 * np.abs(d), band_abs), t, self.t_out)
        self.peak = np.maximum(self.peak, np.sign(d) * (y - self.r))
        self.err2 += err**2
        self.a2 += np.mean(action**2, axis=1)
        self.da2 += np.mean(((action - prev_action) / self.dt) ** 2, axis=1)
        self.viol += violation
        self.n += 1


@pytest.mark.parametrize("n", [1, 50])
def test_metrics_kernel_equals_the_numpy_formulas(n):
    dt = 1 / 80
    rng = np.random.default_rng(5)
    fast, ref = StepMetrics(n, dt), _MetricsNp(n, dt)
    for m in (fast, ref):
        m.reset(np.arange(n))
    prev = np.zeros((n, 3))
    target = rng.uniform(-1, 1, n)
    for k in range(1, 300):
        t = np.full(n, k * dt)
        seg = np.where(t < 0.5, -1, (t // 1.0).astype(np.int64))  # new segments every second
        y = target * (1 - np.exp(-3 * (t % 1.0))) + 0.02 * rng.standard_normal(n)  # a step response with noise
        if k == 120:
            y[0] = np.nan  # a blown-up environment
        r = np.where(seg % 2 == 0, target, -target)
        a = rng.uniform(-1, 1, (n, 3))
        args = (t, seg, y, r, 30 * (r - y), np.full(n, 0.02), a, prev, rng.random(n) < 0.1)
        fast.update(*args)
        ref.update(*args)
        prev = a
    idx = np.arange(n)
    got, want = fast.finish(idx, t), ref.finish(idx, t)
    for key in want:
        np.testing.assert_array_equal(got[key], want[key], err_msg=key)
    assert np.isfinite(want["rise_time"][1:]).all() and want["segments"][-1] >= 3  # the comparison saw real segments


# ---------------------------------------------------------------------------------------------- task and action kernels
def test_stop_flags_and_control_cost_equal_the_numpy_formulas():
    n = 400
    rng = np.random.default_rng(9)
    P = param_batch(RigParams.default(), n)
    free = ("rig_roll", "rig_pitch", "rig_yaw", "model_pitch", "model_yaw")
    task = VelocityVectorRoll(n, free, 1 / 80, 8.0)  # limits and the control cost are the base class's
    q = rng.uniform(-1.5, 1.5, (n, 5))
    q[0, 1] = np.nan
    on, beyond = task.limits(q, P)
    on_np, beyond_np = np.zeros(n, bool), np.zeros(n, bool)
    for j in ("rig_pitch", "rig_yaw", "model_pitch"):
        c, jj = getattr(L, f"P_STOPS_{j.upper()}_LOWER_DEG"), JOINTS.index(j)
        lo, hi = P[:, c], P[:, c + 1]
        on_np |= (q[:, jj] <= lo) | (q[:, jj] >= hi)
        beyond_np |= (q[:, jj] < lo - STOP_MARGIN) | (q[:, jj] > hi + STOP_MARGIN)
    np.testing.assert_array_equal(on, on_np)
    np.testing.assert_array_equal(beyond, beyond_np)
    assert 0 < on.sum() < n and 0 < beyond.sum() < on.sum()  # both outcomes occur
    # the control cost (tasks/base.py's docstring): 0.05 a^2 + 0.3 ((|a| - knee) / (1 - knee))^2 above the knee, per
    # action, plus RATE_WEIGHT m, the command activity m advanced each step by alpha (sum ((a - a_prev) / (RATE_SCALE dt))^2 - m)
    from rig_env.envs.tasks import base as tb

    dt = 1 / 80
    for k in (3, 6):
        task = VelocityVectorRoll(n, free, dt, 8.0)
        m = np.zeros(n)
        a_prev = rng.uniform(-1, 1, (n, k))
        for _ in range(3):
            a = rng.uniform(-1.2, 1.2, (n, k))
            sat = np.maximum(np.abs(a) - tb.SAT_KNEE, 0.0) / (1.0 - tb.SAT_KNEE)
            m = m + (dt / tb.RATE_TAU) * (np.sum(((a - a_prev) / (tb.RATE_SCALE * dt)) ** 2, axis=1) - m)
            expected = np.sum(0.25 * a**2 + 0.3 * sat**2, axis=1) + tb.RATE_WEIGHT * m  # the docstring's weights
            np.testing.assert_allclose(task._control_cost(a, a_prev), expected, rtol=1e-12, atol=1e-14)
            a_prev = a


def test_actions_are_clipped_as_np_clip_and_non_finite_rejected():
    env = RigVectorEnv(4)
    a = np.array([[0.5, -3.0, 2.0], [-0.0, 1.0, -1.0], [0.25, 1.5, -7.0], [1e-300, -1e300, 0.999]])
    np.testing.assert_array_equal(env.check_actions(a), np.clip(a, -1.0, 1.0))
    a[2, 1] = np.inf
    with pytest.raises(ValueError, match=r"environment\(s\) \[2\]"):
        env.check_actions(a)


@pytest.mark.parametrize("k", [3, 6])
def test_command_inputs_equal_the_numpy_formula(k):
    n = 40
    rng = np.random.default_rng(11)
    a, pilot = rng.uniform(-1, 1, (n, k)), rng.uniform(-0.2, 0.2, (n, 3))
    U = rng.standard_normal((n, L.N_INPUTS))
    want = U.copy()
    want[:, :k] = np.radians(40.0) * a
    hawk = slice(L.U_HAWK_ELEVATOR, L.U_HAWK_ELEVATOR + 3)
    want[:, hawk] = pilot + (want[:, hawk] if k > 3 else 0.0)
    _command_inputs(a, pilot, math.radians(40.0), U)
    np.testing.assert_array_equal(U, want)


def test_episode_ends_equal_the_numpy_formula():
    n = 200
    rng = np.random.default_rng(13)
    status = rng.choice(np.array([L.S_OK, L.S_OK, L.S_OK, 1, 2], dtype=np.int8), n)
    beyond = rng.random(n) < 0.2
    steps = rng.integers(600, 660, n)
    reward = rng.random(n)
    te, tr, r = np.empty(n, bool), np.empty(n, bool), np.empty(n)
    any_done = _episode_ends(status, beyond, steps, 640, reward, te, tr, r)
    te_np = (status != L.S_OK) | beyond
    np.testing.assert_array_equal(te, te_np)
    np.testing.assert_array_equal(tr, (steps >= 640) & ~te_np)
    np.testing.assert_array_equal(r, np.where(te_np, 0.0, reward))
    assert any_done and te.any() and tr.any() and not (te & tr).any()
    assert not _episode_ends(np.zeros(3, np.int8), np.zeros(3, bool), np.zeros(3, np.int64), 640, np.ones(3), te[:3], tr[:3], r[:3])


def test_roll_reference_kernel_equals_the_numpy_profile():
    """VelocityVectorRoll.reference against the profile written with numpy clips, on a grid with every phase boundary."""
    n = 64
    task = VelocityVectorRoll(n, ("rig_roll", "model_pitch"), 1 / 80, 8.0)
    rng = np.random.default_rng(17)
    task.reset(np.arange(n), rng.random((n, task.n_draws)))
    Ts, Tr, Th, Td, R, phi0 = task.T_START, task.T_RAMP, task.Th, task.Td, task.R, task.phi0
    t1 = Ts + Tr + Th
    times = [np.full(n, x) for x in (0.0, 0.25, 0.5, 0.75, 1.0, 7.9)] + [t1, t1 - 0.01, t1 + 0.5 * Td, t1 + Td, t1 + Td + 1.0]
    for t in times:
        s1, s2, s3 = np.clip(t - Ts, 0.0, Tr), np.clip(t - Ts - Tr, 0.0, Th), np.clip(t - t1, 0.0, Td)
        phi = phi0 + R * (s1**2 / (2 * Tr) + s2 + s3 - s3**2 / (2 * Td))
        p = R * np.where(t < Ts + Tr, s1 / Tr, np.where(t < t1, 1.0, 1.0 - s3 / Td))
        np.testing.assert_array_equal(task.reference(t), np.stack([phi, p], axis=1))
    # the stop: the angle reference ends at the documented stop angle, the rate at 0
    end = task.reference(t1 + Td + 1.0)
    np.testing.assert_allclose(end[:, 0], phi0 + R * (0.25 + Th + Td / 2), rtol=1e-13, atol=1e-13)
    np.testing.assert_array_equal(end[:, 1], 0.0)


def test_roll_observation_and_tracked_kernels_equal_the_numpy_formulas():
    n = 300
    free = ("rig_roll", "model_pitch")
    task = VelocityVectorRoll(n, free, 1 / 80, 8.0)
    rng = np.random.default_rng(19)
    task.reset(np.arange(n), rng.random((n, task.n_draws)))
    D = math.pi / 180.0
    t = rng.choice(np.arange(0, 641) / 80.0, n)
    t[:3] = (0.5, task.T_START + task.T_RAMP + task.Th[3], 7.0)
    q, qd = rng.uniform(-4, 4, (n, 5)), rng.uniform(-8, 8, (n, 5))
    ref = task.reference(t)
    angles, rates = q[:, [0, 3]] + rng.normal(0, 0.5, (n, 2)), qd[:, [0, 3]] * 3.0  # some entries beyond the +-5 bounds
    rates[0, 0] = np.nan
    e = (ref[:, 0] - angles[:, 0]) / (45.0 * D)
    ep = (ref[:, 1] - rates[:, 0]) / 12.0
    want = np.clip(np.stack([e, ref[:, 1] / 12.0, ep], axis=1), task.obs_low, task.obs_high)
    got = task.observation(ref, angles, rates)
    np.testing.assert_array_equal(got, want)
    assert np.isnan(got[0, 2]) and (np.abs(got[1:]) == 5.0).any()  # NaN kept, bounds reached
    t1 = task.T_START + task.T_RAMP + task.Th
    seg = np.where(t <= task.T_START, -1, np.where(t <= t1, 0, 1))
    stop = task.phi0 + task.R * (0.5 * task.T_RAMP + task.Th + 0.5 * task.Td)
    want = (seg, np.where(seg == 0, qd[:, 0], q[:, 0]), np.where(seg == 0, task.R, stop), (ref[:, 0] - q[:, 0]) / D,
            np.where(seg == 0, 5.0 * D, 2.0 * D))
    for g, w in zip(task.tracked(t, q, qd, ref), want):
        np.testing.assert_array_equal(g, w)
    assert set(np.unique(seg)) == {-1, 0, 1}
