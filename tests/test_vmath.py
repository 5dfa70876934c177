"""rig_env.physics.vmath against the C library (Python's math module): accuracy in units in the last
place, every branch of the range reduction and quadrant, and special values."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

from rig_env.physics import vmath as V


@njit(cache=True)
def _atan_all(x, out):
    for i in range(x.size):
        out[i] = V.atan(x[i])


@njit(cache=True)
def _atan2_all(y, x, out):
    for i in range(x.size):
        out[i] = V.atan2(y[i], x[i])


def ulps(got: np.ndarray, ref: np.ndarray) -> float:
    """Largest error in units in the last place of the reference."""
    return float(np.max(np.abs(got - ref) / np.spacing(np.maximum(np.abs(ref), np.finfo(float).tiny))))


def ref(f, *xs) -> np.ndarray:
    return np.array([f(*v) for v in zip(*xs)])


RNG = np.random.default_rng(12)


def test_atan_within_one_ulp():
    x = np.concatenate([RNG.standard_cauchy(100_000), RNG.uniform(-3.0, 3.0, 50_000), [0.66, -0.66, V._T3P8, -V._T3P8, 1.0, -1.0]])
    out = np.empty_like(x)
    _atan_all(x, out)
    assert ulps(out, ref(math.atan, x)) <= 1.0


def test_atan_special_values():
    x = np.array([0.0, np.inf, -np.inf, 1e300, np.nan])
    out = np.empty_like(x)
    _atan_all(x, out)
    assert out[0] == 0.0 and out[1] == math.pi / 2 and out[2] == -math.pi / 2 and out[3] == math.pi / 2
    assert np.isnan(out[4])


def test_atan2_every_quadrant_within_two_ulp():
    y, x = RNG.standard_normal(100_000), RNG.standard_normal(100_000)
    y[:8] = [1.0, -1.0, 0.0, 2.0, -2.0, 0.0, 3.0, -3.0]
    x[:8] = [0.0, 0.0, 1.0, -1.0, -1.0, -5.0, 3.0, -3.0]
    out = np.empty_like(x)
    _atan2_all(y, x, out)
    assert ulps(out, ref(math.atan2, y, x)) <= 2.0
    z = np.zeros(1)
    _atan2_all(z, z, out[:1])
    assert out[0] == 0.0


def test_atan2_over_the_whole_exponent_range_and_special_values():
    # reduced from abs(y), abs(x) directly: no overflow or underflow of y / x at extreme ratios
    y = RNG.standard_normal(50_000) * 10.0 ** RNG.uniform(-300, 300, 50_000)
    x = RNG.standard_normal(50_000) * 10.0 ** RNG.uniform(-300, 300, 50_000)
    out = np.empty_like(x)
    _atan2_all(y, x, out)
    assert ulps(out, ref(math.atan2, y, x)) <= 2.0
    y = np.array([np.nan, 1.0, np.nan, 0.0, -0.0, 0.0, 1e-320, 5.0])
    x = np.array([1.0, np.nan, np.nan, -2.0, -2.0, 0.0, 1e-320, 5.0 / V._T3P8])
    out = np.empty_like(x)
    _atan2_all(y, x, out)
    assert np.all(np.isnan(out[:3]))
    assert out[3] == math.pi and out[4] == math.pi and out[5] == 0.0  # documented: atan2(+-0, x < 0) = +pi
    assert ulps(out[6:], ref(math.atan2, y[6:], x[6:])) <= 2.0


@njit(cache=True)
def _sincos_all(x, s, c):
    for i in range(x.size):
        s[i], c[i] = V.sincos(x[i])


@njit(cache=True)
def _exp_all(x, out, out_m1):
    for i in range(x.size):
        out[i] = V.exp(x[i])
        out_m1[i] = V.expm1(x[i])


@njit(cache=True)
def _asin_all(x, out):
    for i in range(x.size):
        out[i] = V.asin(x[i])


@pytest.mark.parametrize("hi", [1.0, 10.0, 1e3, 1e6, 1e9])
def test_sincos_within_two_ulp_and_2e16_absolute(hi):
    x = RNG.uniform(-hi, hi, 50_000)
    s, c = np.empty_like(x), np.empty_like(x)
    _sincos_all(x, s, c)
    rs, rc = ref(math.sin, x), ref(math.cos, x)
    assert np.max(np.abs(s - rs)) <= 2.3e-16 and np.max(np.abs(c - rc)) <= 2.3e-16
    away = (np.abs(rs) > 1e-3) & (np.abs(rc) > 1e-3)  # relative error near a zero measures the argument's rounding
    assert ulps(s[away], rs[away]) <= 2.0 and ulps(c[away], rc[away]) <= 2.0


def test_sincos_at_the_octant_boundaries_and_special_values():
    x = np.concatenate([np.arange(-400, 401) * (math.pi / 4), [0.0, -0.0, 1e-300, 2.0**30, -(2.0**30)]])
    s, c = np.empty_like(x), np.empty_like(x)
    _sincos_all(x, s, c)
    assert np.max(np.abs(s - ref(math.sin, x))) <= 2.3e-16
    assert np.max(np.abs(c - ref(math.cos, x))) <= 2.3e-16
    x = np.array([np.nan, np.inf, -np.inf])
    s, c = np.empty_like(x), np.empty_like(x)
    _sincos_all(x, s, c)
    assert np.all(np.isnan(s)) and np.all(np.isnan(c))


def test_exp_within_two_ulp_and_expm1_within_four_over_their_range():
    x = np.concatenate([RNG.uniform(-708.0, 709.0, 100_000), RNG.uniform(-1.0, 1.0, 50_000), RNG.uniform(-1e-8, 1e-8, 1000), [0.5, -0.5, 0.0]])
    out, out_m1 = np.empty_like(x), np.empty_like(x)
    _exp_all(x, out, out_m1)
    assert ulps(out, ref(math.exp, x)) <= 2.0
    assert ulps(out_m1, ref(math.expm1, x)) <= 4.0


def test_exp_ends_and_special_values():
    x = np.array([-800.0, -708.5, 709.9, 800.0, np.inf, -np.inf, np.nan, 0.0])
    out, out_m1 = np.empty_like(x), np.empty_like(x)
    _exp_all(x, out, out_m1)
    assert out[0] == 0.0 and out[1] == 0.0 and out[2] == np.inf and out[3] == np.inf
    assert out[4] == np.inf and out[5] == 0.0 and np.isnan(out[6]) and out[7] == 1.0
    assert out_m1[0] == -1.0 and out_m1[5] == -1.0 and out_m1[4] == np.inf and np.isnan(out_m1[6]) and out_m1[7] == 0.0


def test_asin_within_three_ulp():
    x = np.concatenate([RNG.uniform(-1.0, 1.0, 100_000), [1.0, -1.0, 0.0, 0.5, -0.999999]])
    out = np.empty_like(x)
    _asin_all(x, out)
    assert ulps(out, ref(math.asin, x)) <= 3.0


@njit(cache=True)
def _log_all(x, out):
    for i in range(x.size):
        out[i] = V.log(x[i])


def test_log_within_one_ulp_and_special_values():
    x = np.concatenate([
        RNG.uniform(0.0, 1.0, 100_000), 1.0 - np.arange(1, 1000) * 2.0**-53, 2.0 ** -np.arange(0.0, 54.0),
        10.0 ** RNG.uniform(-300, 300, 100_000), [1.0, 0.5, 2.0, V._SQRTH, np.nextafter(V._SQRTH, 0.0), np.finfo(float).tiny],
    ])  # fmt: skip
    out = np.empty_like(x)
    _log_all(x, out)
    assert ulps(out, ref(math.log, x)) <= 1.0
    x = np.array([0.0, -0.0, -1.0, np.inf, -np.inf, np.nan])
    out = np.empty_like(x)
    _log_all(x, out)
    assert out[0] == -np.inf and out[1] == -np.inf and np.isnan(out[2]) and out[3] == np.inf and np.isnan(out[4]) and np.isnan(out[5])
