"""numba kernels of the rig model.  Import-time side effects: a source-keyed numba cache directory, and
a compile-time fix for numba's IR inliner (:mod:`rig_env.physics.fast_inline`; ``RIG_ENV_FAST_INLINE=0``
turns it off).

numba's on-disk cache (``cache=True``) checks only the source file of the function it compiled, not
the files of the functions it inlined: after an edit to ``aero.py`` a cached ``integrator.step_batch``
would still run the old aerodynamics.  Unless the user sets ``NUMBA_CACHE_DIR`` themselves, the
kernels therefore cache under a directory named by a hash of every source file of this package, so
any change to the physics invalidates every cached kernel at once.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba

from rig_env.physics import fast_inline


def _cache_dir() -> str:
    digest = hashlib.sha256()
    for path in sorted(Path(__file__).parent.glob("*.py")):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    digest.update(numba.__version__.encode())
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "rig_env"
    return str(base / f"numba-{digest.hexdigest()[:16]}")


if not os.environ.get("NUMBA_CACHE_DIR"):
    numba.config.CACHE_DIR = _cache_dir()

if os.environ.get("RIG_ENV_FAST_INLINE", "1") != "0":
    fast_inline.install()
