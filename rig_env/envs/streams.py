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
first use and cached on disk).  The uniforms are bit-identical to the plain numpy formulas.  The
normals' logarithm and cosine are :mod:`rig_env.physics.vmath`'s (1 and 2 ulp of the C library's),
so that the loop over the environments runs in SIMD lanes, generation and Box-Muller in one pass:
they agree with numpy's formula to 1e-15 (both checked in ``tests/test_env_kernels.py``).
"""

from __future__ import annotations

import math

import numpy as np

from rig_env.physics import vmath
from rig_env.physics.jit import kernel, prange

_JIT = {"cache": True, "error_model": "numpy", "_nrt": False}  # allocation-free kernels, compiled lazily
_JIT_PAR = {"cache": True, "error_model": "numpy", "parallel": True}  # numba parallelises prange only with NRT
_JIT_VEC = dict(_JIT, fastmath=vmath.FASTMATH)  # the normals' loop: vectorised (LLVM needs the fast-math flags)
_JIT_VEC_PAR = dict(_JIT_PAR, fastmath=vmath.FASTMATH)
NORMAL_BLOCK = 512
"""Environments per block of the normals' kernel (each block one task of the parallel twin)."""
NORMAL_PARALLEL_MIN = 8192
"""From this many environments the normals are drawn on all numba threads (below, one vectorised pass
costs less than a parallel launch)."""
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
    """(n,) uint64 keys of environments 0..n-1 of a batch seeded with ``seed`` (env i: seed + i), ``seed`` in
    ``[0, 2**64 - n]`` (so that every seed + i is 64-bit; ValueError otherwise, never a wrap)."""
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or not 0 <= int(seed) <= (1 << 64) - n:
        raise ValueError(f"seed = {seed!r}: must be an integer in [0, 2**64 - {n}] ({(1 << 64) - n})")
    s = (np.arange(n, dtype=np.uint64) + np.uint64(int(seed)))
    with np.errstate(over="ignore"):
        return _mix(s * _GOLD + _GOLD)


def keys_of(seeds: np.ndarray) -> np.ndarray:
    """(m,) uint64 keys of arbitrary non-negative integer seeds: ``keys_of([s])`` equals ``env_keys(s, 1)``."""
    s = np.asarray(seeds)
    if s.ndim != 1 or s.dtype.kind not in "iu" or (s.size and s.min() < 0):
        raise ValueError("env_seeds: expected a 1-D array of non-negative integers")
    with np.errstate(over="ignore"):
        return _mix(s.astype(np.uint64) * _GOLD + _GOLD)


@kernel(**_JIT)
def _mix1(x):
    """SplitMix64 finaliser of one uint64 (wrapping arithmetic); :func:`_mix` of a scalar."""
    x = x ^ (x >> np.uint64(30))
    x = x * _M1
    x = x ^ (x >> np.uint64(27))
    x = x * _M2
    return x ^ (x >> np.uint64(31))


@kernel(**_JIT)
def _uniform_row(keys, episode, step, stream_code, j0, out, flip, i):
    """Row i of :func:`_uniform_kernel`."""
    h = _mix1(keys[i] ^ (episode[i] * _C_EP) ^ (step[i] * _C_STEP) ^ stream_code)
    for c in range(out.shape[1]):
        x = _mix1(h + np.uint64(j0 + c + 1) * _GOLD)
        u = np.float64(x >> np.uint64(11)) * (1.0 / 9007199254740992.0)
        out[i, c] = 1.0 - u if flip else u


@kernel(**_JIT)
def _uniform_kernel(keys, episode, step, stream_code, j0, out, flip):
    """out[i, c] = uniform number j0 + c of environment i, in [0, 1) (53 bits); 1 - that with ``flip``.

    keys, episode, step: (m,) uint64; stream_code: uint64 (stream times its constant); out: (m, c) float64.
    Uniform j (0-based) of an environment is ``mix(mix(key ^ ep C_EP ^ step C_STEP ^ stream C_STREAM)
    + (j + 1) GOLD) >> 11`` times 2^-53.
    """
    for i in range(out.shape[0]):
        _uniform_row(keys, episode, step, stream_code, j0, out, flip, i)


@kernel(**_JIT_PAR)
def _uniform_kernel_parallel(keys, episode, step, stream_code, j0, out, flip):
    """:func:`_uniform_kernel` on all numba threads."""
    for i in prange(out.shape[0]):
        _uniform_row(keys, episode, step, stream_code, j0, out, flip, i)


@kernel(**_JIT_VEC)
def _normal_block(keys, episode, step, stream_code, outT, hbuf, i0, i1):
    """outT[c, i] for environments i0 <= i < i1: ``sqrt(-2 log(1 - u_c)) cos(2 pi u_{k+c})`` with u_j the
    environment's uniform j (:func:`_uniform_kernel`'s); hbuf: (NORMAL_BLOCK,) uint64 scratch for the
    environments' hashes.  c outermost, so the loop over the environments is innermost and runs in SIMD lanes (uint64
    hashing, the conversion, vmath's log and cos); the 53-bit integers convert as signed (exact, and one
    instruction where unsigned takes several)."""
    k = outT.shape[0]
    for i in range(i0, i1):
        hbuf[i - i0] = _mix1(keys[i] ^ (episode[i] * _C_EP) ^ (step[i] * _C_STEP) ^ stream_code)
    for c in range(k):
        g1 = np.uint64(c + 1) * _GOLD
        g2 = np.uint64(k + c + 1) * _GOLD
        for i in range(i0, i1):
            h = hbuf[i - i0]
            u1 = 1.0 - np.float64(np.int64(_mix1(h + g1) >> np.uint64(11))) * (1.0 / 9007199254740992.0)  # (0, 1]
            u2 = np.float64(np.int64(_mix1(h + g2) >> np.uint64(11))) * (1.0 / 9007199254740992.0)
            outT[c, i] = math.sqrt(-2.0 * vmath.log(u1)) * vmath.sincos(2.0 * math.pi * u2)[1]


@kernel(**_JIT_VEC)
def _normal_kernel(keys, episode, step, stream_code, outT, hbuf):
    """outT (k, m): the k standard normals of each of m environments (see :func:`normal`); hbuf: (1,
    NORMAL_BLOCK) uint64 scratch, reused by every block."""
    m = outT.shape[1]
    for b in range((m + NORMAL_BLOCK - 1) // NORMAL_BLOCK):
        _normal_block(keys, episode, step, stream_code, outT, hbuf[0], b * NORMAL_BLOCK, min(m, (b + 1) * NORMAL_BLOCK))


@kernel(**_JIT_VEC_PAR)
def _normal_kernel_parallel(keys, episode, step, stream_code, outT, hbuf):
    """:func:`_normal_kernel` with the blocks on all numba threads; hbuf: (n_blocks, NORMAL_BLOCK), a row per block."""
    m = outT.shape[1]
    for b in prange((m + NORMAL_BLOCK - 1) // NORMAL_BLOCK):
        _normal_block(keys, episode, step, stream_code, outT, hbuf[b], b * NORMAL_BLOCK, min(m, (b + 1) * NORMAL_BLOCK))


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
    """(m, k) standard normals: Box-Muller ``sqrt(-2 log(1 - u_j)) cos(2 pi u_{k+j})`` on 2k uniforms of the stream.

    The array is the transpose of the (k, m) array the kernel fills (Fortran order, no copy): its ``.T``
    is C-contiguous, which is how :meth:`rig_env.envs.sensors.Sensors.update` reads it (a transposing
    copy of 1024 environments' seven channels cost 5.6 us, a sixth of the draw)."""
    keys, ep, st = _counters(keys, episode, step)
    m = keys.shape[0]
    with np.errstate(over="ignore"):
        code = np.uint64(stream) * _C_STREAM
    outT = np.empty((k, m))
    if m >= NORMAL_PARALLEL_MIN:  # one row of hash scratch per block (the blocks run at once)
        _normal_kernel_parallel(keys, ep, st, code, outT, np.empty(((m + NORMAL_BLOCK - 1) // NORMAL_BLOCK, NORMAL_BLOCK), dtype=np.uint64))
    else:
        _normal_kernel(keys, ep, st, code, outT, np.empty((1, NORMAL_BLOCK), dtype=np.uint64))
    return outT.T
