"""Joint accelerations of the joint-space model at given states: the equation-error regressors' source.

:func:`accelerations_at` evaluates ``M(q) qdd + h(q, qd) = Q(q, qd, z, flaps, u)`` (the model every
kernel integrates, :func:`rig_env.physics.joint_space.accelerations`) at a sequence of states, one
parameter row for all of them: equation-error identification compares these with accelerations
differentiated from a record.
"""

from __future__ import annotations

import numpy as np

from numba import njit

from rig_env.physics.joint_space import ATTACHED, accelerations

_JIT = {"cache": True, "error_model": "numpy"}


@njit(**_JIT)
def accelerations_at(q, qd, z, flaps, u, p, flags, free_idx, n_free, tabs, out):
    """Joint accelerations out (n, 5), rad/s^2, at n states.

    q, qd, z: (n, 5) joint angles (rad), rates (rad/s) and LuGre bristle states (rad); flaps: (n, 7)
    servo positions (rad, rig_env.SERVOS order); u: (n, N_INPUTS) inputs; p: (N_PARAMS,) one parameter
    row; flags: feature flags; free_idx: (n_free,) free joints; tabs: aerodynamic tables.  Locked
    joints get zero acceleration.
    """
    M = np.zeros((5, 5))
    hvec = np.zeros(5)
    Q = np.zeros(5)
    jv = np.zeros(45)
    acc = np.zeros(5)
    for i in range(q.shape[0]):
        accelerations(q[i], qd[i], z[i], ATTACHED, flaps[i], u[i], p, flags, free_idx, n_free, tabs, M, hvec, Q, jv, acc)
        for j in range(5):
            out[i, j] = acc[j]


def joint_accelerations(q: np.ndarray, qd: np.ndarray, flaps: np.ndarray, u: np.ndarray, p: np.ndarray, flags: int,
                        free_idx: np.ndarray, tabs: tuple[np.ndarray, ...], z: np.ndarray | None = None) -> np.ndarray:
    """(n, 5) joint accelerations, rad/s^2, at n states (see :func:`accelerations_at`; z None: zero bristles)."""
    n = q.shape[0]
    out = np.empty((n, 5))
    zz = np.zeros((n, 5)) if z is None else np.ascontiguousarray(z, dtype=np.float64)
    fi = np.ascontiguousarray(free_idx, dtype=np.int64)
    accelerations_at(np.ascontiguousarray(q, dtype=np.float64), np.ascontiguousarray(qd, dtype=np.float64), zz,
                     np.ascontiguousarray(flaps, dtype=np.float64), np.ascontiguousarray(u, dtype=np.float64),
                     np.ascontiguousarray(p, dtype=np.float64), int(flags), fi, int(fi.size), tabs, out)
    return out

