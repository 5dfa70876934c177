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
"""

from __future__ import annotations

import numpy as np

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


def uniform(keys: np.ndarray, episode: np.ndarray, step: np.ndarray | int, stream: int, k: int) -> np.ndarray:
    """(m, k) uniforms in [0, 1) for m environments (keys, episode, step of shape (m,) or scalar)."""
    with np.errstate(over="ignore"):
        base = (
            keys.astype(np.uint64)
            ^ (np.asarray(episode, dtype=np.uint64) * _C_EP)
            ^ (np.asarray(step, dtype=np.uint64) * _C_STEP)
            ^ (np.uint64(stream) * _C_STREAM)
        )
        x = _mix(_mix(base)[:, None] + (np.arange(1, k + 1, dtype=np.uint64) * _GOLD)[None, :])
    return (x >> np.uint64(11)).astype(np.float64) * (1.0 / 9007199254740992.0)


def normal(keys: np.ndarray, episode: np.ndarray, step: np.ndarray | int, stream: int, k: int) -> np.ndarray:
    """(m, k) standard normals (Box-Muller on 2k uniforms of the same stream)."""
    u = uniform(keys, episode, step, stream, 2 * k)
    u1 = 1.0 - u[:, :k]  # (0, 1]
    return np.sqrt(-2.0 * np.log(u1)) * np.cos(2.0 * np.pi * u[:, k:])
