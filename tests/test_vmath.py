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
