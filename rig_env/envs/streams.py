"""Counter-based random streams: per-environment randomness without per-environment Python objects.

Every random number an environment uses is a pure function of

    (env_key, episode, step, stream, j)

hashed with SplitMix64 and turned into a uniform in [0, 1) (53 bits) or, by Box-Muller, a standard
normal.  ``env_key`` is derived from an integer seed exactly as :func:`env_keys` says: environment
``i`` of a batch reset with ``seed`` has the key of seed ``seed + i`` (the convention of
``gymnasium.vector.SyncVectorEnv``).  Hence environment ``i`` of a batch seeded with ``s`` draws the
same numbers as a batch of one seeded with ``s + i``, and a batch can be evaluated with numpy over all
environments at once.  ``episode`` counts resets of that environment since its seed; ``step`` counts
control steps within the episode; ``stream`` separates uses (initial state, reference, noise...).

The draws of a batch are numba kernels (one pass over the environments, no temporaries; compiled on
first use and cached on disk).  The logarithm of Box-Muller stays numpy's (its SIMD ``log`` differs
from the C library's in the last bit), so the numbers are bit-identical to the plain numpy formulas
(checked in ``tests/test_env_kernels.py``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

_JIT = {"cache": True, "error_model": "numpy", "_nrt": False}  # allocation-free kernels, compiled lazily
_JIT_PAR = {"cache": True, "error_model": "numpy", "parallel": True}  # numba parallelises prange only with NRT
PARALLEL_MIN = 256
"""From this many environments the draws are computed on all numba threads (the same numbers: each element
is computed alone); below it a parallel launch costs more than it saves."""

_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_GOLD = np.uint64(0x9E3779B97F4A7C15)
_C_EP = np.uint64(0xD1B54A32D192ED03)
_C_STEP = np.uint64(0xABC98388FB8FAC03)
_C_STREAM = np.uint64(0x8CB92BA72F3D8DD7)

# stream identifiers (any distinct integers)
S_PARAMS = 1
S_INITIAL = 2
S_REFERENCE = 3
S_SENSOR = 4
S_TURBULENCE = 5


def _mix(x: np.ndarray) -> np.ndarray:
    """SplitMix64 finaliser on a uint64 array (wrapping arithmetic)."""
    x = x ^ (x >> np.uint64(30))
    x = x * _M1
    x = x ^ (x >> np.uint64(27))
    x = x * _M2
    return x ^ (x >> np.uint64(31))


def env_keys(seed: int, n: int) -> np.ndarray:
    """(n,) uint64 keys of environments 0..n-1 of a batch seeded with ``seed`` (env i: seed + i)."""
    if not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed = {seed!r}: must be a non-negative integer")
    s = (np.arange(n, dtype=np.uint64) + np.uint64(int(seed) % (1 << 64)))
    with np.errstate(over="ignore"):
        return _mix(s * _GOLD + _GOLD)


def keys_of(seeds: np.ndarray) -> np.ndarray:
    """(m,) uint64 keys of arbitrary non-negative integer seeds: ``keys_of([s])`` equals ``env_keys(s, 1)``."""
    s = np.asarray(seeds)
    if s.ndim != 1 or s.dtype.kind not in "iu" or (s.size and s.min() < 0):
        raise ValueError("env_seeds: expected a 1-D array of non-negative integers")
    with np.errstate(over="ignore"):
        return _mix(s.astype(np.uint64) * _GOLD + _GOLD)


@njit(**_JIT)
def _mix1(x):
    """SplitMix64 finaliser of one uint64 (wrapping arithmetic); :func:`_mix` of a scalar."""
    x = x ^ (x >> np.uint64(30))
    x = x * _M1
    x = x ^ (x >> np.uint64(27))
    x = x * _M2
    return x ^ (x >> np.uint64(31))


@njit(**_JIT)
def _uniform_row(keys, episode, step, stream_code, j0, out, flip, i):
    """Row i of :func:`_uniform_kernel`."""
    h = _mix1(keys[i] ^ (episode[i] * _C_EP) ^ (step[i] * _C_STEP) ^ stream_code)
    for c in range(out.shape[1]):
        x = _mix1(h + np.uint64(j0 + c + 1) * _GOLD)
        u = np.float64(x >> np.uint64(11)) * (1.0 / 9007199254740992.0)
        out[i, c] = 1.0 - u if flip else u


@njit(**_JIT)
def _uniform_kernel(keys, episode, step, stream_code, j0, out, flip):
    """out[i, c] = uniform number j0 + c of environment i, in [0, 1) (53 bits); 1 - that with ``flip``.

    keys, episode, step: (m,) uint64; stream_code: uint64 (stream times its constant); out: (m, c) float64.
    Uniform j (0-based) of an environment is ``mix(mix(key ^ ep C_EP ^ step C_STEP ^ stream C_STREAM)
    + (j + 1) GOLD) >> 11`` times 2^-53.
    """
    for i in range(out.shape[0]):
        _uniform_row(keys, episode, step, stream_code, j0, out, flip, i)


@njit(**_JIT_PAR)
def _uniform_kernel_parallel(keys, episode, step, stream_code, j0, out, flip):
    """:func:`_uniform_kernel` on all numba threads."""
    for i in prange(out.shape[0]):
        _uniform_row(keys, episode, step, stream_code, j0, out, flip, i)


@njit(**_JIT)
def _box_muller_row(log_u1, u2, out, i):
    for c in range(out.shape[1]):
        out[i, c] = math.sqrt(-2.0 * log_u1[i, c]) * math.cos(2.0 * math.pi * u2[i, c])


@njit(**_JIT)
def _box_muller_kernel(log_u1, u2, out):
    """out = sqrt(-2 log_u1) cos(2 pi u2), elementwise over (m, k) arrays (log_u1 = log of a (0, 1] uniform)."""
    for i in range(out.shape[0]):
        _box_muller_row(log_u1, u2, out, i)


@njit(**_JIT_PAR)
def _box_muller_kernel_parallel(log_u1, u2, out):
    """:func:`_box_muller_kernel` on all numba threads."""
    for i in prange(out.shape[0]):
        _box_muller_row(log_u1, u2, out, i)


def _counters(keys: np.ndarray, episode: np.ndarray | int, step: np.ndarray | int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """keys, episode, step as (m,) contiguous uint64 arrays (scalars broadcast)."""
    keys = np.ascontiguousarray(keys, dtype=np.uint64)
    m = keys.shape[0]
    ep = np.asarray(episode)
    st = np.asarray(step)
    ep = np.full(m, ep, dtype=np.uint64) if ep.ndim == 0 else np.ascontiguousarray(ep, dtype=np.uint64)
    st = np.full(m, st, dtype=np.uint64) if st.ndim == 0 else np.ascontiguousarray(st, dtype=np.uint64)
    return keys, ep, st


def uniform(keys: np.ndarray, episode: np.ndarray, step: np.ndarray | int, stream: int, k: int) -> np.ndarray:
    """(m, k) uniforms in [0, 1) for m environments (keys, episode, step of shape (m,) or scalar)."""
    keys, ep, st = _counters(keys, episode, step)
    out = np.empty((keys.shape[0], k))
    with np.errstate(over="ignore"):
        code = np.uint64(stream) * _C_STREAM
    (_uniform_kernel_parallel if keys.shape[0] >= PARALLEL_MIN else _uniform_kernel)(keys, ep, st, code, 0, out, False)
    return out


def normal(keys: np.ndarray, episode: np.ndarray, step: np.ndarray | int, stream: int, k: int) -> np.ndarray:
    """(m, k) standard normals: Box-Muller ``sqrt(-2 log(1 - u_j)) cos(2 pi u_{k+j})`` on 2k uniforms of the stream."""
    keys, ep, st = _counters(keys, episode, step)
    m = keys.shape[0]
    with np.errstate(over="ignore"):
        code = np.uint64(stream) * _C_STREAM
    log_u1, out = np.empty((m, k)), np.empty((m, k))
    par = m >= PARALLEL_MIN
    uniform_kernel = _uniform_kernel_parallel if par else _uniform_kernel
    uniform_kernel(keys, ep, st, code, 0, log_u1, True)  # 1 - u in (0, 1]
    uniform_kernel(keys, ep, st, code, k, out, False)
    np.log(log_u1, out=log_u1)
    (_box_muller_kernel_parallel if par else _box_muller_kernel)(log_u1, out, out)
    return out
